"""The robot's route and odometry for the scan-level simulator.

The robot follows :class:`~evaluation.scenarios.scan.scene.RobotRoute` waypoints with a heading controller
at the odometry rate; each step moves the pose along the exact arc of Thrun's velocity motion model
(:func:`evaluation.scenarios.robot.step_pose`). The odometry integrates noisy controls
(:class:`~evaluation.scenarios.scan.scene.OdometryNoise`), so it drifts as wheel odometry does.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evaluation.scenarios.robot import step_pose
from evaluation.scenarios.scan.scene import OdometryNoise, RobotRoute
from gridbridge.ego_motion import velocity_displacement
from gridbridge.geometry import rotate

__all__ = ["drive_route", "integrate_controls", "interpolate_poses", "odometry_from_controls"]


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def drive_route(
    route: RobotRoute, n_steps: int, dt: float, *, rng: np.random.Generator
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Drive the route for ``n_steps`` steps of ``dt`` s.

    Returns
    -------
    poses : ndarray, shape (n_steps, 3)
        True ``base_link`` pose ``(x, y, yaw)`` in the world at ``k dt`` (m, m, rad; yaw unwrapped).
    v, omega : ndarray, shape (n_steps,)
        Controls that moved the robot from step ``k - 1`` to ``k`` (m/s, rad/s); ``v[0] = omega[0] = 0``.
    """
    wps = np.asarray(route.waypoints, dtype=float)
    if route.start:
        pose = np.array(route.start, dtype=float)
        target = 0
    else:
        nxt = wps[1] if len(wps) > 1 else wps[0] + np.array([1.0, 0.0])
        pose = np.array([wps[0, 0], wps[0, 1], math.atan2(nxt[1] - wps[0, 1], nxt[0] - wps[0, 0])])
        target = 1 % len(wps)
    poses = np.empty((n_steps, 3))
    v = np.zeros(n_steps)
    w = np.zeros(n_steps)
    poses[0] = pose
    cur_v = cur_w = 0.0
    v_target = rng.uniform(route.v_min, route.v_max)
    next_change = route.speed_change_s
    done = False
    for k in range(1, n_steps):
        t = k * dt
        if t >= next_change:
            v_target = rng.uniform(route.v_min, route.v_max)
            next_change += route.speed_change_s
        dx, dy = wps[target, 0] - pose[0], wps[target, 1] - pose[1]
        if not done and math.hypot(dx, dy) < route.reach_m:
            if target == len(wps) - 1 and not route.loop:
                done = True
            else:
                target = (target + 1) % len(wps)
                dx, dy = wps[target, 0] - pose[0], wps[target, 1] - pose[1]
        if done:
            tv, tw = 0.0, 0.0
        else:
            alpha = _wrap(math.atan2(dy, dx) - pose[2])
            tw = float(np.clip(route.turn_gain * alpha, -route.omega_max, route.omega_max))
            tv = v_target * max(math.cos(alpha), 0.0) ** 2
        cur_v += float(np.clip(tv - cur_v, -route.accel * dt, route.accel * dt))
        cur_w += float(np.clip(tw - cur_w, -route.yaw_accel * dt, route.yaw_accel * dt))
        v[k], w[k] = cur_v, cur_w
        pose = step_pose(pose, cur_v, cur_w, dt)
        poses[k] = pose
    return poses, v, w


def odometry_from_controls(
    v: ArrayLike, omega: ArrayLike, dt: float, *, noise: OdometryNoise, start: ArrayLike, rng: np.random.Generator
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Noisy odometry (see :class:`~evaluation.scenarios.scan.scene.OdometryNoise`).

    Parameters
    ----------
    v, omega : array_like, shape (T,)
        True controls per step (m/s, rad/s); ``v[0], omega[0]`` are ignored (the odometry starts at ``start``).
    dt : float
        Step (s).
    noise : OdometryNoise
    start : array_like, shape (3,)
        Odometry pose at step 0 (m, m, rad; odom frame).
    rng : numpy.random.Generator

    Returns
    -------
    poses : ndarray, shape (T, 3)
        Odometry pose of ``base_link`` in the odom frame per step.
    v_odom, omega_odom : ndarray, shape (T,)
        The reported controls.
    """
    v = np.asarray(v, dtype=float).copy()
    w = np.asarray(omega, dtype=float).copy()
    v[0] = w[0] = 0.0
    e_v = rng.normal(0.0, noise.scale_sd_v) if noise.scale_sd_v > 0 else 0.0
    e_w = rng.normal(0.0, noise.scale_sd_w) if noise.scale_sd_w > 0 else 0.0
    sd_v = np.sqrt(noise.alpha1 * v**2 + noise.alpha2 * w**2)
    sd_w = np.sqrt(noise.alpha3 * v**2 + noise.alpha4 * w**2)
    v_o = v * (1.0 + e_v) + sd_v * rng.standard_normal(v.shape)
    w_o = w * (1.0 + e_w) + sd_w * rng.standard_normal(w.shape)
    if noise.yaw_bias_sd > 0 or noise.slip > 0:  # drawn after the rest: scenes without them keep their streams
        bias = rng.normal(0.0, noise.yaw_bias_sd) if noise.yaw_bias_sd > 0 else 0.0
        w_o = w_o * (1.0 + noise.slip * np.minimum(np.abs(w), 1.0)) + bias
        w_o[0] = 0.0
    return integrate_controls(v_o, w_o, dt, start=start), v_o, w_o


def integrate_controls(v: ArrayLike, omega: ArrayLike, dt: float, *, start: ArrayLike) -> NDArray[np.float64]:
    """Vectorised :func:`evaluation.scenarios.robot.integrate_path`: pose ``k`` is pose ``k - 1`` moved along
    the exact arc of ``(v[k], omega[k])`` over ``dt`` (poses ``(T, 3)``, yaw unwrapped)."""
    v = np.asarray(v, dtype=float).reshape(-1)
    w = np.asarray(omega, dtype=float).reshape(-1)
    x0, y0, th0 = (float(c) for c in np.asarray(start, dtype=float).reshape(3))
    dx, dy, dth = velocity_displacement(v, w, dt)
    yaw = th0 + np.cumsum(dth)
    before = yaw - dth  # heading at the start of each step
    step = rotate(np.stack((dx, dy), axis=-1), before)  # each arc's displacement in the world frame
    x = x0 + np.cumsum(step[:, 0])
    y = y0 + np.cumsum(step[:, 1])
    return np.column_stack((x, y, yaw))


def interpolate_poses(times: ArrayLike, step_times: ArrayLike, poses: ArrayLike) -> NDArray[np.float64]:
    """Poses ``(T, 3)`` at ``times`` by linear interpolation of ``poses`` (unwrapped yaw) at ``step_times``."""
    t = np.asarray(times, dtype=float).reshape(-1)
    st = np.asarray(step_times, dtype=float).reshape(-1)
    p = np.asarray(poses, dtype=float).reshape(st.size, 3)
    return np.column_stack([np.interp(t, st, p[:, i]) for i in range(3)])
