"""Prediction based on sensor motion (Batista & Pereira 2015, Sect. 3.1.2, eqs. 10-11).

The grid is attached to the sensor frame, so when the robot moves by the rigid transform
``(dx, dy, dtheta)`` (the new sensor frame expressed in the old one) a point fixed in the world moves, in
sensor coordinates, from ``p_old`` to ``p_new = R(-dtheta) (p_old - t)``.

Odometry (v, vy, omega, dt) gives the displacement through Thrun's velocity motion model (Probabilistic
Robotics, Table 5.3) with executed controls ``v_hat``, ``w_hat`` and final rotation ``gamma_hat``, extended by a
lateral velocity ``vy`` to the full SE(2) motion of the sensor frame (a frame mounted off the robot's rotation
axis and yawed also moves sideways). A constant body-frame velocity ``(v, vy, w)`` over ``dt`` integrates to

    dx = (v sin(w dt) - vy (1 - cos(w dt))) / w,   dy = (v (1 - cos(w dt)) + vy sin(w dt)) / w,
    dtheta = (w_hat + gamma_hat) dt                  (straight line ``dx = v dt, dy = vy dt`` when w = 0),

with ``v = v_hat``, ``w = w_hat``; ``vy = 0`` is Thrun's model. The noise stays on ``v_hat``, ``w_hat`` and
``gamma_hat``; ``vy`` enters the mean only.

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
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from gridbridge import jit, kernels
from gridbridge.geometry import Pose2D, from_frame_xy
from gridbridge.grid import GridSpec
from gridbridge.params import SensorMotionNoise
from gridbridge.validation import check_number, check_positive, check_probability

__all__ = [
    "Odometry",
    "border_inflow",
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
    """Motion of the sensor frame over one step, as a constant body-frame velocity (sensor frame).

    Attributes
    ----------
    v : float
        Forward speed (m/s, x of the moving sensor frame).
    omega : float
        Yaw rate (rad/s).
    vy : float
        Lateral speed (m/s, y of the moving sensor frame); 0 for a sensor on the robot's rotation axis
        (Thrun's velocity model).
    """

    v: float = 0.0
    omega: float = 0.0
    vy: float = 0.0

    def __post_init__(self) -> None:
        check_number(self.v, "Odometry.v")  # TypeError for a bool, a string or a complex
        check_number(self.omega, "Odometry.omega")
        check_number(self.vy, "Odometry.vy")


def velocity_displacement(
    v: ArrayLike, omega: ArrayLike, dt: float, gamma: ArrayLike = 0.0, vy: ArrayLike = 0.0
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Displacement of the sensor frame over ``dt`` under a constant body-frame velocity (eqs. 10-11).

    Parameters
    ----------
    v, omega : array_like
        Executed forward speed (m/s) and yaw rate (rad/s) of the velocity motion model, sensor frame.
    dt : float
        Time step (s).
    gamma : array_like
        Executed final rotation rate (rad/s; Thrun's ``gamma_hat``), added to ``dtheta`` only.
    vy : array_like
        Lateral speed (m/s, y of the moving sensor frame); see the module docstring for the closed form.

    Returns
    -------
    dx, dy, dtheta : ndarray
        The new sensor frame in the old one (m, m, rad), broadcast over the inputs.
    """
    v = np.asarray(v, dtype=float)
    w = np.asarray(omega, dtype=float)
    turning = np.abs(w) > _OMEGA_EPS
    w_safe = np.where(turning, w, 1.0)
    wdt = w * dt
    sin_wdt, one_minus_cos = np.sin(wdt), 1.0 - np.cos(wdt)  # once each, for Thrun's and the lateral terms
    # Thrun's terms first, the lateral ones added after: with vy = 0 the result is bit-identical to vy-free code.
    dx = np.where(turning, v / w_safe * sin_wdt, v * dt)
    dy = np.where(turning, v / w_safe * one_minus_cos, 0.0)
    lat = np.asarray(vy, dtype=float)
    if np.any(lat != 0.0):
        dx = dx - np.where(turning, lat / w_safe * one_minus_cos, 0.0)
        dy = dy + np.where(turning, lat / w_safe * sin_wdt, lat * dt)
    dtheta = (w + np.asarray(gamma, dtype=float)) * dt
    return dx, dy, np.broadcast_to(dtheta, np.broadcast(dx, dtheta).shape).copy()


def odometry_pose(odometry: Odometry | None, dt: float) -> Pose2D:
    """The sensor frame after ``dt`` s of ``odometry`` in the frame before (the mean motion of eqs. 10-11, no
    noise; m, m, rad); identity for None."""
    if odometry is None:
        return Pose2D()
    dx, dy, dth = velocity_displacement(odometry.v, odometry.omega, dt, vy=odometry.vy)
    return Pose2D(x=float(dx), y=float(dy), yaw=float(dth))


def ego_motion_sigma_points(
    odometry: Odometry | None, dt: float, noise: SensorMotionNoise
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Sigma-point displacements of the noisy velocity motion model (eqs. 10-11).

    The noise is on ``v``, ``omega`` and ``gamma`` (:meth:`SensorMotionNoise.variances`); the lateral speed
    ``odometry.vy`` enters every sigma point as its mean.

    Returns
    -------
    poses : ndarray, shape (S, 3)
        ``(dx, dy, dtheta)`` per sigma point (m, m, rad), old sensor frame.
    weights : ndarray, shape (S,)
        Non-negative, summing to 1.
    """
    dt = check_positive(dt, "dt")
    odo = Odometry() if odometry is None else odometry
    if type(noise) is not SensorMotionNoise or type(odo) is not Odometry:  # a subclass may not hash by value
        return _sigma_points_cached.__wrapped__(odo, dt, noise)
    return _sigma_points_cached(odo, dt, noise)


@lru_cache(maxsize=256)
def _sigma_points_cached(
    odo: Odometry, dt: float, noise: SensorMotionNoise
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`ego_motion_sigma_points` (read-only arrays), cached: a robot's odometry repeats from frame to frame."""
    variances = noise.variances(odo.v, odo.omega)
    mean = (float(odo.v), float(odo.omega), 0.0)
    active = [k for k, var in enumerate(variances) if var > 0.0]
    centre = 1.0 - len(active) / 3.0
    nodes: list[tuple[float, ...]] = [mean] if centre > 0.0 else []  # a centre of weight 0 (3 noisy controls): out
    weights = [centre] if centre > 0.0 else []
    for k in active:
        step = math.sqrt(3.0 * variances[k])
        for sign in (1.0, -1.0):
            node = list(mean)
            node[k] += sign * step  # the float64 sum numpy's in-place add gave
            nodes.append(tuple(node))
            weights.append(1.0 / 6.0)
    poses = np.array([_node_displacement(v, w, gamma, dt, float(odo.vy)) for v, w, gamma in nodes]).reshape(-1, 3)
    w_arr = np.array(weights)
    weights = w_arr / w_arr.sum()
    poses.setflags(write=False)
    weights.setflags(write=False)
    return poses, weights


def _node_displacement(v: float, w: float, gamma: float, dt: float, vy: float) -> tuple[float, float, float]:
    """:func:`velocity_displacement` of one control ``(v, w, gamma)`` in Python floats: the same IEEE operations
    in the same order, element by element (``math.sin`` / ``math.cos`` are the C library's, as numpy's float64
    ufuncs on this platform), without a dozen numpy calls on a handful of elements.

    Returns
    -------
    tuple of float
        ``(dx, dy, dtheta)`` (m, m, rad).
    """
    turning = abs(w) > _OMEGA_EPS
    wdt = w * dt
    sin_wdt, one_minus_cos = math.sin(wdt), 1.0 - math.cos(wdt)
    if turning:
        dx, dy = v / w * sin_wdt, v / w * one_minus_cos
    else:
        dx, dy = v * dt, 0.0
    if vy != 0.0:
        if turning:
            dx, dy = dx - vy / w * one_minus_cos, dy + vy / w * sin_wdt
        else:
            dx, dy = dx - 0.0, dy + vy * dt
    return dx, dy, (w + gamma) * dt


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
    p, w, outside = _warp_args(poses, weights, outside)
    if len(p) == 1 and np.all(p[0] == 0.0):
        return bel.copy()
    if jit.enabled():
        grid = (float(spec.x0), float(spec.y0), float(spec.resolution))
        return kernels.warp_bilinear(np.ascontiguousarray(bel), grid, np.ascontiguousarray(p), w, outside)
    gx, gy = spec.cell_centres()
    # p_old = R(dtheta) p_new + t, evaluated at every new cell centre for every pose: shape (S, nx, ny).
    x_old, y_old = from_frame_xy(gx, gy, p[:, None, None, :])
    u, v = spec.to_fractional(x_old, y_old)
    coords = np.stack((u.ravel() - 0.5, v.ravel() - 0.5))
    samples = ndimage.map_coordinates(bel, coords, order=1, mode="grid-constant", cval=outside)
    out = np.tensordot(w, samples.reshape(len(p), *spec.shape), axes=1)
    return np.clip(out, 0.0, 1.0, out=out)


def _warp_args(
    poses: ArrayLike, weights: ArrayLike | None, outside: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """:func:`warp_belief`'s poses ``(S, 3)``, normalised weights ``(S,)`` and ``outside``, checked.

    Raises
    ------
    ValueError
        Poses not ``(S, 3)`` or ``(3,)`` of finite numbers, weights not ``S`` non-negative finite numbers with a
        positive sum, ``outside`` not a probability.
    """
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
    return p, w / w.sum(), outside


def border_inflow(
    spec: GridSpec, poses: ArrayLike, weights: ArrayLike | None = None, *, outside: float = 0.5
) -> NDArray[np.float64]:
    """What the sensor motion brings into each cell from beyond the border: :func:`warp_belief` of an all-zero
    belief, bit for bit (compiled: :func:`gridbridge.kernels.warp_outside`, which computes only the cells near
    the border; arguments as there).

    Returns
    -------
    ndarray, shape (nx, ny)
    """
    if not jit.enabled():
        return warp_belief(np.zeros(spec.shape), spec, poses, weights, outside=outside)
    p, w, outside = _warp_args(poses, weights, outside)
    if len(p) == 1 and np.all(p[0] == 0.0):
        return np.zeros(spec.shape)
    grid = (float(spec.x0), float(spec.y0), float(spec.resolution))
    return kernels.warp_outside((int(spec.nx), int(spec.ny)), grid, np.ascontiguousarray(p), w, outside)


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
