"""The motion detector: walkers through space seen free are found, static things and mixed pixels are not."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gridbridge import jit
from gridbridge.geometry import Pose2D
from pfpeople.detect.motion import MotionDetector, MotionParams, _moved_numpy, _Past
from pfpeople.detect.motion_kernels import moved_flags
from pfpeople.sensors import LaserScan

N = 541
ANG = np.linspace(-math.pi / 2, math.pi / 2, N)


def _ray_circle(cx: float, cy: float, rad: float) -> np.ndarray:
    d = np.column_stack((np.cos(ANG), np.sin(ANG)))
    b = d @ np.array([cx, cy])
    disc = b * b - (cx * cx + cy * cy - rad * rad)
    t = b - np.sqrt(np.maximum(disc, 0))
    return np.where((disc >= 0) & (t > 0), t, np.inf)


def _scan(k: int, person: tuple[float, float] | None, *, posts: bool = True) -> LaserScan:
    """A wall 6 m ahead, two posts, and a person (two legs) at ``person``; 10 Hz stamps."""
    r = 6.0 / np.maximum(np.cos(ANG), 1e-3)
    r = np.where(np.abs(ANG) < 1.2, r, np.inf)
    things = [(4.5, -1.0, 0.03), (4.0, 1.5, 0.03)] if posts else []
    if person is not None:
        things += [(person[0], person[1] - 0.1, 0.06), (person[0], person[1] + 0.1, 0.06)]
    for cx, cy, rad in things:
        r = np.minimum(r, _ray_circle(cx, cy, rad))
    return LaserScan(
        ranges=r,
        angle_min=float(ANG[0]),
        angle_increment=float(ANG[1] - ANG[0]),
        range_max=10.0,
        stamp_ns=k * 100_000_000,
    )


_STILL = Pose2D()


def _run(det: MotionDetector, frames: list[LaserScan], motion: Pose2D | None = _STILL) -> list[np.ndarray]:
    out = []
    for k, s in enumerate(frames):
        det.observe_motion(None if k == 0 else motion)
        out.append(det.detect(s))
    return out


def test_a_walker_crossing_is_found_and_posts_are_not() -> None:
    frames = [_scan(k, (3.0, -2.0 + 0.13 * k)) for k in range(20)]
    found = _run(MotionDetector(), frames)
    hits = 0
    for k in range(6, 20):  # old enough views exist from 0.2 s on
        person = np.array([3.0, -2.0 + 0.13 * k])
        near = np.linalg.norm(found[k] - person, axis=1)
        hits += int(near.size > 0 and near.min() < 0.3)
        assert (near < 0.5).all()  # nothing else: the posts and the wall did not move
    assert hits >= 12


def test_nothing_moves_nothing_is_found() -> None:
    frames = [_scan(k, (3.0, 0.5)) for k in range(15)]  # a person standing still and the posts
    assert all(len(d) == 0 for d in _run(MotionDetector(), frames))


def test_unknown_ego_motion_sees_nothing() -> None:
    frames = [_scan(k, (3.0, -2.0 + 0.13 * k)) for k in range(15)]
    assert all(len(d) == 0 for d in _run(MotionDetector(), frames, motion=None))


def test_a_wrong_ego_within_tolerance_does_not_move_the_posts() -> None:
    """The robot stands, but the ego-motion says it turned by 0.002 rad per scan (odometry error)."""
    frames = [_scan(k, None) for k in range(15)]
    assert all(len(d) == 0 for d in _run(MotionDetector(), frames, motion=Pose2D(yaw=0.002)))


def test_a_lone_mixed_pixel_never_moves() -> None:
    frames = [_scan(k, None) for k in range(10)]
    r = frames[-1].ranges.copy()
    r[200] = 3.0  # a lone return in front of the wall, where every earlier scan saw through
    frames[-1] = LaserScan(
        ranges=r,
        angle_min=frames[-1].angle_min,
        angle_increment=frames[-1].angle_increment,
        range_max=10.0,
        stamp_ns=frames[-1].stamp_ns,
    )
    assert len(_run(MotionDetector(MotionParams(min_returns=1)), frames)[-1]) == 0


@pytest.mark.parametrize("inc", [0.005, -0.005])
def test_compiled_and_numpy_see_through_agree(rng: np.random.Generator, inc: float) -> None:
    n = 400
    far = rng.uniform(0.5, 8.0, n)
    far[rng.random(n) < 0.1] = np.inf
    far[rng.random(n) < 0.05] = -np.inf
    past = _Past(
        stamp_ns=0, far=far, angle_min=-1.0 if inc > 0 else 1.0, increment=inc, range_max=8.0, points=np.zeros((0, 2))
    )
    qr, qb = rng.uniform(0.2, 9.0, 2000), rng.uniform(-1.2, 1.2, 2000)
    want = _moved_numpy(qr, qb, past, 0.3, 0.05, 0.01, 8.0)
    got = moved_flags(qr, qb, far, past.angle_min, inc, 0.3, 0.05, 0.01, 8.0)
    np.testing.assert_array_equal(got, want)
    assert want.any() and not want.all()


def test_detector_paths_agree() -> None:
    frames = [_scan(k, (3.0, -2.0 + 0.13 * k)) for k in range(12)]
    out = []
    for compiled in (True, False):
        with jit.override(compiled, "pfpeople"):
            out.append(_run(MotionDetector(), frames))
    for a, b in zip(*out, strict=True):
        np.testing.assert_allclose(a, b)


def test_params_are_checked() -> None:
    with pytest.raises(ValueError, match="max_age"):
        MotionParams(min_age=0.5, max_age=0.4)
    with pytest.raises(ValueError, match="views"):
        MotionParams(views=0)
