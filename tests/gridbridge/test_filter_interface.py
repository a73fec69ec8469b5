"""The one filter interface (gridbridge.filter.BeliefFilter): predict + update is step, bit for bit."""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from gridbridge import GridFilter, GridSpec, Odometry
from gridbridge.filter import BeliefFilter, FilterStep, Prediction
from pfpeople.config import FilterConfig
from pfpeople.particle.filter import ParticleFilter, ParticleStep
from pfpeople.pipeline.assembly import build_filter

SPEC = GridSpec()
DETS = [np.array([[3.0, 0.5], [5.0, -1.0]]), None, np.array([[4.0, 0.0]])]
FRAMES = [(DETS, None, 0.1), (DETS, Odometry(v=0.6, omega=0.3), 0.1), ([None, None, None], (0.4, -0.2), 0.15)]


def _filters(kind: str, seed: int) -> list[Any]:
    """The paper and the recommended filter of ``kind`` (particle filters with the same seed)."""
    from gridbridge import PAPER_DETECTORS

    return [
        build_filter(FilterConfig(kind=kind, mode=mode, seed=seed, n_particles=2000), SPEC, PAPER_DETECTORS)
        for mode in ("paper", "recommended")
    ]


def _equal(a: FilterStep, b: FilterStep) -> None:
    for name in ("people_prior", "sensor_prior", "fired", "covered", "detector_likelihoods", "likelihood", "posterior"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    if isinstance(a, ParticleStep):
        assert isinstance(b, ParticleStep) and a.resampled == b.resampled
        for name in ("x", "y", "vx", "vy", "w"):
            np.testing.assert_array_equal(getattr(a.particles, name), getattr(b.particles, name), err_msg=name)


@pytest.mark.parametrize("kind", ["grid", "particle"])
def test_predict_then_update_is_step_bit_for_bit(kind: str, caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.ERROR, logger="pfpeople.pipeline.assembly"):  # the paper mode's FNR warning
        stepped, split = _filters(kind, 3), _filters(kind, 3)
    for one, two in zip(stepped, split, strict=True):
        assert isinstance(one, BeliefFilter)
        for dets, odo, dt in FRAMES:
            ref = one.step(dets, odo, dt)
            pred = two.predict(odo, dt)
            assert isinstance(pred, Prediction)
            np.testing.assert_array_equal(pred.people_prior, ref.people_prior)
            np.testing.assert_array_equal(pred.sensor_prior, ref.sensor_prior)
            _equal(ref, two.update(dets))
            np.testing.assert_array_equal(one.belief, two.belief)


@pytest.mark.parametrize("make", [lambda: GridFilter(SPEC), lambda: ParticleFilter(SPEC, rng=np.random.default_rng(0))])
def test_update_without_predict_updates_the_current_belief(make: Callable[[], Any]) -> None:
    flt = make()
    out = flt.update(DETS)
    np.testing.assert_allclose(out.sensor_prior, 0.5, rtol=1e-12)
    np.testing.assert_allclose(out.people_prior, out.sensor_prior, rtol=0)
    assert out.posterior[SPEC.to_cell(4.0, 0.0)] > 0.5 > out.posterior[SPEC.to_cell(8.0, 4.0)]
    np.testing.assert_array_equal(flt.belief, out.posterior)


@pytest.mark.parametrize("make", [lambda: GridFilter(SPEC), lambda: ParticleFilter(SPEC, rng=np.random.default_rng(0))])
def test_predict_makes_the_belief_the_prior_and_bad_detections_change_nothing(make: Callable[[], Any]) -> None:
    flt = make()
    pred = flt.predict(Odometry(v=0.5, omega=0.1), 0.1)
    np.testing.assert_allclose(flt.belief, np.clip(pred.sensor_prior, 0.0, 1.0), rtol=0)
    before = flt.belief.copy()
    with pytest.raises(ValueError):
        flt.update([np.array([[np.nan, 0.0]]), None, None])
    np.testing.assert_array_equal(flt.belief, before)
    flt.update(DETS)  # the pending prediction is still there
    with pytest.raises(ValueError, match="dt"):
        flt.predict(None, 0.0)


def test_zero_total_weight_skips_resampling_with_a_warning_and_a_count(caplog: pytest.LogCaptureFixture) -> None:
    pf = ParticleFilter(SPEC, n_particles=2000, rng=np.random.default_rng(0), initial=0.0, outside=0.0)
    with caplog.at_level(logging.WARNING, logger="pfpeople.particle.filter"):
        out = pf.step(DETS, None, 0.1)
        pf.step(DETS, None, 0.1)
    assert not out.resampled and pf.resampling_skipped == 2
    assert "resampling skipped (2 steps so far)" in caplog.text
    assert pf.belief.max() == 0.0
