"""pfpeople.perception.arrivals: hand-made scans of a leg that came, a post that stood, and a moving laser."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gridbridge import jit
from gridbridge.geometry import Pose2D
from pfpeople.perception import arrivals
from pfpeople.perception.arrivals import MARGIN_M, SIDE_BEAMS, RecentScans, seen_through_beams
from pfpeople.sensors import LaserScan

#: 181 beams over +-90 deg, one a degree.
N, INC = 181, math.radians(1.0)
S = 1_000_000_000  # ns per second


def _scan(ranges: np.ndarray, range_max: float = 10.0) -> LaserScan:
    return LaserScan(ranges=ranges, angle_min=-math.pi / 2, angle_increment=INC, range_max=range_max)


def _wall(r: float = 8.0) -> np.ndarray:
    return np.full(N, r)


def _with_leg(ranges: np.ndarray, beam: int, r: float, half: int = 2) -> np.ndarray:
    out = ranges.copy()
    out[beam - half : beam + half + 1] = r
    return out


def _points(scan: LaserScan) -> np.ndarray:
    return scan.points()


def test_seen_through_by_beam_reading() -> None:
    """A beam sees through a point it passed by MARGIN_M or more, or when it returned nothing; NaN says nothing;
    the nearest beam's SIDE_BEAMS neighbours on each side must see through it too."""
    assert SIDE_BEAMS == 1
    ranges = _wall(5.0)
    ranges[100], ranges[110], ranges[120] = np.nan, np.inf, 10.0  # no reading, nothing (REP-117), range_max
    ranges[130] = 0.01  # below range_min: too close to read
    ranges[111] = ranges[121] = np.inf
    scan = LaserScan(ranges=ranges, angle_min=-math.pi / 2, angle_increment=INC, range_min=0.05, range_max=10.0)
    at = lambda k, r: [r * math.cos(-math.pi / 2 + k * INC), r * math.sin(-math.pi / 2 + k * INC)]  # noqa: E731
    pts = [at(90, 3.0), at(90, 5.0 - MARGIN_M + 0.01), at(110.4, 3.0), at(120.4, 3.0), at(130, 3.0), at(132, 3.0)]
    assert seen_through_beams(np.array(pts), scan).tolist() == [True, False, True, True, False, True]
    # beams 99 and 101 read 5 m, but their neighbour 100 (NaN) says nothing; beam 98's neighbours read 5 m
    assert seen_through_beams(np.array([at(99, 3.0), at(101, 3.0), at(98, 3.0)]), scan).tolist() == [False, False, True]
    # the beam nearest the bearing decides which neighbours: 0.4 beams off 102 is beam 102's (101-103: seen),
    # 0.6 beams off 101 is beam 102's too, 0.4 beams off 101 is beam 101's (100-102: not)
    near = [at(102.4, 3.0), at(101.6, 3.0), at(101.4, 3.0)]
    assert seen_through_beams(np.array(near), scan).tolist() == [True, True, False]


def test_outside_the_field_of_view_or_range_says_nothing() -> None:
    scan = _scan(_wall(5.0), range_max=6.0)
    behind, edge, far = [-3.0, 0.0], [0.0, -3.0], [7.0, 0.0]  # beam 0 lies at -90 deg: no beam beside it
    assert not seen_through_beams(np.array([behind, edge, far]), scan).any()
    assert seen_through_beams(
        np.array([[3.0 * math.cos(-math.pi / 2 + INC), 3.0 * math.sin(-math.pi / 2 + INC)]]), scan
    ).all()
    assert not seen_through_beams(np.array([[3.0, 0.0]]), _scan(np.zeros(0))).any()


def test_a_leg_that_came_arrived_a_post_that_stood_did_not() -> None:
    """The post at beam 60 is in every scan; the leg at beam 120 only from t = 0.5 s, where the wall showed before."""
    recent = RecentScans()
    post = (60, 3.0)
    leg = (120, 3.0)
    for k in range(10):  # 7.5 Hz, the laser standing
        ranges = _with_leg(_wall(), *post)
        if k >= 4:
            ranges = _with_leg(ranges, *leg)
        scan = _scan(ranges)
        t = k * S * 2 // 15
        if k == 9:
            at = lambda b, r: [r * math.cos(-math.pi / 2 + b * INC), r * math.sin(-math.pi / 2 + b * INC)]  # noqa: E731
            out = recent.arrived(np.array([at(*post), at(*leg)]), _points(scan), Pose2D(), t)
            assert out.tolist() == [False, True]
        recent.add(scan, Pose2D(), t)
    assert len(recent) == 8  # 1 s at 7.5 Hz: the scans of t >= 0.2 s


def test_scans_are_registered_by_their_poses() -> None:
    """The laser drove 0.4 m forward past a post: with the poses the post's returns fall on the post in the old
    scan (it did not arrive); taken as standing, the old scan's beams passed beside them (it would have)."""
    post = np.array([[3.0, 1.0]])

    def scan_at(x: float) -> LaserScan:
        rel = post[0] - [x, 0.0]
        b = round((math.atan2(rel[1], rel[0]) + math.pi / 2) / INC)
        return _scan(_with_leg(_wall(), b, float(np.hypot(*rel)), half=1))

    recent = RecentScans()
    old, new = scan_at(0.0), scan_at(0.4)
    recent.add(old, Pose2D(), 0)
    here = np.array([[2.6, 1.0]])  # the post in the new laser frame
    pts = _points(new)
    assert not recent.arrived(here, pts, Pose2D(x=0.4), S // 2).any()
    assert recent.arrived(here, pts, Pose2D(), S // 2).all()


@pytest.mark.parametrize(("age_s", "used"), [(0.1, False), (0.5, True), (0.99, True)])
def test_only_scans_min_age_to_window_old_are_looked_at(age_s: float, used: bool) -> None:
    recent = RecentScans()
    recent.add(_scan(_wall()), Pose2D(), 0)
    now = _scan(_with_leg(_wall(), 90, 3.0))
    assert recent.arrived(np.array([[3.0, 0.0]]), _points(now), Pose2D(), int(age_s * S)).tolist() == [used]


def test_old_scans_are_dropped_and_clear_forgets() -> None:
    recent = RecentScans()
    recent.add(_scan(_wall()), Pose2D(), 0)
    recent.add(_scan(_wall()), Pose2D(), int(1.5 * S))
    assert len(recent) == 1
    recent.clear()
    assert len(recent) == 0
    now = _scan(_with_leg(_wall(), 90, 3.0))
    assert not recent.arrived(np.array([[3.0, 0.0]]), _points(now), Pose2D(), 2 * S).any()


def test_half_of_the_returns_must_have_been_seen_through() -> None:
    """Of a detection's returns, at least FRACTION must have been seen through by one earlier scan."""
    recent = RecentScans()
    recent.add(_scan(_with_leg(_wall(), 90, 3.0, half=1)), Pose2D(), 0)  # beams 89-91 stopped at 3 m a moment ago
    det = np.array([[3.0, 0.0]])
    # seen through now: the returns whose beam and both neighbours read 8 m before (beams up to 87, from 93 on)
    wider = _points(_scan(_with_leg(_wall(), 90, 3.0, half=4)))  # beams 86-94: 86, 87, 93, 94 (4 of 9)
    widest = _points(_scan(_with_leg(_wall(), 90, 3.0, half=6)))  # beams 84-96: 84-87 and 93-96 (8 of 13)
    assert not recent.arrived(det, wider, Pose2D(), S // 2).any()
    assert recent.arrived(det, widest, Pose2D(), S // 2).all()
    assert arrivals.FRACTION == 0.5


def test_no_views_or_no_returns_mean_no_arrival() -> None:
    recent = RecentScans()
    assert recent.arrived(np.zeros((0, 2)), np.zeros((0, 2)), Pose2D(), 0).shape == (0,)
    recent.add(_scan(_wall()), Pose2D(), 0)
    far_from_returns = np.array([[1.0, 0.0]])
    assert not recent.arrived(far_from_returns, _points(_scan(_wall())), Pose2D(), S // 2).any()


def _random_scan(rng: np.random.Generator, k: int) -> LaserScan:
    """A cluttered random scan: leg-like blobs on a wall, NaN / inf / too close / range_max beams, either turn
    direction, part or all of a turn."""
    beams = int(rng.choice([5, 181, 768]))
    ranges = np.full(beams, 6.0) + rng.normal(0, 0.5, beams).cumsum() * 0.05
    for _ in range(rng.integers(0, 10)):
        c, w = int(rng.integers(0, beams)), int(rng.integers(1, 10))
        ranges[c : c + w] = rng.uniform(0.5, 5.0)
    bad = rng.random(beams)
    ranges[bad < 0.03] = np.nan
    ranges[(bad >= 0.03) & (bad < 0.06)] = np.inf
    ranges[(bad >= 0.06) & (bad < 0.07)] = 10.0
    ranges[(bad >= 0.07) & (bad < 0.08)] = 0.01
    span = float(rng.choice([math.pi, 2 * math.pi]))
    inc = (-1 if k % 3 == 0 else 1) * span / beams
    start = float(rng.uniform(-4.0, 4.0))
    return LaserScan(ranges=ranges, angle_min=start, angle_increment=inc, range_min=0.05, range_max=10.0)


@pytest.mark.skipif(not jit.enabled("pfpeople"), reason="numba is not installed or PFPEOPLE_NUMBA=0")
def test_arrived_compiled_equals_numpy() -> None:
    """The compiled :meth:`RecentScans.arrived` gives the numpy code's answers on random scans, poses and
    detections (some near many returns, some near none)."""
    rng = np.random.default_rng(3)
    answers = []
    for case in range(30):
        recent = RecentScans()
        pose = Pose2D()
        for k in range(12):
            scan = _random_scan(rng, case + k)
            dx, dy, dyaw = (float(v) for v in rng.normal(0, [0.03, 0.03, 0.02]))
            pose = pose.compose(Pose2D(x=dx, y=dy, yaw=dyaw))
            stamp = k * S * 2 // 15
            pts = scan.points()
            finite = pts[np.isfinite(pts).all(axis=1)]
            m = int(rng.integers(0, 9))
            det = (
                finite[rng.integers(0, len(finite), m)] + rng.normal(0, 0.1, (m, 2))
                if len(finite)
                else np.zeros((0, 2))
            )
            det = np.concatenate((det, rng.uniform(-8, 8, (int(rng.integers(0, 3)), 2))))
            with jit.override(False, "pfpeople"):
                want = recent.arrived(det, pts, pose, stamp)
            got = recent.arrived(det, pts, pose, stamp)
            assert got.dtype == want.dtype == bool and np.array_equal(got, want)
            answers.append(want)
            recent.add(scan, pose, stamp)
    every = np.concatenate(answers)
    assert every.any() and not every.all()


def _held_scene() -> tuple[RecentScans, np.ndarray]:
    """A leg came at beam 90 (3 m) at t = 0.5 s where the wall showed at t = 0: it arrived, holdable."""
    recent = RecentScans()
    recent.add(_scan(_wall()), Pose2D(), 0)
    leg = np.array([[3.0, 0.0]])
    now = _points(_scan(_with_leg(_wall(), 90, 3.0)))
    assert recent.arrived(leg, now, Pose2D(), S // 2, holdable=[True]).tolist() == [True]
    return recent, leg


@pytest.mark.parametrize(
    ("t_s", "held"), [(1.5, True), (0.5 + arrivals.HOLD_S - 0.01, True), (0.5 + arrivals.HOLD_S + 0.1, False)]
)
def test_a_holdable_arrival_holds_its_place_for_hold_s(t_s: float, held: bool) -> None:
    """After one arrival, a holdable detection at the same place of the map frame (the laser drove 0.5 m
    forward: 2.5 m ahead now) is let through without new evidence until HOLD_S after the arrival; one
    HOLD_RADIUS_M away and more, or not holdable, it is not."""
    recent, _ = _held_scene()
    pose = Pose2D(x=0.5)
    t = int(t_s * S)
    same = np.array([[2.5, 0.0], [2.5, arrivals.HOLD_RADIUS_M - 0.02], [2.5, arrivals.HOLD_RADIUS_M + 0.02]])
    stood = _points(_scan(_with_leg(_wall(), 90, 2.5)))  # no scan saw through it: no arrival of its own
    got = recent.arrived(same, stood, pose, t, holdable=[True, True, True])
    assert got.tolist() == [held, held, False]
    assert not recent.arrived(same[:1], stood, pose, t, holdable=[False]).any()
    assert not recent.arrived(same[:1], stood, pose, t).any()  # default: nothing held


def test_held_detections_do_not_renew_the_place_and_clear_forgets_it() -> None:
    recent, leg = _held_scene()
    stood = _points(_scan(_with_leg(_wall(), 90, 3.0)))
    assert arrivals.HOLD_S == 2.0
    assert recent.arrived(leg, stood, Pose2D(), 2 * S, holdable=[True]).all()  # held, 1.5 s after the arrival
    # 2.4 s after it: lapsed (the held detection at 2 s did not renew the place)
    assert not recent.arrived(leg, stood, Pose2D(), int(2.9 * S), holdable=[True]).any()
    recent2, _ = _held_scene()
    recent2.clear()
    assert not recent2.arrived(leg, stood, Pose2D(), S, holdable=[True]).any()
    with pytest.raises(ValueError, match="holdable must have one flag per detection"):
        recent2.arrived(leg, stood, Pose2D(), S, holdable=[True, False])
