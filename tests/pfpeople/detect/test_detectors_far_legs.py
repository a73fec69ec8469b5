"""Far leg blobs of the leg detector (``LegDetectorParams.far_from``): people whose legs give 1-3 returns."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pfpeople.detect.legs import LegDetector, LegDetectorParams, far_leg_blobs
from pfpeople.detect.synthetic import render_scan, reversed_scan
from pfpeople.sensors import LaserScan

LEG_R = 0.06
STEP = math.radians(0.5)  # 0.5 deg: a 0.12 m leg gets 1-2 beams at 8 m
WALL = [(14.0, -12.0, 14.0, 12.0)]


def _person(x: float, y: float, sep: float = 0.3) -> list[tuple[float, float, float]]:
    b = math.atan2(y, x)
    ox, oy = -math.sin(b) * sep / 2, math.cos(b) * sep / 2
    return [(x + ox, y + oy, LEG_R), (x - ox, y - oy, LEG_R)]


def _scan(circles, segments=WALL):  # type: ignore[no-untyped-def]
    return render_scan(circles=circles, segments=segments, angle_increment=STEP, range_max=20.0)


@pytest.mark.parametrize("where", [(8.0, 0.0), (7.0, 3.0), (9.5, -2.0)])
def test_far_person_found_only_with_far_legs(where: tuple[float, float]) -> None:
    scan = _scan(_person(*where))
    legs = np.isfinite(scan.ranges) & (scan.ranges < 13.0)
    assert 2 <= np.count_nonzero(legs) <= 6  # 1-3 returns per leg: too few for the shape features
    assert LegDetector(params=LegDetectorParams(far_from=math.inf)).detect(scan).shape == (0, 2)
    found = LegDetector().detect(scan)  # far_from 5 m by default
    assert found.shape == (1, 2)
    # the blob centres lie on the legs' near faces: within one leg radius of the midpoint
    assert np.hypot(*(found[0] - where)) < LEG_R + 0.01


def test_blobs_need_range_foreground_and_size() -> None:
    p = LegDetectorParams(far_from=5.0)
    near = _scan(_person(4.0, 0.0))  # 4 m: the ordinary leg tests' business
    assert far_leg_blobs(near, p)[0].shape == (0, 2)
    on_wall = _scan([], segments=[(8.0, -3.0, 8.0, 3.0)])  # a wall: one long run, no foreground
    assert far_leg_blobs(on_wall, p)[0].shape == (0, 2)
    wide = _scan([(8.0, 0.0, 0.3)])  # a 0.6 m pillar
    assert far_leg_blobs(wide, p)[0].shape == (0, 2)
    # in front of a wall only 0.2 m behind: not a foreground object by 0.3 m
    flush = _scan(_person(8.0, 0.0), segments=[(8.26, -3.0, 8.26, 3.0), *WALL])
    assert far_leg_blobs(flush, p)[0].shape == (0, 2)
    assert far_leg_blobs(flush, LegDetectorParams(far_from=5.0, far_min_jump=0.1))[0].shape == (2, 2)


def test_single_far_blob_is_no_person() -> None:
    scan = _scan([(8.0, 1.0, LEG_R)])  # one leg (the other hidden): a pole or a person
    blobs, small = far_leg_blobs(scan, LegDetectorParams())
    assert blobs.shape == (1, 2) and small.shape == (1, 2)
    assert np.hypot(*(blobs[0] - (8.0, 1.0))) < LEG_R
    people, singles = LegDetector().detect_with_singles(scan)
    assert people.shape == (0, 2) and singles.shape == (0, 2)


def _chair(x: float, y: float, size: float = 0.4, leg: float = 0.025) -> list[tuple[float, float, float]]:
    h = size / 2
    return [(x + dx, y + dy, leg) for dx in (-h, h) for dy in (-h, h)]


def test_chair_at_range_is_no_person_but_a_person_beside_it_is() -> None:
    """A chair showing its four legs is rejected by ``far_isolation``; one showing two (seen edge-on) is not,
    and is left to the static-clutter map."""
    chair = _chair(7.0, 2.0)
    scan = _scan(chair)
    blobs, _ = far_leg_blobs(scan, LegDetectorParams())
    assert blobs.shape[0] == 4  # its 5 cm legs are far leg blobs: 1-2 returns each
    assert LegDetector().detect(scan).shape == (0, 2)
    assert LegDetector(params=LegDetectorParams(far_isolation=0.0)).detect(scan).shape == (2, 2)
    assert LegDetector().detect(_scan(_chair(6.0, 0.0))).shape == (1, 2)  # two legs in line with the beams
    found = LegDetector().detect(_scan(chair + _person(7.0, -0.5)))
    assert found.shape == (1, 2) and np.hypot(*(found[0] - (7.0, -0.5))) < LEG_R + 0.01


def test_far_person_not_counted_twice() -> None:
    """A person at 6 m whose legs pass the ordinary tests too is reported once."""
    scan = render_scan(circles=_person(6.0, 0.0), segments=WALL, angle_increment=math.radians(0.1), range_max=20.0)
    plain = LegDetector().detect(scan)
    both = LegDetector(params=LegDetectorParams(far_from=5.0)).detect(scan)
    assert plain.shape == (1, 2) and both.shape == (1, 2)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"far_from": 0.0}, "far_from"),
        ({"far_max_points": 0}, "far_max_points"),
        ({"far_max_width": -0.1}, "far_max_width"),
        ({"far_min_jump": math.nan}, "far_min_jump"),
        ({"far_isolation": -0.5}, "far_isolation"),
        ({"far_from": "5"}, "far_from"),
    ],
)
def test_far_params_validated(kwargs: dict[str, float], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        LegDetectorParams(**kwargs)  # type: ignore[arg-type]


def test_reversed_scan_and_invalid_beams_give_the_same_far_person() -> None:
    scan = _scan(_person(8.0, 1.0))
    found = LegDetector().detect(scan)
    assert found.shape == (1, 2)
    n = scan.ranges.size
    assert np.allclose(reversed_scan(scan).points()[::-1], scan.points(), atol=1e-9, equal_nan=True)
    assert np.allclose(LegDetector().detect(reversed_scan(scan)), found, atol=1e-9)
    # NaN beams away from the person change nothing; a scan of NaN has no blobs
    ranges = scan.ranges.copy()
    ranges[:20] = np.nan
    holes = LaserScan(ranges=ranges, angle_min=scan.angle_min, angle_increment=scan.angle_increment, range_max=20.0)
    assert np.allclose(LegDetector().detect(holes), found, atol=1e-9)
    empty = LaserScan(ranges=np.full(n, np.nan), angle_min=scan.angle_min, angle_increment=scan.angle_increment)
    assert far_leg_blobs(empty, LegDetectorParams())[0].shape == (0, 2)
