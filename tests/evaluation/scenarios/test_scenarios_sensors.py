"""Simulated detectors: field of view, misses, clutter, noise shape, laser occlusion."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from evaluation.scenarios import SimulatedDetector, clutter_for_ppv, occluded, paper_simulated_detectors
from evaluation.scenarios.simulated_detectors import in_field_of_view, simulate_detections
from gridbridge.grid import GridSpec
from gridbridge.params import PAPER_DETECTORS

SPEC = GridSpec()


def _perfect(det: SimulatedDetector) -> SimulatedDetector:
    """The same detector with no misses, no clutter and no noise."""
    return dataclasses.replace(det, miss_rate=0.0, clutter_rate=0.0, sigma_lateral=0.0, sigma_range=0.0)


def test_paper_detectors_take_fov_from_gridbridge() -> None:
    sims = paper_simulated_detectors()
    assert [s.model for s in sims] == list(PAPER_DETECTORS)
    laser, _, camera = sims
    assert laser.occlusion and not camera.occlusion
    assert camera.noise == "line_of_sight" and (camera.sigma_lateral, camera.sigma_range) == (1.0, 1.7)
    assert laser.sigma_range == pytest.approx(0.035)
    # clutter rate reproduces the wanted PPV: (1 - m) N / ((1 - m) N + lambda)
    lam = clutter_for_ppv(0.95, 0.3, 3.0)
    assert 0.7 * 3 / (0.7 * 3 + lam) == pytest.approx(0.95)


def test_field_of_view() -> None:
    laser, _, camera = PAPER_DETECTORS
    pts = np.array([[3.0, 0.0], [3.0, 3.0], [0.1, 4.0], [-1.0, 0.0], [3.0, 1.7]])
    # camera: +-31 deg; (3, 1.7) is at 29.5 deg
    np.testing.assert_array_equal(in_field_of_view(camera, pts), [True, False, False, False, True])
    np.testing.assert_array_equal(in_field_of_view(laser, pts), [True, True, True, False, True])


def test_person_directly_behind_another_is_missed_by_the_lasers_only() -> None:
    people = np.array([[3.0, 0.0], [6.0, 0.0], [6.0, 2.0]])
    ids = np.array([10, 11, 12])
    dets = [_perfect(d) for d in paper_simulated_detectors()]
    out = simulate_detections(people, ids, detectors=dets, spec=SPEC, rng=np.random.default_rng(0))
    for laser in out[:2]:
        assert sorted(laser.source.tolist()) == [10, 12]
        assert laser.occluded_ids.tolist() == [11]
        np.testing.assert_allclose(laser.positions[np.argsort(laser.source)], people[[0, 2]])
    camera = out[2]  # sees over people; (6, 2) is inside its 31 deg half-angle (18.4 deg)
    assert sorted(camera.source.tolist()) == [10, 11, 12]
    assert camera.occluded_ids.size == 0


def test_occlusion_fraction_rule() -> None:
    # front person at 3 m (half-angle asin(0.25/3) = 0.0834 rad); the one behind at 6 m (0.0417 rad)
    # lateral 0.3 m: bearing 0.05 rad, 90 % of its interval covered -> occluded
    # lateral 0.6 m: bearing 0.0997 rad, 30 % covered -> visible (threshold 0.5)
    front = [3.0, 0.0]
    assert occluded(np.array([front, [6.0, 0.3]])).tolist() == [False, True]
    assert occluded(np.array([front, [6.0, 0.6]])).tolist() == [False, False]
    assert occluded(np.array([front, [6.0, 0.6]]), threshold=0.25).tolist() == [False, True]
    # two half-covering neighbours together hide a person their union covers
    pair = np.array([[3.0, -0.2], [3.0, 0.2], [6.0, 0.0]])
    assert occluded(pair).tolist() == [False, False, True]
    # nobody hides from behind
    assert occluded(np.array([[6.0, 0.0], [3.0, 0.0]])).tolist() == [True, False]


def test_miss_rate_and_clutter_statistics() -> None:
    det = dataclasses.replace(paper_simulated_detectors()[0], occlusion=False, miss_rate=0.3, clutter_rate=0.8)
    people = np.array([[2.0, -3.0], [4.0, 0.0], [7.0, 3.0]])
    ids = np.arange(3)
    rng = np.random.default_rng(5)
    n = 4000
    hits = clutter = 0
    for _ in range(n):
        (out,) = simulate_detections(people, ids, detectors=[det], spec=SPEC, rng=rng)
        hits += int(np.count_nonzero(out.is_true))
        fp = out.positions[~out.is_true]
        clutter += fp.shape[0]
        assert np.all(SPEC.contains(fp[:, 0], fp[:, 1]))
    # binomial: sd of the hit fraction sqrt(0.21 / 12000) = 0.0042; 4 sd
    assert hits / (3 * n) == pytest.approx(0.7, abs=4 * math.sqrt(0.21 / (3 * n)))
    # Poisson: sd of the mean sqrt(0.8 / 4000) = 0.014; 4 sd
    assert clutter / n == pytest.approx(0.8, abs=4 * math.sqrt(0.8 / n))


def test_camera_clutter_stays_in_its_field_of_view() -> None:
    cam = dataclasses.replace(paper_simulated_detectors()[2], clutter_rate=5.0)
    (out,) = simulate_detections(np.zeros((0, 2)), [], detectors=[cam], spec=SPEC, rng=np.random.default_rng(1))
    assert out.positions.shape[0] > 0
    assert np.all(np.abs(np.arctan2(out.positions[:, 1], out.positions[:, 0])) <= math.radians(31) + 1e-9)


def test_noise_shape_along_the_line_of_sight() -> None:
    cam = dataclasses.replace(paper_simulated_detectors()[2], miss_rate=0.0, clutter_rate=0.0, crop_to_grid=False)
    laser = dataclasses.replace(paper_simulated_detectors()[0], miss_rate=0.0, clutter_rate=0.0, crop_to_grid=False)
    bearing = math.radians(20)
    p = 5.0 * np.array([[math.cos(bearing), math.sin(bearing)]])
    u = p[0] / 5.0
    nvec = np.array([-u[1], u[0]])
    rng = np.random.default_rng(9)
    n = 6000
    cam_err = np.empty((n, 2))
    laser_err = np.empty((n, 2))
    for k in range(n):
        c, la = simulate_detections(p, [0], detectors=[cam, laser], spec=SPEC, rng=rng)
        cam_err[k] = c.positions[0] - p[0]
        laser_err[k] = la.positions[0] - p[0]
    # sample sd has relative sd 1/sqrt(2n) = 0.9 %; 5 % tolerance
    assert np.std(cam_err @ u) == pytest.approx(1.7, rel=0.05)
    assert np.std(cam_err @ nvec) == pytest.approx(1.0, rel=0.05)
    assert abs(np.corrcoef(cam_err @ u, cam_err @ nvec)[0, 1]) < 0.05
    assert np.std(laser_err, axis=0) == pytest.approx([0.035, 0.035], rel=0.05)


def test_crop_to_grid_counts_what_it_drops() -> None:
    laser = _perfect(paper_simulated_detectors()[0])
    people = np.array([[3.0, 0.0], [12.0, 2.0]])  # the second is beyond the grid's 9 m
    (out,) = simulate_detections(people, [1, 2], detectors=[laser], spec=SPEC, rng=np.random.default_rng(0))
    assert out.source.tolist() == [1] and out.n_cropped == 1
    (out,) = simulate_detections(
        people,
        [1, 2],
        detectors=[dataclasses.replace(laser, crop_to_grid=False)],
        spec=SPEC,
        rng=np.random.default_rng(0),
    )
    assert sorted(out.source.tolist()) == [1, 2] and out.n_cropped == 0


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"miss_rate": 1.5}, "miss_rate"),
        ({"clutter_rate": -1.0}, "clutter_rate"),
        ({"noise": "laplace"}, "noise"),
        ({"sigma_range": float("nan")}, "sigma_range"),
        ({"occlusion_threshold": 0.0}, "occlusion_threshold"),
    ],
)
def test_bad_detector_config_names_the_field(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        dataclasses.replace(paper_simulated_detectors()[0], **kwargs)


def test_detector_from_dict() -> None:
    det = SimulatedDetector.from_dict(
        {"base": "camera_hog", "miss_rate": 0.2, "people_in_view": 2.0, "model": {"fov_max_deg": 40.0, "ppv": 0.9}}
    )
    assert det.model.fov_max == pytest.approx(math.radians(40.0))
    assert det.model.ppv == 0.9 and det.noise == "line_of_sight"
    assert det.clutter_rate == pytest.approx(clutter_for_ppv(0.9, 0.2, 2.0))
    with pytest.raises(ValueError, match="unknown detector field"):
        SimulatedDetector.from_dict({"base": "laser_legs", "mis_rate": 0.2})
    with pytest.raises(ValueError, match="base"):
        SimulatedDetector.from_dict({"base": "radar"})
    # without a base, miss_rate is required (was a bare KeyError with people_in_view)
    own = {"model": {"name": "radar", "ppv": 0.9, "fnr": 0.2}, "people_in_view": 2.0}
    with pytest.raises(ValueError, match="miss_rate"):
        SimulatedDetector.from_dict(own)
    assert SimulatedDetector.from_dict({**own, "miss_rate": 0.2}).clutter_rate == pytest.approx(
        clutter_for_ppv(0.9, 0.2, 2.0)
    )


def test_bad_truth_input_is_named() -> None:
    with pytest.raises(ValueError, match="ids"):
        simulate_detections(
            np.zeros((2, 2)), [1], detectors=paper_simulated_detectors(), spec=SPEC, rng=np.random.default_rng(0)
        )
    with pytest.raises(ValueError, match="positions"):
        simulate_detections(
            np.array([[np.nan, 0.0]]),
            [1],
            detectors=paper_simulated_detectors(),
            spec=SPEC,
            rng=np.random.default_rng(0),
        )
