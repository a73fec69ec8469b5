"""Scored detections: an ``(M, 3)`` entry carries each detection's own PPV into eqs. 13-14 and the independent fusion.

References: hand-computed odds, a brute-force per-cell loop over the detections' own maps, and the constant-PPV
fusion (a column equal to the detector's PPV gives it bit for bit).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gridbridge import GridFilter, GridSpec, jit
from gridbridge.likelihoods import DeMorganLikelihood, IndependentLikelihood
from gridbridge.measurement import bayes_update, detection_map, detection_ppv_map, split_detections
from gridbridge.params import DetectorModel
from pfpeople import ParticleFilter

SPEC = GridSpec()
LASER = DetectorModel(name="learned", ppv=0.7, fnr=0.55, footprint_radius=0.2)
OTHER = DetectorModel(name="legs", ppv=0.8, fnr=0.6)
CAM = DetectorModel(name="cam", ppv=0.9, fnr=0.5, uncertainty="gaussian", sigma_lateral=0.4, sigma_range=0.7)


def test_one_scored_detection_gives_its_own_ppv_at_the_base_rate() -> None:
    base = 0.02
    dets = np.array([[3.05, 0.05, 0.95], [5.05, -1.15, 0.55]])
    lik = IndependentLikelihood(base_rate=base)(SPEC, (LASER,), [dets])
    post = bayes_update(np.full(SPEC.shape, base), lik.likelihood)
    assert post[SPEC.to_cell(3.05, 0.05)] == pytest.approx(0.95, rel=1e-12)
    assert post[SPEC.to_cell(5.05, -1.15)] == pytest.approx(0.55, rel=1e-12)
    # a cell nobody fired in: the detector's miss, as without scores
    assert lik.likelihood[0, 0] / (1 - lik.likelihood[0, 0]) == pytest.approx(0.55, rel=1e-12)


def test_de_morgan_uses_the_detection_ppv_where_it_fired() -> None:
    """Eq. 13 with PPV_1 the detection's: L = 1 - (1 - 0.93)(1 - FNR_2) where the scored detector fires and the other
    covers the cell without firing; eq. 14 (min FNR) where nobody fires."""
    dets = [np.array([[3.05, 0.05, 0.93]]), np.zeros((0, 2))]
    lik = DeMorganLikelihood()(SPEC, (LASER, OTHER), dets)
    assert lik.likelihood[SPEC.to_cell(3.05, 0.05)] == pytest.approx(1 - (1 - 0.93) * (1 - 0.6), rel=1e-12)
    assert lik.detector_likelihoods[0][SPEC.to_cell(3.05, 0.05)] == pytest.approx(0.93, rel=1e-12)
    assert lik.likelihood[0, 0] == pytest.approx(0.55, rel=1e-12)


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("component", [DeMorganLikelihood(), IndependentLikelihood(base_rate=0.02)])
@pytest.mark.parametrize("model", [LASER, CAM])
def test_a_column_of_the_detector_ppv_is_the_constant_fusion(compiled: bool, component: object, model: object) -> None:
    pts = np.array([[3.0, 0.4], [3.2, 0.6], [6.1, -2.0]])
    scored = np.column_stack([pts, np.full(len(pts), model.ppv)])  # type: ignore[attr-defined]
    with jit.override(compiled):
        plain = component(SPEC, (model, OTHER), [pts, pts[:1]])  # type: ignore[operator]
        own = component(SPEC, (model, OTHER), [scored, pts[:1]])  # type: ignore[operator]
    np.testing.assert_allclose(own.likelihood, plain.likelihood, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(own.fired, plain.fired)
    np.testing.assert_array_equal(own.covered, plain.covered)


def _brute_ppv_map(model: DetectorModel, pts: np.ndarray, ppv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per cell, over every detection's own map: the largest weight, and of the detections with it the largest PPV."""
    maps = [detection_map(SPEC, model, p[None, :]) for p in pts]
    fired, out = np.zeros(SPEC.shape), np.full(SPEC.shape, model.ppv)
    for i in range(SPEC.nx):
        for j in range(SPEC.ny):
            w = np.array([m[i, j] for m in maps])
            if w.size == 0 or w.max() <= 0.0:
                continue
            fired[i, j] = w.max()
            out[i, j] = max(p for p, ww in zip(ppv, w, strict=True) if ww == w.max())
    return fired, out


@settings(max_examples=25, deadline=None)
@given(
    st.lists(
        st.tuples(st.floats(1.0, 7.0), st.floats(-3.0, 3.0), st.floats(0.05, 0.95).map(lambda v: round(v, 2))),
        min_size=1,
        max_size=5,
    ),
    st.sampled_from([LASER, CAM]),
)
def test_ppv_map_is_the_brute_force_rule(rows: list[tuple[float, float, float]], model: DetectorModel) -> None:
    arr = np.array(rows)
    arr[1::2, :2] = arr[0, :2] + 0.1  # overlapping footprints, some tied in weight
    fired, ppv_map = detection_ppv_map(SPEC, model, arr[:, :2], arr[:, 2])
    ref_fired, ref_map = _brute_ppv_map(model, arr[:, :2], arr[:, 2])
    np.testing.assert_array_equal(fired, ref_fired)
    np.testing.assert_array_equal(ppv_map, ref_map)
    np.testing.assert_array_equal(fired, detection_map(SPEC, model, arr[:, :2]))


def test_bad_scores_are_named_and_change_no_filter() -> None:
    with pytest.raises(ValueError, match=r"learned.*third column"):
        split_detections(np.array([[3.0, 0.0, 1.0]]), "detections of learned")
    with pytest.raises(ValueError, match=r"learned.*third column"):
        split_detections(np.array([[3.0, 0.0, np.nan]]), "detections of learned")
    assert split_detections(np.zeros((0, 3)), "x")[1] is None
    for f in (
        GridFilter(SPEC, detectors=(LASER,)),
        ParticleFilter(SPEC, detectors=(LASER,), n_particles=2000, rng=np.random.default_rng(0)),
    ):
        before = np.array(f.belief, copy=True)
        with pytest.raises(ValueError, match="third column"):
            f.update([np.array([[3.0, 0.0, 0.0]])])
        np.testing.assert_array_equal(np.asarray(f.belief), before)


def test_both_filters_see_a_confident_detection_more_than_a_doubtful_one() -> None:
    """One update from the base rate, the two filters: each detection's cell ends at its own PPV (the grid filter
    and the particle filter, whose update reweights each cell's particles by the cell's likelihood ratio)."""
    a, b = (2.05, 1.05), (2.05, -1.05)
    dets = [np.array([[*a, 0.95], [*b, 0.6]])]
    lik = IndependentLikelihood(base_rate=0.02)
    grid = GridFilter(SPEC, detectors=(LASER,), likelihood=lik, initial=0.02)
    particles = ParticleFilter(
        SPEC, detectors=(LASER,), likelihood=lik, initial=0.02, n_particles=5000, rng=np.random.default_rng(1)
    )
    g = np.asarray(grid.update(dets).posterior)
    assert g[SPEC.to_cell(*a)] == pytest.approx(0.95, rel=1e-12)
    assert g[SPEC.to_cell(*b)] == pytest.approx(0.6, rel=1e-12)
    p = np.asarray(particles.update(dets).posterior)
    assert p[SPEC.to_cell(*a)] == pytest.approx(0.95, rel=1e-9)
    assert p[SPEC.to_cell(*b)] == pytest.approx(0.6, rel=1e-9)
