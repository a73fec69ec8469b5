"""Prediction based on sensor motion (Batista & Pereira 2015, Sect. 3.1.2, eqs. 10-11).

The grid is attached to the sensor frame, so when the robot moves by the rigid transform
``(dx, dy, dtheta)`` (the new sensor frame expressed in the old one) a point fixed in the world moves, in
sensor coordinates, from ``p_old`` to ``p_new = R(-dtheta) (p_old - t)``.

Odometry (v, omega, dt) gives the displacement through Thrun's velocity motion model (Probabilistic
Robotics, Table 5.3) with executed controls ``v_hat``, ``w_hat`` and final rotation ``gamma_hat``:

    dx = v_hat / w_hat * sin(w_hat dt),   dy = v_hat / w_hat * (1 - cos(w_hat dt)),
    dtheta = (w_hat + gamma_hat) dt                                      (straight line when w_hat = 0).

Reading of eq. 10 ("P(p | v_sensors) can be found using eq. 8 with v_people replaced by v_sensors"): we do
not apply eq. 8's colonisation form to ego-motion, because the robot's motion does not create or remove
people; it only changes where the same belief lies in the sensor frame. The sensor-motion prediction is the
expectation of the warped belief over the noisy displacement,

    bel(c) = E_pose[ bel'(T_pose^{-1} c) ],

computed as a weighted sum of backward bilinear warps (exact for sub-cell shifts and rotations up to the
interpolation) over sigma points of (v_hat, w_hat, gamma_hat): per noisy control the nodes 0 and
+-sqrt(3) sd with weights 1 - k/3 (centre, k = number of noisy controls) and 1/6 (each side), which match each
control's second and fourth moments. Cells whose source lies outside the grid read ``outside`` (0.5 in the
paper). Bilinear weights are convex, so beliefs stay in [0, 1]; a whole-cell translation without noise is an
exact shift; mass is conserved away from the border to interpolation accuracy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from gridbridge.geometry import Pose2D, from_frame_xy
from gridbridge.grid import GridSpec
from gridbridge.params import SensorMotionNoise
from gridbridge.validation import check_finite, check_positive, check_probability

__all__ = [
    "Odometry",
    "ego_motion_sigma_points",
    "odometry_pose",
    "predict_sensor",
    "velocity_displacement",
    "warp_belief",
]

#: Below this |omega_hat| (rad/s) the straight-line limit of the velocity model is used.
_OMEGA_EPS = 1e-9


@dataclass(frozen=True, kw_only=True)
class Odometry:
    """Robot controls over one step: forward speed ``v`` (m/s) and yaw rate ``omega`` (rad/s), sensor frame."""

    v: float = 0.0
    omega: float = 0.0

    def __post_init__(self) -> None:
        check_finite(self.v, "Odometry.v")
        check_finite(self.omega, "Odometry.omega")


def velocity_displacement(
    v: ArrayLike, omega: ArrayLike, dt: float, gamma: ArrayLike = 0.0
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Displacement ``(dx, dy, dtheta)`` of the sensor frame over ``dt`` (old sensor frame; m, m, rad).

    Vectorised over ``v``, ``omega``, ``gamma`` (executed controls of the velocity motion model).
    """
    v = np.asarray(v, dtype=float)
    w = np.asarray(omega, dtype=float)
    turning = np.abs(w) > _OMEGA_EPS
    w_safe = np.where(turning, w, 1.0)
    dx = np.where(turning, v / w_safe * np.sin(w * dt), v * dt)
    dy = np.where(turning, v / w_safe * (1.0 - np.cos(w * dt)), 0.0)
    dtheta = (w + np.asarray(gamma, dtype=float)) * dt
    return dx, dy, np.broadcast_to(dtheta, np.broadcast(dx, dtheta).shape).copy()


def odometry_pose(odometry: Odometry | None, dt: float) -> Pose2D:
    """The sensor frame after ``dt`` s of ``odometry`` in the frame before (the mean motion, no noise);
    identity for None."""
    if odometry is None:
        return Pose2D()
    dx, dy, dth = velocity_displacement(odometry.v, odometry.omega, dt)
    return Pose2D(x=float(dx), y=float(dy), yaw=float(dth))


def ego_motion_sigma_points(
    odometry: Odometry | None, dt: float, noise: SensorMotionNoise
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Sigma-point displacements of the noisy velocity motion model.

    Returns
    -------
    poses : ndarray, shape (S, 3)
        ``(dx, dy, dtheta)`` per sigma point (m, m, rad), old sensor frame.
    weights : ndarray, shape (S,)
        Non-negative, summing to 1.
    """
    dt = check_positive(dt, "dt")
    odo = Odometry() if odometry is None else odometry
    variances = noise.variances(odo.v, odo.omega)
    mean = np.array([odo.v, odo.omega, 0.0])
    nodes = [mean]
    weights = [1.0]
    active = [k for k, var in enumerate(variances) if var > 0.0]
    weights[0] = 1.0 - len(active) / 3.0
    for k in active:
        step = math.sqrt(3.0 * variances[k])
        for sign in (1.0, -1.0):
            node = mean.copy()
            node[k] += sign * step
            nodes.append(node)
            weights.append(1.0 / 6.0)
    controls = np.array(nodes)
    w = np.array(weights)
    keep = w > 0.0
    controls, w = controls[keep], w[keep]
    dx, dy, dth = velocity_displacement(controls[:, 0], controls[:, 1], dt, controls[:, 2])
    return np.column_stack((dx, dy, dth)), w / w.sum()


def warp_belief(
    belief: ArrayLike,
    spec: GridSpec,
    poses: ArrayLike,
    weights: ArrayLike | None = None,
    *,
    outside: float = 0.5,
) -> NDArray[np.float64]:
    """Move a belief grid into the new sensor frame: weighted sum of bilinear backward warps.

    Parameters
    ----------
    belief : array_like, shape (nx, ny)
        Belief in the old sensor frame.
    spec : GridSpec
        The grid (the same in both frames).
    poses : array_like, shape (S, 3) or (3,)
        Displacements ``(dx, dy, dtheta)`` of the new sensor frame in the old one (m, m, rad).
    weights : array_like, shape (S,), optional
        Weights of the poses (normalised here); equal by default.
    outside : float
        Belief read for points outside the grid.

    Returns
    -------
    ndarray, shape (nx, ny)
        Belief in the new sensor frame.
    """
    bel = spec.check_grid(belief, "belief")
    outside = check_probability(outside, "outside")
    p = np.asarray(poses, dtype=float)
    if p.ndim not in (1, 2) or p.shape[-1] != 3 or p.size == 0:
        raise ValueError(f"poses must have shape (S, 3) or (3,) of (dx, dy, dtheta), S >= 1, got {p.shape}")
    p = p.reshape(-1, 3)
    if not np.all(np.isfinite(p)):
        raise ValueError("poses contain NaN or infinite values")
    w = np.full(len(p), 1.0 / len(p)) if weights is None else np.asarray(weights, dtype=float).ravel()
    if w.shape != (len(p),) or not np.all(np.isfinite(w)) or w.min() < 0 or w.sum() <= 0:
        raise ValueError(f"weights must be {len(p)} non-negative finite numbers with a positive sum")
    w = w / w.sum()
    if len(p) == 1 and np.all(p[0] == 0.0):
        return bel.copy()
    gx, gy = spec.cell_centres()
    # p_old = R(dtheta) p_new + t, evaluated at every new cell centre for every pose: shape (S, nx, ny).
    x_old, y_old = from_frame_xy(gx, gy, p[:, None, None, :])
    u, v = spec.to_fractional(x_old, y_old)
    coords = np.stack((u.ravel() - 0.5, v.ravel() - 0.5))
    samples = ndimage.map_coordinates(bel, coords, order=1, mode="grid-constant", cval=outside)
    out = np.tensordot(w, samples.reshape(len(p), *spec.shape), axes=1)
    return np.clip(out, 0.0, 1.0, out=out)


def predict_sensor(
    belief: ArrayLike,
    spec: GridSpec,
    odometry: Odometry | None,
    dt: float,
    *,
    noise: SensorMotionNoise | None = None,
    outside: float = 0.5,
) -> NDArray[np.float64]:
    """Sensor-motion prediction (eqs. 10-11): the expected warp of ``belief`` under noisy odometry.

    ``odometry=None`` means the robot stood still (identity warp).
    """
    noise = SensorMotionNoise() if noise is None else noise
    poses, weights = ego_motion_sigma_points(odometry, dt, noise)
    return warp_belief(belief, spec, poses, weights, outside=outside)
