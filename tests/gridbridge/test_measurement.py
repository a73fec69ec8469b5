"""Measurement update (eqs. 12-14): hand-computed values, fields of view, soft detections."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from gridbridge import (
    PAPER_DETECTORS,
    DetectorModel,
    GridSpec,
    bayes_update,
    detection_map,
    fov_mask,
    fuse_detectors,
    likelihood_from_detections,
    rasterise,
)
from gridbridge.reference import fuse_and_update_loop

PPV = np.array([0.95, 0.50, 0.95])
FNR = np.array([0.30, 0.40, 0.50])


def cell(values: list[bool | float]) -> np.ndarray:
    return np.array(values, dtype=float).reshape(3, 1, 1)


def test_table1_hand_values() -> None:
    # Detectors 1 and 3 fire, 2 does not: 1 - (1 - 0.95)(1 - 0.40)(1 - 0.95) = 0.9985.
    assert fuse_detectors(cell([1, 0, 1]), PPV, FNR)[0, 0] == pytest.approx(0.9985, abs=1e-15)
    # Nobody fires: min FNR = 0.30 (eq. 14).
    assert fuse_detectors(cell([0, 0, 0]), PPV, FNR)[0, 0] == pytest.approx(0.30, abs=1e-15)
    # Only detector 2 fires: 1 - 0.5 * 0.7 * 0.5 = 0.825.
    assert fuse_detectors(cell([0, 1, 0]), PPV, FNR)[0, 0] == pytest.approx(0.825, abs=1e-15)


def test_update_multiplies_odds_by_likelihood_ratio() -> None:
    prior = np.array([[0.1, 0.5, 0.97]])
    for lik in (0.9985, 0.30):
        post = bayes_update(prior, np.full_like(prior, lik))
        np.testing.assert_allclose(post / (1 - post), prior / (1 - prior) * lik / (1 - lik), rtol=1e-12)
    assert bayes_update(np.array([[0.5]]), np.array([[0.3]]))[0, 0] == pytest.approx(0.3)


def test_vectorised_fusion_and_update_equal_the_loop() -> None:
    rng = np.random.default_rng(11)
    fired = rng.random((3, 8, 6)) < 0.3
    prior = rng.random((8, 6))
    fast = bayes_update(prior, fuse_detectors(fired, PPV, FNR))
    np.testing.assert_allclose(fast, fuse_and_update_loop(prior, fired, PPV, FNR), rtol=1e-13)


def test_degenerate_update_keeps_prior() -> None:
    post = bayes_update(np.array([[0.0, 1.0]]), np.array([[1.0, 0.0]]))
    np.testing.assert_array_equal(post, [[0.0, 1.0]])


def test_soft_firing_is_the_expectation_over_firing_events() -> None:
    rng = np.random.default_rng(5)
    q = rng.random((3, 4, 4))
    fused = fuse_detectors(q, PPV, FNR)
    ref = np.zeros((4, 4))
    for config in itertools.product((0, 1), repeat=3):
        f = np.array(config, dtype=bool)
        prob = np.prod([q[i] if f[i] else 1 - q[i] for i in range(3)], axis=0)
        lik = 1 - np.prod(np.where(f, 1 - PPV, 1 - FNR)) if f.any() else FNR.min()
        ref += prob * lik
    np.testing.assert_allclose(fused, ref, rtol=1e-12)


def test_fields_of_view() -> None:
    fired = cell([0, 0, 1]) * np.ones((3, 1, 2))
    covered = np.array([[[True, False]], [[True, False]], [[True, False]]])
    fused = fuse_detectors(fired, PPV, FNR, covered=covered)
    assert fused[0, 0] == pytest.approx(1 - 0.7 * 0.6 * 0.05)
    assert fused[0, 1] == 0.5  # seen by nobody: L = 0.5 leaves the belief unchanged
    assert bayes_update(np.array([[0.2]]), fused[:, 1:])[0, 0] == pytest.approx(0.2)
    # Only detector 3 covers a cell and does not fire there: its FNR is the min over covering detectors.
    covered = np.array([[[False]], [[False]], [[True]]])
    assert fuse_detectors(cell([0, 0, 0]), PPV, FNR, covered=covered)[0, 0] == pytest.approx(0.5)
    assert fuse_detectors(cell([0, 0, 0]), PPV, FNR * 0 + 0.2, covered=covered)[0, 0] == pytest.approx(0.2)


def test_camera_fov_is_62_degrees() -> None:
    spec = GridSpec()
    cam = fov_mask(spec, PAPER_DETECTORS[2])
    gx, gy = spec.cell_centres()
    bearing = np.degrees(np.arctan2(gy, gx))
    assert cam[np.abs(bearing) < 30.5].all() and not cam[np.abs(bearing) > 31.5].any()
    assert fov_mask(spec, PAPER_DETECTORS[0]).all()  # 180 deg laser in front sees the whole grid
    short = DetectorModel(name="short", ppv=0.9, fnr=0.2, max_range=3.0)
    assert not fov_mask(spec, short)[np.hypot(gx, gy) > 3.0].any()


def test_point_and_gaussian_detection_maps() -> None:
    spec = GridSpec()
    laser = detection_map(spec, PAPER_DETECTORS[0], [[3.0, 0.1], [20.0, 0.0]])
    assert laser.sum() == 1.0 and laser[10, 15] == 1.0  # the far detection is outside the grid
    wide = DetectorModel(name="wide", ppv=0.9, fnr=0.3, footprint_radius=0.31)
    assert detection_map(spec, wide, [[3.15, 0.15]]).sum() == 5.0  # the cell and its 4 neighbours
    odd = GridSpec(nx=30, ny=31, y0=-4.65)  # a row of cell centres on the x axis (j = 15)
    cam = PAPER_DETECTORS[2]
    assert detection_map(odd, cam, [[4.35, 0.0]])[14, 15] == pytest.approx(1.0)
    # 1.8 m along the line of sight (range sd 1.7 m) and 1.2 m across it (lateral sd 1.0 m).
    assert detection_map(odd, cam, [[2.55, 0.0]])[14, 15] == pytest.approx(math.exp(-0.5 * (1.8 / 1.7) ** 2))
    assert detection_map(odd, cam, [[4.35, 0.0]])[14, 19] == pytest.approx(math.exp(-0.5 * 1.2**2))
    # Beyond 3 sd the camera does not fire.
    assert detection_map(odd, cam, [[4.35, 0.0]])[14, 15 + 11] == 0.0


def test_likelihood_from_detections_and_missing_detector() -> None:
    spec = GridSpec()
    lik = likelihood_from_detections(spec, PAPER_DETECTORS, [[[3.0, 0.1]], np.zeros((0, 2)), None])
    assert lik.likelihood[10, 15] == pytest.approx(1 - 0.05 * 0.6)  # camera had no data: not covered
    assert lik.likelihood[0, 0] == pytest.approx(0.30)
    assert not lik.covered[2].any() and (lik.detector_likelihoods[2] == 0.5).all()


def test_rasterise_sums_weights_per_cell() -> None:
    spec = GridSpec()
    grid = rasterise(spec, [[0.1, 0.0], [0.2, 0.05], [8.9, -4.4], [-1.0, 0.0]], [0.25, 0.5, 0.1, 9.0])
    assert grid[0, 15] == pytest.approx(0.75) and grid[29, 0] == pytest.approx(0.1)
    assert grid.sum() == pytest.approx(0.85)


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: fuse_detectors(np.ones((3, 2, 2)), PPV[:2], FNR), "ppv"),
        (lambda: fuse_detectors(np.full((3, 2, 2), 1.5), PPV, FNR), "fired"),
        (lambda: fuse_detectors(np.ones((3, 2, 2)), PPV, FNR, covered=np.ones((3, 2, 2))), "covered"),
        (lambda: bayes_update(np.full((2, 2), np.nan), np.ones((2, 2))), "prior"),
        (lambda: bayes_update(np.ones((2, 2)), np.ones((2, 3))), "shapes"),
        (lambda: detection_map(GridSpec(), PAPER_DETECTORS[0], [[np.nan, 0.0]]), "laser_legs"),
        (lambda: likelihood_from_detections(GridSpec(), PAPER_DETECTORS, [[]]), "one entry per detector"),
        (lambda: DetectorModel(name="x", ppv=1.2, fnr=0.1), "ppv"),
        (lambda: DetectorModel(name="x", ppv=0.9, fnr=0.1, uncertainty="box"), "uncertainty"),  # type: ignore[arg-type]
    ],
)
def test_bad_input(call: object, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        call()  # type: ignore[operator]
