"""gridbridge.geometry: the one pose type and its transforms (compose, inverse, points in and out of a frame)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gridbridge.geometry import (
    Pose2D,
    compose,
    from_frame,
    inverse,
    near_any,
    quaternion_from_yaw,
    rotate,
    to_frame,
    yaw_from_quaternion,
)
from pfpeople.sensors import Pose2D as SensorsPose2D

RNG = np.random.default_rng(0)
PTS = RNG.uniform(-5.0, 5.0, (20, 2))


def test_one_pose_type() -> None:
    assert SensorsPose2D is Pose2D


def test_frames_round_trip_and_match_the_pose_methods() -> None:
    a, b = Pose2D(x=1.0, y=-2.0, yaw=2.5), Pose2D(x=-0.3, y=0.4, yaw=-3.0)
    np.testing.assert_allclose(to_frame(from_frame(PTS, a), a), PTS, atol=1e-12)
    np.testing.assert_array_equal(a.apply(PTS), from_frame(PTS, a))
    np.testing.assert_array_equal(from_frame(PTS, a), from_frame(PTS, a.as_array()))
    ab = a.compose(b)
    np.testing.assert_allclose(ab.apply(PTS), a.apply(b.apply(PTS)), atol=1e-12)
    assert -math.pi < ab.yaw <= math.pi
    ident = a.compose(a.inverse())
    assert abs(ident.x) < 1e-12 and abs(ident.y) < 1e-12 and abs(ident.yaw) < 1e-12
    np.testing.assert_allclose(a.inverse().apply(PTS), to_frame(PTS, a), atol=1e-12)


def test_arrays_of_poses_broadcast_like_one_pose_each() -> None:
    poses = RNG.uniform(-3.0, 3.0, (4, 3))
    many = to_frame(PTS[None, :, :], poses[:, None, :])
    assert many.shape == (4, 20, 2)
    for k, p in enumerate(poses):
        np.testing.assert_array_equal(many[k], to_frame(PTS, p))
    walked = compose(poses, (0.5, 0.1, 0.2), wrap=False)
    np.testing.assert_allclose(walked[:, 2], poses[:, 2] + 0.2)
    np.testing.assert_allclose(walked[:, :2], from_frame(np.array([0.5, 0.1]), poses), atol=1e-12)
    np.testing.assert_allclose(compose(poses, inverse(poses))[:, :2], 0.0, atol=1e-12)
    np.testing.assert_allclose(rotate(np.array([1.0, 0.0]), math.pi / 2), [0.0, 1.0], atol=1e-15)


def test_quaternion_yaw_round_trip_and_bad_shapes() -> None:
    for yaw in (-3.0, -0.5, 0.0, 1.2, 3.1):
        assert yaw_from_quaternion(*quaternion_from_yaw(yaw)) == pytest.approx(yaw, abs=1e-12)
    with pytest.raises(ValueError, match="pose"):
        to_frame(PTS, (1.0, 2.0))
    with pytest.raises(ValueError, match="points"):
        from_frame(np.zeros((3, 3)), Pose2D())


def test_near_any_against_a_loop() -> None:
    pts = RNG.uniform(-2, 2, size=(40, 2))
    others = RNG.uniform(-2, 2, size=(7, 2))
    want = [any(math.dist(p, o) <= 0.5 for o in others) for p in pts]
    assert near_any(pts, others, 0.5).tolist() == want
    assert near_any([[0.0, 0.0]], [[0.3, 0.4]], 0.5).tolist() == [True]  # the radius itself is near
    assert near_any(pts, np.zeros((0, 2)), 1.0).tolist() == [False] * 40
    assert near_any(np.zeros((0, 2)), others, 1.0).shape == (0,)


def test_from_frame_of_a_few_points_is_the_numpy_arithmetic_bit_for_bit() -> None:
    """Up to 8 points go through Python floats: the same floats as the numpy rows of a longer array."""
    from gridbridge.geometry import from_frame

    rng = np.random.default_rng(5)
    for _ in range(300):
        pose = Pose2D(
            x=float(rng.normal(0, 5)), y=float(rng.choice([0.0, -0.0, rng.normal()])), yaw=float(rng.normal(0, 3))
        )
        pts = rng.normal(0, 10, (9, 2))
        pts[rng.random((9, 2)) < 0.1] = -0.0
        want = from_frame(pts, pose)
        for k in range(9):
            got = from_frame(pts[:k], pose)
            assert got.shape == (k, 2) and got.tobytes() == want[:k].tobytes()
    assert Pose2D(x=1.0).apply([2.0, 3.0]).tolist() == [[3.0, 3.0]]
