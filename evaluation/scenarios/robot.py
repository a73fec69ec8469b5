"""The simulated robot: a velocity profile (v, omega) with speeds 0-0.6 m/s and turns, and its world path.

The robot (and the grid's sensor frame, REP-103: x forward, y left, yaw counter-clockwise) moves under
Thrun's velocity motion model (Probabilistic Robotics, Table 5.3; the paper's sensor motion, eqs. 10-11):
over one step ``dt`` with constant controls ``(v, omega)`` the pose ``(x, y, yaw)`` moves along an arc,

    x' = x + v/omega (sin(yaw + omega dt) - sin(yaw)),   y' = y + v/omega (cos(yaw) - cos(yaw + omega dt)),
    yaw' = yaw + omega dt                                  (a straight line when omega = 0).

The odometry of frame ``k`` is the ``(v, omega)`` that moved the robot from frame ``k - 1`` to frame ``k``,
so integrating the odometry with :func:`integrate_path` reproduces the path exactly. Reported (noisy)
odometry adds zero-mean Gaussian errors with the variances of :class:`gridbridge.params.SensorMotionNoise`
(``var(v) = alpha1 v^2 + alpha2 w^2``, ``var(w) = alpha3 v^2 + alpha4 w^2``); the filter's sensor-motion
model assumes the same noise, so the true controls lie around the reported ones as the filter expects.

The velocity profile is a sequence of segments (the paper's robot "speed ranged from 0 to 0.6 m/s", "moving
with changes in its linear and angular velocities"): cruise straight, drive a curve, stop, turn on the spot;
segment targets are reached under acceleration limits, so v and omega change smoothly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge.ego_motion import velocity_displacement
from gridbridge.geometry import compose, from_frame, to_frame
from gridbridge.params import SensorMotionNoise
from gridbridge.validation import check_positive

__all__ = [
    "RobotProfile",
    "integrate_path",
    "noisy_odometry",
    "robot_controls",
    "sensor_to_world",
    "step_pose",
    "world_to_sensor",
]


@dataclass(frozen=True, kw_only=True)
class RobotProfile:
    """How the simulated robot drives.

    Parameters
    ----------
    v_max : float
        Largest forward speed (m/s); the paper's robot drove at 0-0.6 m/s.
    v_min_cruise : float
        Smallest speed of a moving segment (m/s).
    omega_max : float
        Largest yaw rate of a turn (rad/s).
    accel : float
        Forward acceleration limit (m/s^2).
    yaw_accel : float
        Yaw acceleration limit (rad/s^2).
    segment_min, segment_max : float
        Segment durations are uniform in ``[segment_min, segment_max]`` (s).
    p_cruise, p_curve, p_stop, p_spin : float
        Relative weights of the segment kinds (straight, curve, standing still, turning on the spot);
        normalised, at least one must be positive.
    """

    v_max: float = 0.6
    v_min_cruise: float = 0.15
    omega_max: float = 0.6
    accel: float = 0.5
    yaw_accel: float = 1.0
    segment_min: float = 2.0
    segment_max: float = 6.0
    p_cruise: float = 0.45
    p_curve: float = 0.35
    p_stop: float = 0.1
    p_spin: float = 0.1

    def __post_init__(self) -> None:
        check_positive(self.v_max, "RobotProfile.v_max", allow_zero=True)
        check_positive(self.v_min_cruise, "RobotProfile.v_min_cruise", allow_zero=True)
        if self.v_min_cruise > self.v_max:
            raise ValueError(
                f"RobotProfile.v_min_cruise ({self.v_min_cruise!r}) must not exceed v_max ({self.v_max!r})"
            )
        check_positive(self.omega_max, "RobotProfile.omega_max", allow_zero=True)
        check_positive(self.accel, "RobotProfile.accel")
        check_positive(self.yaw_accel, "RobotProfile.yaw_accel")
        check_positive(self.segment_min, "RobotProfile.segment_min")
        check_positive(self.segment_max, "RobotProfile.segment_max")
        if self.segment_min > self.segment_max:
            raise ValueError("RobotProfile.segment_min must not exceed segment_max")
        weights = [self.p_cruise, self.p_curve, self.p_stop, self.p_spin]
        for name, w in zip(("p_cruise", "p_curve", "p_stop", "p_spin"), weights, strict=True):
            check_positive(w, f"RobotProfile.{name}", allow_zero=True)
        if sum(weights) <= 0:
            raise ValueError("RobotProfile.p_cruise/p_curve/p_stop/p_spin: at least one must be positive")

    @classmethod
    def standing(cls) -> RobotProfile:
        """A robot that never moves."""
        return cls(v_max=0.0, v_min_cruise=0.0, omega_max=0.0, p_cruise=0.0, p_curve=0.0, p_stop=1.0, p_spin=0.0)


def _approach(current: float, target: float, limit: float) -> float:
    return current + float(np.clip(target - current, -limit, limit))


def robot_controls(
    n_frames: int, dt: float, *, profile: RobotProfile, rng: np.random.Generator
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Draw a velocity profile: the controls that move the robot into each frame.

    Parameters
    ----------
    n_frames : int
        Number of frames (>= 1).
    dt : float
        Frame period (s).
    profile : RobotProfile
        Speeds, turn rates, segment kinds.
    rng : numpy.random.Generator
        Source of randomness.

    Returns
    -------
    v, omega : ndarray, shape (n_frames,)
        ``v[k]`` (m/s) and ``omega[k]`` (rad/s) moved the robot from frame ``k - 1`` to frame ``k``;
        ``v[0] = omega[0] = 0`` (the robot starts at rest). ``0 <= v <= profile.v_max``.
    """
    if n_frames < 1:
        raise ValueError(f"n_frames must be >= 1, got {n_frames!r}")
    dt = check_positive(dt, "dt")
    weights = np.array([profile.p_cruise, profile.p_curve, profile.p_stop, profile.p_spin], dtype=float)
    weights /= weights.sum()
    v = np.zeros(n_frames)
    w = np.zeros(n_frames)
    cur_v = cur_w = 0.0
    k = 1
    while k < n_frames:
        kind = int(rng.choice(4, p=weights))
        duration = rng.uniform(profile.segment_min, profile.segment_max)
        steps = max(1, round(duration / dt))
        if kind == 0:  # cruise
            tv, tw = rng.uniform(profile.v_min_cruise, profile.v_max), 0.0
        elif kind == 1:  # curve
            tv = rng.uniform(profile.v_min_cruise, profile.v_max)
            tw = rng.choice((-1.0, 1.0)) * rng.uniform(0.3 * profile.omega_max, profile.omega_max)
        elif kind == 2:  # stop
            tv, tw = 0.0, 0.0
        else:  # spin on the spot
            tv, tw = 0.0, rng.choice((-1.0, 1.0)) * rng.uniform(0.3 * profile.omega_max, profile.omega_max)
        for _ in range(steps):
            if k >= n_frames:
                break
            cur_v = _approach(cur_v, tv, profile.accel * dt)
            cur_w = _approach(cur_w, tw, profile.yaw_accel * dt)
            v[k], w[k] = cur_v, cur_w
            k += 1
    return v, w


def step_pose(pose: ArrayLike, v: float, omega: float, dt: float) -> NDArray[np.float64]:
    """Move a world pose ``(x, y, yaw)`` (m, m, rad) by constant controls over ``dt`` (exact arc)."""
    dx, dy, dth = velocity_displacement(v, omega, dt)
    return compose(pose, (float(dx), float(dy), float(dth)), wrap=False)


def integrate_path(
    v: ArrayLike, omega: ArrayLike, dt: float, *, start: ArrayLike = (0.0, 0.0, 0.0)
) -> NDArray[np.float64]:
    """World poses from odometry: pose ``k`` is pose ``k - 1`` moved by ``(v[k], omega[k])`` over ``dt``.

    Parameters
    ----------
    v, omega : array_like, shape (T,)
        Controls per frame (m/s, rad/s); ``v[0], omega[0]`` move the robot into frame 0 from ``start``.
        Pass ``v[0] = omega[0] = 0`` to make pose 0 equal ``start``.
    dt : float
        Frame period (s).
    start : array_like, shape (3,)
        Pose before the first control (m, m, rad; world frame).

    Returns
    -------
    poses : ndarray, shape (T, 3)
        ``(x, y, yaw)`` per frame, world frame; yaw unwrapped (not folded into [-pi, pi)).
    """
    v = np.asarray(v, dtype=float)
    w = np.asarray(omega, dtype=float)
    if v.ndim != 1 or w.shape != v.shape:
        raise ValueError(f"v and omega must be 1-D arrays of equal length, got {v.shape} and {w.shape}")
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(w))):
        raise ValueError("v and omega must be finite")
    dt = check_positive(dt, "dt")
    pose = np.asarray(start, dtype=float).reshape(3)
    out = np.empty((v.size, 3))
    for k in range(v.size):
        pose = step_pose(pose, v[k], w[k], dt)
        out[k] = pose
    return out


def noisy_odometry(
    v: ArrayLike, omega: ArrayLike, *, noise: SensorMotionNoise, rng: np.random.Generator
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Reported odometry: true controls plus Gaussian errors with the velocity-model variances.

    A robot standing still reports exactly zero (both variances vanish at v = omega = 0).

    Returns
    -------
    v_odom, omega_odom : ndarray, shape (T,)
        m/s, rad/s.
    """
    v = np.asarray(v, dtype=float)
    w = np.asarray(omega, dtype=float)
    var_v, var_w, _ = noise.variances(v, w)
    return v + rng.standard_normal(v.shape) * np.sqrt(var_v), w + rng.standard_normal(w.shape) * np.sqrt(var_w)


def world_to_sensor(points: ArrayLike, pose: ArrayLike) -> NDArray[np.float64]:
    """Express world points ``(N, 2)`` in the sensor frame of a robot at world ``pose`` ``(x, y, yaw)``."""
    return to_frame(np.asarray(points, dtype=float).reshape(-1, 2), np.asarray(pose, dtype=float).reshape(3))


def sensor_to_world(points: ArrayLike, pose: ArrayLike) -> NDArray[np.float64]:
    """Inverse of :func:`world_to_sensor`."""
    return from_frame(np.asarray(points, dtype=float).reshape(-1, 2), np.asarray(pose, dtype=float).reshape(3))
