"""Resamplers: filterpy equality on the same offsets, unbiased offspring counts, round-off guard, cell masses."""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.monte_carlo import stratified_resample, systematic_resample
from scipy import stats

from pfpeople.particle.resampler.by_cell import resample_by_cell
from pfpeople.particle.resampler.schemes import (
    RESAMPLERS,
    effective_sample_size,
    get_resampler,
    stratified,
    systematic,
)


@pytest.mark.parametrize("seed", [0, 1, 2, 3, 4])
def test_systematic_matches_filterpy_on_same_offset(seed: int) -> None:
    w = np.random.default_rng(seed).random(500) ** 3
    w /= w.sum()
    # filterpy draws its offset from the global RNG: read the same number for ours (reference only).
    np.random.seed(seed)  # noqa: NPY002
    u = np.random.random()  # noqa: NPY002
    np.random.seed(seed)  # noqa: NPY002
    expected = systematic_resample(w)
    np.testing.assert_array_equal(systematic(w, u=u), expected)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_stratified_matches_filterpy_on_same_offsets(seed: int) -> None:
    w = np.random.default_rng(100 + seed).random(400) ** 2
    w /= w.sum()
    np.random.seed(seed)  # noqa: NPY002
    u = np.random.random(len(w))  # noqa: NPY002
    np.random.seed(seed)  # noqa: NPY002
    expected = stratified_resample(w)
    np.testing.assert_array_equal(stratified(w, u=u), expected)


@pytest.mark.parametrize("name", sorted(RESAMPLERS))
def test_offspring_counts_match_n_w_in_expectation(name: str) -> None:
    # Sum of offspring over R runs ~ R n W_i; chi-square test at alpha = 1e-3 (fixed seed). For the low-variance
    # schemes the statistic is far below the multinomial reference, which is still a valid upper test.
    rng = np.random.default_rng(7)
    w = np.array([0.05, 0.1, 0.15, 0.2, 0.2, 0.3])
    n, runs = 60, 400
    total = np.zeros(w.size)
    fn = get_resampler(name)
    for _ in range(runs):
        total += np.bincount(fn(w, n, rng=rng), minlength=w.size)
    expected = runs * n * w
    chi2 = float(((total - expected) ** 2 / expected).sum())
    assert chi2 < stats.chi2.ppf(1 - 1e-3, df=w.size - 1)
    assert total.sum() == runs * n


@pytest.mark.parametrize("name", sorted(RESAMPLERS))
def test_no_index_error_when_weights_sum_below_one(name: str) -> None:
    w = np.full(1000, (1.0 - 1e-12) / 1000)
    w[-1] = 0.0  # the last particle has no weight: it must still be safe
    rng = np.random.default_rng(3)
    for _ in range(20):
        a = RESAMPLERS[name](w, 1000, rng=rng)
        assert a.shape == (1000,)
        assert a.min() >= 0 and a.max() <= 999


def test_systematic_offset_near_one_stays_in_range() -> None:
    w = np.full(10, 0.1 - 1e-13)
    a = systematic(w, u=np.nextafter(1.0, 0.0))
    assert a.shape == (10,) and a.max() <= 9


def test_unknown_resampler_and_bad_weights_raise() -> None:
    with pytest.raises(ValueError, match="resampler must be one of"):
        get_resampler("bogus")
    with pytest.raises(ValueError, match="weights contain NaN"):
        systematic(np.array([0.5, np.nan]), u=0.5)
    with pytest.raises(ValueError, match="non-negative with a positive sum"):
        systematic(np.array([0.0, 0.0]), u=0.5)
    with pytest.raises(ValueError, match="rng"):
        stratified(np.array([0.5, 0.5]))
    with pytest.raises(ValueError, match="u must lie"):
        systematic(np.array([0.5, 0.5]), u=1.0)


def test_ess() -> None:
    assert effective_sample_size(np.full(10, 0.3)) == pytest.approx(10.0)
    assert effective_sample_size(np.array([1.0, 0.0, 0.0])) == pytest.approx(1.0)


@pytest.mark.parametrize("name", sorted(RESAMPLERS))
def test_resample_by_cell_keeps_cell_mass_and_count(name: str) -> None:
    rng = np.random.default_rng(11)
    n_cells, n_part = 50, 3000
    cells = rng.integers(0, n_cells, size=n_part)
    w = rng.random(n_part) ** 4 * 0.01
    w[cells == 7] *= 1e-6  # a cell with tiny mass must keep a particle
    w[cells == 9] = 0.0  # a cell without mass may lose its particles
    before = np.bincount(cells, weights=w, minlength=n_cells)
    anc, new_w = resample_by_cell(cells, w, 2000, n_cells=n_cells, rng=rng, resampler=name)
    assert anc.shape == (2000,) and new_w.shape == (2000,)
    after = np.bincount(cells[anc], weights=new_w, minlength=n_cells)
    np.testing.assert_allclose(after, before, rtol=1e-12, atol=0.0)
    counts = np.bincount(cells[anc], minlength=n_cells)
    assert np.all(counts[before > 0] >= 1)
    assert counts[9] == 0


def test_resample_by_cell_bad_input() -> None:
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="cannot keep one"):
        resample_by_cell(np.arange(5), np.ones(5), 3, n_cells=5, rng=rng)
    with pytest.raises(ValueError, match="weights must be finite"):
        resample_by_cell(np.arange(2), np.array([1.0, np.nan]), 3, n_cells=5, rng=rng)
    with pytest.raises(ValueError, match="resampler must be one of"):
        resample_by_cell(np.arange(2), np.ones(2), 3, n_cells=5, rng=rng, resampler="nope")
