"""Issue 46, finding 14: the limits a run's configuration is held to hold in the library too, and one filter step
within them is bounded in memory and work.

Before: ``GridFilter`` on 30 x 30 took 1.6 GB at ``dt = 3`` and 4.3 GB at 4 (the paper kernel's table of ``q / (1 - q)``
per distinct tap value, the integrated kernel's dense tents), ``ParticleFilter`` 4.5 GB at ``dt = 5`` (scipy's
convolution of the border with a kernel larger than the grid), and ``GridSpec(nx=10**5, ny=10**5)`` reached numpy's
own MemoryError. Memory is measured here with ``tracemalloc`` (numpy's allocations) where the old code allocated
with numpy; timings are left to ``python -m evaluation.bench.step_limits``.
"""

from __future__ import annotations

import math
import tracemalloc

import numpy as np
import pytest
from scipy import ndimage

from gridbridge import jit, kernels, people_motion
from gridbridge.filter import GridFilter
from gridbridge.grid import GridSpec
from gridbridge.limits import ResourceLimitError
from gridbridge.params import PeopleMotion
from pfpeople.config import config_from_mapping
from pfpeople.particle.filter import ParticleFilter

CELLS = r"GridSpec: 100000 x 100000 = 10000000000 cells is more than the limit of 4000000 cells"


def test_a_grid_beyond_the_cell_limit_is_refused_by_gridspec_with_the_configs_message() -> None:
    with pytest.raises(ResourceLimitError, match=CELLS):
        GridSpec(nx=10**5, ny=10**5)
    with pytest.raises(ResourceLimitError, match=CELLS):
        config_from_mapping(
            {
                "frames": {"driver": "/scan"},
                "detectors": [{"name": "l", "kind": "leg", "topic": "/scan"}],
                "grid": {"nx": 10**5, "ny": 10**5, "x0": 0.0, "y0": 0.0},
            }
        )


def test_the_filters_refuse_a_resolution_whose_step_is_too_costly_as_the_config_does() -> None:
    spec = GridSpec(nx=300, ny=300, resolution=0.01)
    with pytest.raises(ResourceLimitError, match=r"GridFilter: resolution 0.01 m .* motion neighbourhood of 106 cells"):
        GridFilter(spec)
    with pytest.raises(ResourceLimitError, match=r"resolution 0.01 m .* motion neighbourhood of 106 cells"):
        ParticleFilter(spec, n_particles=10**5, rng=np.random.default_rng(0))


def test_a_grid_filter_beyond_the_memory_budget_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("PFPEOPLE_MAX_MEMORY_BYTES", str(2**20))
    with pytest.raises(ResourceLimitError, match=r"GridFilter: the requested run needs about .* more than the budget"):
        GridFilter(GridSpec(nx=100, ny=100))


@pytest.mark.parametrize("kind", ["grid", "particle"])
def test_a_step_whose_motion_is_too_costly_is_refused_before_anything_changes(kind: str) -> None:
    spec = GridSpec(nx=200, ny=200)
    filt = (
        GridFilter(spec) if kind == "grid" else ParticleFilter(spec, n_particles=40_000, rng=np.random.default_rng(0))
    )
    before = filt.belief.copy()
    state = getattr(filt, "state", None)
    draws = filt.rng.bit_generator.state if kind == "particle" else None
    dets = [np.zeros((0, 2))] * len(filt.detectors)
    with pytest.raises(ResourceLimitError, match=r"people motion over 10 s: .* neighbourhood of 349 cells radius"):
        filt.step(dets, None, 10.0)
    np.testing.assert_array_equal(filt.belief, before)
    if kind == "particle":  # not a particle moved, not a number drawn
        assert filt.state is state and filt.rng.bit_generator.state == draws


def test_the_integrated_kernel_of_a_long_step_takes_memory_linear_in_its_quadrature() -> None:
    """The dense tents took ``points x (2R + 1)`` floats three times: 1.7 GB at ``dt = 3`` (0.3 m cells)."""
    people_motion._kernel_cached.cache_clear()
    tracemalloc.start()
    try:
        kernel = people_motion.people_motion_kernel(GridSpec(), dt=3.0, form="integrated")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert kernel.shape == (213, 213) and kernel.sum() == pytest.approx(1.0, abs=1e-12)
    assert peak < 100 * 2**20


@pytest.mark.parametrize("dt", [0.1, 0.5])
def test_the_sparse_tents_equal_the_dense_ones(dt: float, monkeypatch: pytest.MonkeyPatch) -> None:
    motion = PeopleMotion()
    dense = people_motion._integrated_kernel(0.3, motion, dt)
    monkeypatch.setattr(people_motion, "_DENSE_TENT_ENTRIES", 0)
    sparse = people_motion._integrated_kernel(0.3, motion, dt)
    np.testing.assert_allclose(sparse, dense, rtol=0, atol=1e-15)


@pytest.mark.parametrize(("dt", "shape"), [(0.1, (30, 30)), (1.0, (30, 30)), (0.5, (7, 40))])
def test_the_paper_prediction_by_tap_is_bit_for_bit_the_one_by_value(dt: float, shape: tuple[int, int]) -> None:
    """The table of ``q / (1 - q)`` per distinct tap value (1.4 GB at 3 s) is replaced by the same division per tap
    and cell for long steps: the same numbers added in the same order."""
    kernel = people_motion._paper_kernel(0.3, PeopleMotion(), dt)
    bel = np.random.default_rng(1).random(shape)
    padded = kernels._padded(bel, kernel.shape[0] // 2, 0.5)
    by_value = kernels._odds_sum_by_value(padded, kernel, *shape)
    by_tap = kernels._odds_sum_by_tap(padded, kernel, *shape)
    assert by_value.tobytes() == by_tap.tobytes()


@pytest.mark.parametrize("form", ["paper", "linear"])
def test_a_ten_second_step_of_the_grid_filter_agrees_with_the_numpy_path(form: str) -> None:
    dets = [np.array([[3.0, 0.5]]), np.zeros((0, 2)), None]
    out = {}
    for compiled in (True, False):
        with jit.override(compiled):
            filt = GridFilter(GridSpec(), form=form)  # type: ignore[arg-type]
            filt.step(dets, (0.5, 0.1), 0.1)
            out[compiled] = filt.step(dets, (0.5, 0.1), 10.0).posterior
    np.testing.assert_allclose(out[True], out[False], rtol=0, atol=1e-12)
    assert np.isfinite(out[True]).all()


@pytest.mark.parametrize(("dt", "shape"), [(1.0, (7, 20)), (3.0, (30, 30)), (10.0, (30, 30))])
def test_the_particle_filters_border_inflow_for_a_kernel_beyond_the_grid(dt: float, shape: tuple[int, int]) -> None:
    """scipy's convolution with a kernel larger than the grid took 850 MB and 2 s at 10 s; the summed-area table
    gives the same inflow to round-off."""
    kernel = people_motion._integrated_kernel(0.3, PeopleMotion(), dt)
    assert kernel.shape[0] > 2 * max(shape) + 1
    ref = ndimage.convolve(np.zeros(shape), kernel, mode="constant", cval=0.5)
    np.testing.assert_allclose(people_motion.outside_inflow(shape, kernel, 0.5), ref, rtol=0, atol=1e-12)


def test_a_ten_second_particle_step_runs_within_the_limits() -> None:
    filt = ParticleFilter(GridSpec(), n_particles=10_000, rng=np.random.default_rng(0))
    dets = [np.array([[3.0, 0.5]]), np.zeros((0, 2)), None]
    filt.step(dets, (0.5, 0.1), 0.1)
    step = filt.step(dets, (0.5, 0.1), 10.0)
    assert np.isfinite(step.posterior).all() and math.isclose(filt.belief.max(), step.posterior.max())


def test_the_numpy_linear_prediction_of_a_kernel_beyond_the_grid_equals_scipys() -> None:
    kernel = people_motion._integrated_kernel(0.3, PeopleMotion(), 3.0)
    bel = np.random.default_rng(2).random((30, 30))
    with jit.override(False):
        got = people_motion.predict_people(bel, kernel, outside=0.5, form="linear")
    ref = np.clip(ndimage.convolve(bel, kernel, mode="constant", cval=0.5), 0.0, 1.0)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
