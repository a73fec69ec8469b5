"""Sensor motion in sampling form (eqs. 10-11): :class:`VelocityEgoSampling`, its reference form in numpy and its
compiled forms.

Thrun's ``sample_motion_model_velocity`` (Probabilistic Robotics, Table 5.3): executed controls ``v_hat = v + e1``,
``w_hat = w + e2`` and a final rotation ``gamma_hat = e3`` with the variances of
:meth:`~gridbridge.SensorMotionNoise.variances`, mapped to the displacement ``(dx, dy, dtheta)`` of the new sensor
frame in the old one by :func:`gridbridge.velocity_displacement`, with the odometry's lateral speed ``vy`` (a sensor
mounted off the rotation axis) in the mean of every draw (no noise on it). A point (and a velocity) moves into the
new sensor frame as ``p_new = R(-dtheta) (p_old - t)``, ``v_new = R(-dtheta) v_old``.

Forms: :func:`sample_ego_poses` and :func:`apply_ego_motion` (reference, numpy); :func:`ego_rows_from` (compiled, the
same draws from the ``Generator`` and the same arithmetic: bit for bit); :func:`ego_rows_drawn` (compiled, the normal
draws made in the kernel from a SplitMix64 stream, :mod:`pfpeople.particle.predictor.draws`). The compiled forms give
rows ``(dx, dy, cos(dtheta), sin(dtheta))`` (4, S), which :mod:`pfpeople.particle.predictor.passes` applies.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from gridbridge import Odometry, SensorMotionNoise, velocity_displacement
from gridbridge.ego_motion import _OMEGA_EPS
from gridbridge.jit import jit
from gridbridge.validation import check_int, check_positive
from pfpeople.particle.predictor import draws
from pfpeople.particle.state import ParticleState

__all__ = [
    "VelocityEgoSampling",
    "apply_ego_motion",
    "ego_rows",
    "ego_rows_drawn",
    "ego_rows_from",
    "sample_ego_poses",
]


@dataclass(frozen=True, kw_only=True)
class VelocityEgoSampling:
    """Sensor motion (eqs. 10-11) sampled per particle: Thrun's velocity motion model with ``noise``.

    Reference form :meth:`poses`; compiled forms :meth:`rows` (the same draws, bit for bit) and :meth:`rows_drawn`
    (the draws inside the kernel, beside a people motion that draws inside).

    With at most ``pool`` particles every particle draws its own displacement; above, ``pool`` i.i.d. exact draws
    are shared (particle k uses draw ``k mod pool``), so each particle's displacement is still an exact draw while
    the cost of the trigonometry stays fixed.

    Parameters
    ----------
    noise : SensorMotionNoise
        Odometry noise of the velocity motion model (also the grid's sigma points for the border inflow).
    pool : int
        Largest number of distinct displacement draws per step, >= 1.
    """

    noise: SensorMotionNoise = field(default_factory=SensorMotionNoise)
    pool: int = 4096

    def __post_init__(self) -> None:
        if not isinstance(self.noise, SensorMotionNoise):
            raise TypeError(f"VelocityEgoSampling.noise must be a SensorMotionNoise, got {type(self.noise).__name__}")
        check_int(self.pool, "VelocityEgoSampling.pool", minimum=1)

    def poses(self, odometry: Odometry | None, dt: float, n: int, *, rng: np.random.Generator) -> NDArray[np.float64]:
        """``min(n, pool)`` displacements ``(dx, dy, dtheta)`` of the sensor frame (m, m, rad), shape (S, 3)
        (:func:`sample_ego_poses`)."""
        return sample_ego_poses(odometry, dt, self.noise, min(n, self.pool), rng=rng)

    def rows(self, odometry: Odometry | None, dt: float, n: int, *, rng: np.random.Generator) -> NDArray[np.float64]:
        """:meth:`poses` (the same draws and arithmetic, compiled: :func:`ego_rows_from`) as rows dx, dy,
        cos(dtheta), sin(dtheta), shape (4, S)."""
        sd, control, dt = self._kernel_args(odometry, dt)
        return ego_rows_from(rng, min(n, self.pool), sd, control, dt, _OMEGA_EPS)

    def rows_drawn(self, odometry: Odometry | None, dt: float, n: int, *, seed: np.uint64 | int) -> NDArray[np.float64]:
        """:meth:`rows` with the normal draws made in the kernel from a SplitMix64 stream (``seed``, 64 bits;
        :func:`ego_rows_drawn`): the same distribution, other draws; shape (4, S)."""
        sd, control, dt = self._kernel_args(odometry, dt)
        return ego_rows_drawn(np.uint64(seed), min(n, self.pool), sd, control, dt, _OMEGA_EPS)

    def _kernel_args(
        self, odometry: Odometry | None, dt: float
    ) -> tuple[NDArray[np.float64], tuple[float, float, float], float]:
        """The noise sd of ``(v, omega, gamma)``, the control ``(v, omega, vy)`` and ``dt`` as the kernels take them."""
        dt = check_positive(dt, "dt")
        o = Odometry() if odometry is None else odometry
        sd = np.sqrt(np.asarray(self.noise.variances(o.v, o.omega), dtype=np.float64))
        return sd, (float(o.v), float(o.omega), float(o.vy)), dt


def sample_ego_poses(
    odometry: Odometry | None,
    dt: float,
    noise: SensorMotionNoise,
    n: int,
    *,
    rng: np.random.Generator,
) -> NDArray[np.float64]:
    """``n`` displacements ``(dx, dy, dtheta)`` of the sensor frame from the noisy velocity motion model (eqs. 10-11).

    The noise is on ``v``, ``omega`` and ``gamma``; ``odometry.vy`` (m/s, lateral) enters every draw unchanged.

    Returns
    -------
    ndarray, shape (n, 3)
        Displacement of the new sensor frame in the old one (m, m, rad).
    """
    dt = check_positive(dt, "dt")
    odo = Odometry() if odometry is None else odometry
    sd = np.sqrt(np.asarray(noise.variances(odo.v, odo.omega)))
    e = rng.standard_normal((3, n)) * sd[:, None]
    dx, dy, dth = velocity_displacement(odo.v + e[0], odo.omega + e[1], dt, e[2], vy=odo.vy)
    return np.column_stack((dx, dy, dth))


def apply_ego_motion(state: ParticleState, poses: NDArray[np.float64]) -> None:
    """Move every particle (and its velocity) into the new sensor frame (fields replaced by new arrays).

    Parameters
    ----------
    state : ParticleState
    poses : ndarray, shape (S, 3)
        Sampled displacements (from :func:`sample_ego_poses`), ``S <= N``. Particle k uses pose ``k mod S``:
        with ``S == N`` every particle has its own draw; with ``S < N`` each particle's displacement is still
        an exact draw from the motion model, and particles ``S`` apart in the arrays share it. (The poses are
        i.i.d., so a fixed assignment needs no further randomness.)
    """
    p = np.asarray(poses, dtype=float)
    n = state.size
    if p.ndim != 2 or p.shape[1] != 3 or not 1 <= len(p) <= max(n, 1):
        raise ValueError(f"poses must have shape (S, 3) with 1 <= S <= N={n}, got {p.shape}")
    cos_t, sin_t = np.cos(p[:, 2]), np.sin(p[:, 2])
    x, y, vx, vy = state.x, state.y, state.vx, state.vy
    out = np.empty((4, n))
    block = len(p)
    # Blocks of S particles (cache-sized), each block using poses 0..S-1; R(-dtheta) = [[c, s], [-s, c]].
    for b0 in range(0, n, block):
        b1 = min(b0 + block, n)
        m = b1 - b0
        dx, dy, c, s = p[:m, 0], p[:m, 1], cos_t[:m], sin_t[:m]
        xr = x[b0:b1] - dx
        yr = y[b0:b1] - dy
        np.multiply(c, xr, out=out[0, b0:b1])
        out[0, b0:b1] += s * yr
        np.multiply(c, yr, out=out[1, b0:b1])
        out[1, b0:b1] -= s * xr
        np.multiply(c, vx[b0:b1], out=out[2, b0:b1])
        out[2, b0:b1] += s * vy[b0:b1]
        np.multiply(c, vy[b0:b1], out=out[3, b0:b1])
        out[3, b0:b1] -= s * vx[b0:b1]
    state.x, state.y, state.vx, state.vy = out[0], out[1], out[2], out[3]


# ---------------------------------------------------------------- compiled forms


@jit
def _ego_row(
    e: tuple[float, float, float],
    sd: NDArray[np.float64],
    control: tuple[float, float, float],
    dt: float,
    eps: float,
    libm: bool,
) -> tuple[float, float, float, float]:
    """One sampled sensor displacement (eqs. 10-11) from its three standard normal draws ``e``: ``(dx, dy,
    cos(dtheta), sin(dtheta))`` (:func:`sample_ego_poses`'s arithmetic; arguments as
    :func:`ego_rows`), with the C library's sine and cosine (``libm``, numpy's) or :func:`draws.sincos`."""
    v0, w0, vy = control
    v = v0 + e[0] * sd[0]
    w = w0 + e[1] * sd[1]
    gamma = e[2] * sd[2]
    if abs(w) > eps:
        sw, cw = (math.sin(w * dt), math.cos(w * dt)) if libm else draws.sincos(w * dt)
        dx, dy = v / w * sw, v / w * (1.0 - cw)
        if vy != 0.0:
            dx, dy = dx - vy / w * (1.0 - cw), dy + vy / w * sw
    else:
        dx, dy = v * dt, 0.0
        if vy != 0.0:
            dx, dy = dx - 0.0, dy + vy * dt
    th = (w + gamma) * dt
    st, ct = (math.sin(th), math.cos(th)) if libm else draws.sincos(th)
    return dx, dy, ct, st


@jit
def ego_rows(
    e: NDArray[np.float64], sd: NDArray[np.float64], control: tuple[float, float, float], dt: float, eps: float
) -> NDArray[np.float64]:
    """Sampled sensor displacements (eqs. 10-11) as rows dx, dy, cos(dtheta), sin(dtheta):
    :func:`sample_ego_poses` from its standard normal draws ``e`` (3, S), bit for bit.

    ``sd`` are the noise sd of ``v``, ``omega`` and ``gamma``, ``control = (v, omega, vy)`` the odometry
    (m/s, rad/s, m/s), ``eps`` the yaw rate below which the motion is a straight line
    (:func:`gridbridge.velocity_displacement`).
    """
    n = e.shape[1]
    out = np.empty((4, n))
    for k in range(n):
        out[0, k], out[1, k], out[2, k], out[3, k] = _ego_row((e[0, k], e[1, k], e[2, k]), sd, control, dt, eps, True)
    return out


@jit
def ego_rows_from(
    g: np.random.Generator, n: int, sd: NDArray[np.float64], control: tuple[float, float, float], dt: float, eps: float
) -> NDArray[np.float64]:
    """:func:`ego_rows` of ``n`` displacements whose draws ``g.standard_normal((3, n))`` are made here, bit for bit
    numpy's (numba's ``Generator`` runs numpy's algorithms on the same bit generator), shape (4, n)."""
    return ego_rows(g.standard_normal((3, n)), sd, control, dt, eps)


@jit
def ego_rows_drawn(
    seed: np.uint64, n: int, sd: NDArray[np.float64], control: tuple[float, float, float], dt: float, eps: float
) -> NDArray[np.float64]:
    """:func:`ego_rows` of ``n`` displacements whose standard normal draws are made here (the ziggurat of
    :func:`draws.standard_normal` on the SplitMix64 stream ``seed``) and whose sines and cosines are
    :func:`draws.sincos`'s, shape (4, n)."""
    out = np.empty((4, n))
    state = seed
    for k in range(n):
        state, e0 = draws.standard_normal(state)
        state, e1 = draws.standard_normal(state)
        state, e2 = draws.standard_normal(state)
        out[0, k], out[1, k], out[2, k], out[3, k] = _ego_row((e0, e1, e2), sd, control, dt, eps, False)
    return out
