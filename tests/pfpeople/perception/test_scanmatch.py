"""Scan matching (pfpeople.perception.scan_matching) on ray-cast synthetic scans with known motion.

The scans are cast with numpy against line segments (walls, a box) and circles (posts), 768 beams over 270 deg
up to 11 m, like the leg_tracker lasers. Tolerances: 1 cm / 0.5 deg for a noise-free or 1 cm-noise match
(the brief's bound); 3 cm / 1 deg with 3 cm range noise.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.typing import NDArray

from pfpeople.perception.scan_matching import (
    MatchResult,
    ScanMatchConfig,
    ScanOdometry,
    ScanOdometryConfig,
    match_scans,
)
from pfpeople.sensors import Pose2D

Segment = tuple[tuple[float, float], tuple[float, float]]
Circle = tuple[tuple[float, float], float]

ROOM: list[Segment] = [
    ((-3.0, -4.0), (8.0, -4.0)),
    ((8.0, -4.0), (8.0, 5.0)),
    ((8.0, 5.0), (-3.0, 5.0)),
    ((-3.0, 5.0), (-3.0, -4.0)),
    ((2.0, 1.0), (3.0, 1.5)),
]
POSTS: list[Circle] = [((4.0, 2.0), 0.2), ((5.0, -2.0), 0.1), ((1.0, -2.5), 0.3)]


def ray_cast(
    pose: Pose2D,
    segments: list[Segment],
    circles: list[Circle],
    *,
    beams: int = 768,
    fov: float = math.radians(270.0),
    range_max: float = 11.0,
    noise: float = 0.0,
    rng: np.random.Generator | None = None,
) -> NDArray[np.float64]:
    """End points (B, 2) in the sensor frame of a sensor at ``pose`` (world frame); NaN rows = no return."""
    rel = np.linspace(-fov / 2, fov / 2, beams)
    a = pose.yaw + rel
    d = np.column_stack((np.cos(a), np.sin(a)))
    o = np.array([pose.x, pose.y])
    r = np.full(beams, np.inf)
    for p0, p1 in segments:
        e = np.subtract(p1, p0)
        w = np.subtract(p0, o)
        den = -d[:, 0] * e[1] + d[:, 1] * e[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (-w[0] * e[1] + w[1] * e[0]) / den
            u = (d[:, 0] * w[1] - d[:, 1] * w[0]) / den
        hit = (t > 0) & (u >= 0) & (u <= 1)
        r = np.where(hit & (t < r), t, r)
    for centre, radius in circles:
        w = o - np.asarray(centre)
        b = d @ w
        disc = b * b - (w @ w - radius**2)
        with np.errstate(invalid="ignore"):
            t = -b - np.sqrt(disc)
        hit = (disc >= 0) & (t > 0)
        r = np.where(hit & (t < r), t, r)
    if noise:
        assert rng is not None
        r = r + rng.normal(0.0, noise, beams)
    r[r > range_max] = np.nan
    return np.column_stack((r * np.cos(rel), r * np.sin(rel)))


def relative(a: Pose2D, b: Pose2D) -> Pose2D:
    """Frame b expressed in frame a."""
    return a.inverse().compose(b)


def pose_error(est: Pose2D, truth: Pose2D) -> tuple[float, float]:
    dyaw = math.atan2(math.sin(est.yaw - truth.yaw), math.cos(est.yaw - truth.yaw))
    return math.hypot(est.x - truth.x, est.y - truth.y), abs(math.degrees(dyaw))


P0 = Pose2D(x=0.3, y=0.2, yaw=0.1)
P1 = Pose2D(x=0.45, y=0.12, yaw=0.1 + math.radians(4.0))


@pytest.mark.parametrize("noise", [0.0, 0.01])
def test_room_motion_recovered_within_1cm_half_degree(noise: float, rng: np.random.Generator) -> None:
    prev = ray_cast(P0, ROOM, POSTS, noise=noise, rng=rng)
    cur = ray_cast(P1, ROOM, POSTS, noise=noise, rng=rng)
    res = match_scans(prev, cur)
    dist, ang = pose_error(res.pose, relative(P0, P1))
    assert res.ok and res.converged and not res.degenerate
    assert dist <= 0.01 and ang <= 0.5, (dist, ang)
    assert res.rmse <= 0.005 + 1.5 * noise
    assert res.inlier_fraction >= 0.9


def test_room_motion_with_3cm_noise_and_larger_motion(rng: np.random.Generator) -> None:
    p1 = Pose2D(x=0.6, y=-0.1, yaw=0.1 - math.radians(8.0))
    prev = ray_cast(P0, ROOM, POSTS, noise=0.03, rng=rng)
    cur = ray_cast(p1, ROOM, POSTS, noise=0.03, rng=rng)
    res = match_scans(prev, cur, init=Pose2D(x=0.2))
    dist, ang = pose_error(res.pose, relative(P0, p1))
    assert res.ok
    assert dist <= 0.03 and ang <= 1.0, (dist, ang)


def test_single_wall_is_degenerate_and_keeps_the_initial_guess_along_it() -> None:
    wall: list[Segment] = [((-5.0, 2.0), (10.0, 2.0))]
    p1 = Pose2D(x=0.15, y=-0.05, yaw=math.radians(4.0))
    res = match_scans(ray_cast(Pose2D(), wall, []), ray_cast(p1, wall, []))
    assert res.degenerate and not res.ok
    assert res.min_eigenvalue < 1e-6
    # along the wall (x) nothing is known: the estimate stays at the guess (0) instead of wandering off;
    # across it (y) and in yaw the wall constrains the motion
    assert abs(res.pose.x) < 1e-3
    assert abs(res.pose.y - p1.y) < 0.01 and abs(math.degrees(res.pose.yaw - p1.yaw)) < 0.5


def test_unrelated_scans_are_poor() -> None:
    rng = np.random.default_rng(3)
    a = rng.uniform(-5, 5, (400, 2))
    b = rng.uniform(-5, 5, (400, 2))
    res = match_scans(a, b)
    assert not res.ok


def test_empty_and_nan_input() -> None:
    res = match_scans(np.zeros((0, 2)), ray_cast(P1, ROOM, POSTS))
    assert isinstance(res, MatchResult) and not res.ok and res.inlier_fraction == 0.0
    pts = ray_cast(P1, ROOM, POSTS)
    pts[::3] = np.nan  # invalid beams are ignored
    assert match_scans(ray_cast(P0, ROOM, POSTS), pts).ok


def test_bad_input_errors() -> None:
    with pytest.raises(ValueError, match="prev_points"):
        match_scans(np.zeros((5, 3)), np.zeros((5, 2)))
    with pytest.raises(TypeError, match="init"):
        match_scans(np.zeros((5, 2)), np.zeros((5, 2)), init=(0.0, 0.0, 0.0))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="min_correspondence"):
        ScanMatchConfig(min_correspondence=1.0, max_correspondence=0.5)
    with pytest.raises(ValueError, match="max_iterations"):
        ScanMatchConfig(max_iterations=0)
    with pytest.raises(TypeError, match="max_points"):
        ScanMatchConfig(max_points=1.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="keyframe_distance"):
        ScanOdometryConfig(keyframe_distance=-1.0)
    with pytest.raises(TypeError, match="config"):
        ScanOdometry(ScanMatchConfig())  # type: ignore[arg-type]


def test_odometry_integrates_a_turning_trajectory(rng: np.random.Generator) -> None:
    """40 scans along an arc (4 cm and 1.5 deg per scan, 1 cm noise): the integrated pose stays within
    5 cm / 1 deg of the truth and every step is matched."""
    odo = ScanOdometry()
    truth = [Pose2D(x=0.0, y=0.0, yaw=0.0)]
    for _ in range(40):
        truth.append(truth[-1].compose(Pose2D(x=0.04, y=0.0, yaw=math.radians(1.5))))
    est = Pose2D()
    steps = [odo.update(ray_cast(p, ROOM, POSTS, noise=0.01, rng=rng)) for p in truth]
    for st in steps[1:]:
        est = est.compose(st.ego)
    assert not steps[0].ok and all(st.ok for st in steps[1:])
    assert any(not st.new_keyframe for st in steps[1:]), "small motion reuses the keyframe"
    dist, ang = pose_error(est, relative(truth[0], truth[-1]))
    assert dist <= 0.05 and ang <= 1.0, (dist, ang)


def test_odometry_standing_still_has_no_drift(rng: np.random.Generator) -> None:
    odo = ScanOdometry()
    est = Pose2D()
    for _ in range(30):
        est = est.compose(odo.update(ray_cast(P0, ROOM, POSTS, noise=0.01, rng=rng)).ego)
    assert math.hypot(est.x, est.y) < 0.01 and abs(math.degrees(est.yaw)) < 0.2


def test_odometry_falls_back_to_identity_on_a_poor_match() -> None:
    odo = ScanOdometry()
    wall: list[Segment] = [((-5.0, 2.0), (10.0, 2.0))]
    odo.update(ray_cast(Pose2D(), wall, []))
    st = odo.update(ray_cast(Pose2D(x=0.1, y=0.05), wall, []))
    assert not st.ok and st.match is not None and st.match.degenerate
    assert (st.ego.x, st.ego.y, st.ego.yaw) == (0.0, 0.0, 0.0)
    assert odo.poor_matches == 1


def test_a_skipped_scan_becomes_the_keyframe_of_the_next_match() -> None:
    """skip(B) then update(C): C is matched against B (one period apart), not against the older A nor against
    nothing, so the step is B -> C; the counts say what happened."""
    a, b = Pose2D(x=0.0, y=0.0, yaw=0.0), Pose2D(x=0.6, y=0.1, yaw=math.radians(20.0))
    c = b.compose(Pose2D(x=0.05, y=0.0, yaw=math.radians(1.5)))
    odo = ScanOdometry()
    odo.update(ray_cast(a, ROOM, POSTS))
    odo.skip(ray_cast(b, ROOM, POSTS))
    st = odo.update(ray_cast(c, ROOM, POSTS))
    assert st.ok and st.new_keyframe is False
    dist, ang = pose_error(st.ego, relative(b, c))
    assert dist <= 0.01 and ang <= 0.2, (dist, ang)
    assert (odo.steps, odo.skipped, odo.poor_matches) == (2, 1, 0)
    # a skip after a reset works the same: the next update has a keyframe
    odo.reset()
    odo.skip(ray_cast(b, ROOM, POSTS))
    assert odo.update(ray_cast(c, ROOM, POSTS)).ok
    with pytest.raises(ValueError, match="points"):
        odo.skip(np.zeros((3, 3)))
