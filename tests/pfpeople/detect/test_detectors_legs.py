"""Leg-pattern detector (detector 1) and the shared leg pairing, on synthetic scans."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gridbridge.params import CALIBRATED_LASER_DETECTORS
from pfpeople.detect.legs import LegDetector, LegDetectorParams, PairingParams, pair_legs, people_from_legs
from pfpeople.detect.synthetic import render_scan
from pfpeople.sensors import LaserScan

LEG_R = 0.06  # 0.12 m diameter legs
# Tolerance of a detected person (leg-pair midpoint) to the true midpoint: one leg radius. The segment centroid
# of a visible half-circle lies 2 r / pi = 0.038 m in front of the leg centre, so this is the expected bias.
TOL = LEG_R


def _person(x: float, y: float, sep: float = 0.3) -> list[tuple[float, float, float]]:
    """Two legs ``sep`` apart across the line of sight, centred on (x, y)."""
    b = math.atan2(y, x)
    ox, oy = -math.sin(b) * sep / 2, math.cos(b) * sep / 2
    return [(x + ox, y + oy, LEG_R), (x - ox, y - oy, LEG_R)]


@pytest.mark.parametrize("where", [(2.0, 0.5), (3.5, -1.5), (1.2, 2.0)])
def test_two_legs_give_one_person_at_the_midpoint(where: tuple[float, float]) -> None:
    scan = render_scan(circles=_person(*where), segments=[(7.0, -6.0, 7.0, 6.0)])
    det = LegDetector()
    legs = det.detect_legs(scan)
    people = det.detect(scan)
    assert legs.shape == (2, 2)
    assert people.shape == (1, 2)
    assert np.hypot(*(people[0] - where)) < TOL


@pytest.mark.parametrize("dist", [3.0, 3.5, 4.0, 4.5, 5.0, 6.0])
def test_a_far_person_with_three_beams_per_leg(dist: float) -> None:
    """At 0.5 deg per beam a 0.12 m leg gets about 0.12 / (r * 0.0087) beams (here 5, 4, 4, 3, 2, 3 at these ranges,
    as the beams fall). ``far_leg_width`` (0.10 m) lowers the point minimum to the beams a 0.10 m leg can give (never
    below 3) where ``min_points`` (4) cannot be met: a person with 3 returns on each leg is found only with it, one with
    4 or more with or without it, one with 2 never (the far leg blobs off:
    ``tests/pfpeople/detect/test_detectors_far_legs.py``)."""
    circles = _person(dist, 0.0)
    scan = render_scan(circles=circles, angle_increment=math.radians(0.5))
    pts = scan.points()
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    per_leg = [int(np.count_nonzero(np.hypot(pts[:, 0] - x, pts[:, 1] - y) <= r + 1e-6)) for x, y, r in circles]
    found = LegDetector(params=LegDetectorParams(far_from=math.inf)).detect(scan)
    without = LegDetector(params=LegDetectorParams(far_leg_width=0.0, far_from=math.inf)).detect(scan)
    assert without.shape == ((1, 2) if min(per_leg) >= 4 else (0, 2))
    assert found.shape == ((1, 2) if min(per_leg) >= 3 else (0, 2))
    if len(found):
        assert np.hypot(*(found[0] - (dist, 0.0))) < TOL


def test_two_people_and_clutter() -> None:
    circles = _person(2.0, 1.0) + _person(3.0, -1.0)
    walls = [(6.0, -5.0, 6.0, 5.0), (1.0, -3.0, 5.0, -3.0)]  # a long wall and a side wall
    scan = render_scan(circles=circles, segments=walls)
    people = LegDetector().detect(scan)
    assert people.shape == (2, 2)
    truth = np.array([[2.0, 1.0], [3.0, -1.0]])
    d = np.hypot(people[:, None, 0] - truth[None, :, 0], people[:, None, 1] - truth[None, :, 1])
    assert np.all(d.min(axis=0) < TOL)


def test_wall_and_poles_are_not_people() -> None:
    wall = render_scan(segments=[(3.0, -3.0, 3.0, 3.0)])
    thin_pole = render_scan(circles=[(2.0, 0.0, 0.015)])  # 3 cm pole: narrower than min_width
    leg_sized_pole = render_scan(circles=[(2.0, 0.0, LEG_R)])  # one leg-like pole, no partner
    det = LegDetector()
    for scan in (wall, thin_pole, leg_sized_pole):
        assert det.detect(scan).shape == (0, 2)
    assert det.detect_legs(wall).shape == (0, 2)
    assert det.detect_legs(thin_pole).shape == (0, 2)
    assert det.detect_legs(leg_sized_pole).shape == (1, 2)
    # counting single legs makes the lone pole a person
    single = LegDetector(params=LegDetectorParams(pairing=PairingParams(count_single_legs=True)))
    assert single.detect(leg_sized_pole).shape == (1, 2)


def test_legs_too_far_apart_are_not_paired() -> None:
    scan = render_scan(circles=_person(2.5, 0.0, sep=1.0))
    det = LegDetector()
    assert det.detect_legs(scan).shape == (2, 2)
    assert det.detect(scan).shape == (0, 2)


def test_nan_inf_and_empty_scans() -> None:
    scan = render_scan(circles=_person(2.0, 0.0))
    ranges = scan.ranges.copy()
    ranges[::7] = np.nan  # drop-outs all over, including inside the legs
    ranges[3] = -np.inf
    noisy = LaserScan(ranges=ranges, angle_min=scan.angle_min, angle_increment=scan.angle_increment, range_max=10.0)
    people = LegDetector().detect(noisy)
    assert people.shape == (1, 2) and np.hypot(*(people[0] - [2.0, 0.0])) < TOL
    for r in (np.zeros(0), np.full(100, np.nan), np.full(100, np.inf)):
        empty = LaserScan(ranges=r, angle_min=-1.0, angle_increment=0.02)
        assert LegDetector().detect(empty).shape == (0, 2)
        assert LegDetector().detect_legs(empty).shape == (0, 2)


def test_pair_legs_greedy_closest_first() -> None:
    legs = np.array([[0.0, 0.0], [0.0, 0.3], [0.0, 0.5], [5.0, 5.0]])
    pairs, paired = pair_legs(legs, min_separation=0.1, max_separation=0.6)
    assert pairs.tolist() == [[1, 2]]  # 0.2 apart beats 0.3
    assert paired.tolist() == [False, True, True, False]
    assert pair_legs(np.zeros((0, 2)), min_separation=0.1, max_separation=0.6)[0].shape == (0, 2)


def test_people_from_legs_together_segment() -> None:
    legs = np.array([[2.0, 0.0], [3.0, 1.0], [3.0, 1.3]])
    widths = np.array([0.35, 0.12, 0.12])  # the first is two legs together
    people = people_from_legs(legs, widths, params=PairingParams())
    np.testing.assert_allclose(people, [[2.0, 0.0], [3.0, 1.15]], atol=1e-12)
    with pytest.raises(ValueError, match="widths"):
        people_from_legs(legs, widths[:2], params=PairingParams())


def test_model_and_params_validation() -> None:
    assert LegDetector().model == CALIBRATED_LASER_DETECTORS[0]
    assert LegDetector().model.fov_max - LegDetector().model.fov_min == pytest.approx(math.pi)
    with pytest.raises(ValueError, match="min_width"):
        LegDetectorParams(min_width=0.5, max_width=0.4)
    with pytest.raises(ValueError, match="min_points"):
        LegDetectorParams(min_points=2)
    with pytest.raises(ValueError, match="min_separation"):
        PairingParams(min_separation=0.7, max_separation=0.6)
    with pytest.raises(TypeError, match="model"):
        LegDetector(model="laser")  # type: ignore[arg-type]


def test_scan_segments_are_shared_by_identity_and_params() -> None:
    """The leg and boosted detectors of one laser share the segmentation of the same scan object."""
    from pfpeople.detect.segments import SegmentationParams, scan_segments, segment_features, segment_scan
    from pfpeople.sensors import LaserScan

    scan = LaserScan(ranges=np.full(90, 3.0), angle_min=-0.5, angle_increment=0.01)
    segs, feats = scan_segments(scan)
    again, again_feats = scan_segments(scan)
    assert again is segs and again_feats is feats  # computed once
    np.testing.assert_array_equal(feats, segment_features(segment_scan(scan)))
    other = scan_segments(scan, params=SegmentationParams(jump_distance=0.5))[0]
    assert other is not segs  # other parameters: computed again
    copy = LaserScan(ranges=scan.ranges.copy(), angle_min=-0.5, angle_increment=0.01)
    assert scan_segments(copy)[0] is not segs  # an equal but other scan object: computed again
