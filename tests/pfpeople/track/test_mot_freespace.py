"""Free space seen by the lasers (``pfpeople.track.free_space``) and the coasting tracks it leaves out."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gridbridge.classifiers import People
from gridbridge.grid import GridSpec
from pfpeople.detect.synthetic import render_scan, reversed_scan
from pfpeople.sensors import LaserScan, Pose2D
from pfpeople.track import TrackerConfig
from pfpeople.track.free_space import seen_through
from pfpeople.track.reported_people import PeopleTracker

WALL = [(8.0, -6.0, 8.0, 6.0)]
ORIGIN = Pose2D()


def _scan(circles=(), segments=WALL, **kw):  # type: ignore[no-untyped-def]
    return render_scan(circles=list(circles), segments=segments, angle_increment=math.radians(0.5), **kw)


def test_empty_place_in_front_of_a_wall_is_seen_through() -> None:
    scan = _scan()
    got = seen_through([[3.0, 0.0], [7.6, 0.0], [3.0, 2.0]], [(scan, ORIGIN)])
    # 3 m: the wall is 5 m behind; 7.6 m: only 0.4 m in front of the wall (within the margin)
    assert got.tolist() == [True, False, True]


def test_a_person_there_or_in_front_is_not_seen_through() -> None:
    person = [(3.0, 0.0, 0.25)]
    scan = _scan(person)
    assert seen_through([[3.0, 0.0], [5.0, 0.0], [3.0, 0.2]], [(scan, ORIGIN)]).tolist() == [False, False, False]
    # 0.6 m beside the person: the window (+-0.3 m) misses it and sees the wall
    assert seen_through([[3.0, 0.9]], [(scan, ORIGIN)]).tolist() == [True]


def test_no_return_is_free_but_an_invalid_return_says_nothing() -> None:
    scan = _scan(segments=[])  # every beam +inf (no return within range_max, REP-117)
    assert seen_through([[3.0, 0.0]], [(scan, ORIGIN)]).tolist() == [True]
    ranges = scan.ranges.copy()
    ranges[np.abs(scan.angle_min + scan.angle_increment * np.arange(ranges.size)) < 0.05] = np.nan
    broken = LaserScan(
        ranges=ranges, angle_min=scan.angle_min, angle_increment=scan.angle_increment, range_max=scan.range_max
    )
    assert seen_through([[3.0, 0.0]], [(broken, ORIGIN)]).tolist() == [False]


def test_outside_the_field_of_view_or_range_says_nothing() -> None:
    scan = _scan(range_max=10.0)  # 180 deg
    assert seen_through([[-3.0, 0.0], [0.0, -12.0]], [(scan, ORIGIN)]).tolist() == [False, False]


@pytest.mark.parametrize("flip", [False, True])
def test_mounted_and_reversed_scans(flip: bool) -> None:
    """The laser 1 m ahead of the grid origin, turned 90 deg left, beams counter- or clockwise: the place 3 m
    ahead of the laser along its x axis is (1, 3) in the grid frame."""
    scan = _scan()
    if flip:
        scan = reversed_scan(scan)
    mount = Pose2D(x=1.0, y=0.0, yaw=math.pi / 2)
    assert seen_through([[1.0, 3.0], [1.0, 7.7]], [(scan, mount)]).tolist() == [True, False]
    # a 360 deg scan starting at 0 rad: bearings below 0 wrap round
    full = render_scan(
        segments=[(-8, -8, 8, -8)], angle_min=0.0, angle_max=2 * math.pi - 0.01, angle_increment=math.radians(0.5)
    )
    assert seen_through([[0.0, -3.0]], [(full, ORIGIN)]).tolist() == [True]


def test_people_tracker_leaves_out_a_coasting_track_the_laser_sees_through() -> None:
    spec = GridSpec(nx=30, ny=30, resolution=0.3, x0=0.0, y0=-4.5)
    belief = np.zeros((spec.nx, spec.ny))
    cfg = TrackerConfig(birth_min_score=0.0)

    def found(*pts: tuple[float, float]) -> People:
        p = np.array(pts, dtype=float).reshape(-1, 2)
        return People(
            positions=p,
            scores=np.full(len(p), 0.9),
            sizes=np.ones(len(p), np.int64),
            mask=np.zeros((spec.nx, spec.ny), bool),
        )

    def run(see: bool, last_scan: LaserScan) -> tuple[int, int]:
        tr = PeopleTracker(None, config=cfg, see_through=see, coast_frames=1)
        for k in range(6):
            tr.step(found((3.0, 0.1 * k)), belief, spec, 0.1, views=[(_scan(), ORIGIN)])
        out = tr.step(found(), belief, spec, 0.1, views=[(last_scan, ORIGIN)])  # a miss: the track coasts
        return len(out.tracks), len(out.people.positions)

    assert run(False, _scan()) == (1, 1)
    assert run(True, _scan()) == (0, 0)  # the laser sees the wall through the predicted place
    assert run(True, _scan([(3.0, 0.6, 0.2)])) == (1, 1)  # something stands there (or in front): kept


def _seen_through_by_masks(positions: np.ndarray, views: list[tuple[LaserScan, Pose2D]]) -> np.ndarray:
    """The previous seen_through's beam test: the usable mask of every beam (+inf, or LaserScan.valid at least
    range_min), then the window's masks."""
    pts = np.asarray(positions, dtype=float).reshape(-1, 2)
    out = np.zeros(len(pts), dtype=bool)
    for scan, mount in views:
        local = mount.inverse().apply(pts)
        r = np.hypot(local[:, 0], local[:, 1])
        bearing = np.arctan2(local[:, 1], local[:, 0])
        ranges, inc = scan.ranges, float(scan.angle_increment)
        with np.errstate(invalid="ignore"):
            usable = np.isposinf(ranges) | (scan.valid & (ranges >= scan.range_min))
        for i in np.flatnonzero(~out & (r > 1e-6) & (r <= scan.range_max)).tolist():
            half = math.atan2(0.5, float(r[i]))
            rel = (float(bearing[i]) - scan.angle_min) % (2.0 * math.pi)
            k0, k1 = (rel - half) / inc, (rel + half) / inc
            lo, hi = math.ceil(min(k0, k1) - 1e-9), math.floor(max(k0, k1) + 1e-9)
            if lo < 0 or hi >= ranges.size or hi < lo:
                continue
            out[i] = bool(usable[lo : hi + 1].all() and np.all(ranges[lo : hi + 1] >= r[i] + 0.5))
    return out


def test_the_beam_tests_in_python_floats_are_the_masks() -> None:
    """seen_through's per-window beam tests against the whole-scan masks: ranges with NaN, +inf, -inf, below
    range_min and above range_max, two lasers, many places."""
    rng = np.random.default_rng(41)
    n_seen = 0
    for k in range(40):
        views = []
        for _ in range(2):
            ranges = rng.uniform(0.0, 12.0, 720) if rng.random() < 0.3 else rng.uniform(7.0, 12.0, 720)
            bad = rng.random(720) < float(rng.choice([0.0, 0.03, 0.3]))
            ranges[bad] = rng.choice([np.nan, np.inf, -np.inf, 0.01, 30.0], int(bad.sum()))
            scan = LaserScan(
                ranges=ranges,
                angle_min=-math.pi,
                angle_increment=math.radians(0.5),
                range_min=0.05,
                range_max=float(rng.choice([10.0, 25.0, math.inf])),
            )
            views.append((scan, Pose2D(x=rng.normal(0, 0.3), y=rng.normal(0, 0.3), yaw=rng.normal(0, 0.5))))
        pts = rng.uniform(-7.0, 7.0, (30, 2))
        got = seen_through(pts, views)
        assert got.tolist() == _seen_through_by_masks(pts, views).tolist(), k
        n_seen += int(got.sum())
    assert n_seen > 50  # places seen through and not
