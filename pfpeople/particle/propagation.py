"""Sampling forms of the people-motion and sensor-motion models (the particle side of eqs. 5-11).

People motion, ``"paper"`` model (Batista & Pereira 2015, Sect. 3.1.1; the same :class:`PeopleMotion` the grid
turns into a kernel): over a step of ``dt`` a person stays put with probability ``p_stationary``; otherwise
they walk at a speed ``s`` ~ N(mu, sigma) truncated to [0, v_max] in a uniform direction. The velocity is
memoryless (drawn afresh every step). The truncated normal is sampled exactly by inverse CDF,

    s = mu + sigma * Phi^-1( Phi(a) + U (Phi(b) - Phi(a)) ),   a = -mu / sigma,  b = (v_max - mu) / sigma,

which is the density :func:`gridbridge.truncated_speed_pdf`. A particle drawn uniformly in cell k and moved
this way lands in cell c with probability ``T(c <- k)``, the integrated kernel of
:func:`gridbridge.people_motion_kernel` (``form="integrated"``).

People motion, ``"persistent"`` model (:class:`PersistentMotion`, which the grid cannot represent because it
has no velocity state): a walker keeps heading and speed from step to step with noise,

    heading += N(0, heading_noise^2 dt),
    speed   += speed_reversion (mu - speed) dt + N(0, speed_noise^2 dt)    (reflected into [0, v_max]),

a walker stops with probability ``p_stop`` per second and a standing person starts with probability
``p_start`` per second (per step ``1 - (1 - p)^dt``); a person who starts draws speed and heading from the
paper's prior. Standing is ``vx = vy = 0``.

Sensor motion (eqs. 10-11): Thrun's ``sample_motion_model_velocity`` (Probabilistic Robotics, Table 5.3):
executed controls ``v_hat = v + e1``, ``w_hat = w + e2`` and a final rotation ``gamma_hat = e3`` with the
variances of :meth:`SensorMotionNoise.variances`, mapped to the displacement ``(dx, dy, dtheta)`` of the new
sensor frame in the old one by :func:`gridbridge.velocity_displacement`, with the odometry's lateral speed
``vy`` (a sensor mounted off the rotation axis) in the mean of every draw (no noise on it). A point (and a
velocity) moves into the new sensor frame as ``p_new = R(-dtheta) (p_old - t)``, ``v_new = R(-dtheta) v_old``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import special

from gridbridge import GridSpec, Odometry, PeopleMotion, SensorMotionNoise, jit, velocity_displacement
from gridbridge.validation import check_positive, check_probability
from pfpeople.particle import step_kernels as kernels
from pfpeople.particle.state import ParticleState

__all__ = [
    "PersistentMotion",
    "apply_ego_motion",
    "move_paper",
    "move_persistent",
    "redraw_in_cells",
    "sample_ego_poses",
    "sample_speeds",
    "sample_velocity_prior",
    "speeds_from_uniform",
]


@dataclass(frozen=True, kw_only=True)
class PersistentMotion:
    """Parameters of the velocity-persistent people motion model (see the module docstring).

    Parameters
    ----------
    heading_noise : float
        Heading random walk intensity (rad / sqrt(s)): heading sd after 1 s of walking.
    speed_noise : float
        Speed noise intensity (m/s / sqrt(s)).
    speed_reversion : float
        Rate (1/s) at which speed relaxes towards ``PeopleMotion.mu``; 0 gives a pure random walk.
    p_stop : float
        Probability per second that a walking person stops.
    p_start : float
        Probability per second that a standing person starts walking.

    Notes
    -----
    ``heading_noise = 1.0`` (57 deg after 1 s, 18 deg per 0.1 s step) and ``p_stop = p_start = 0.5`` (were 0.5,
    0.2, 0.2) were chosen with the recommended particle filter's tracks (``pfpeople run`` with ``[filter] kind =
    "particle"`` on the scan-level scenes, the ETH/UCY replays as the benchmark replays them): MOTA of the tracks,
    mean over the particle filter's seeds 0, 1, 2::

        heading, p_stop = p_start   eth    hotel  zara01  wheelchair  corridor  crowd
        0.5, 0.2                    .753   .524   .640    .542        .827      .716
        1.0, 0.2                    .754   .576   .656    .558        .835      .718
        1.5, 0.2                    .757   .538   .669    .545        .825      .714 (crowd: seeds 0, 1)
        1.0, 0.3 (seed 1)           .789   .556   .672    .548        .846      .711
        **1.0, 0.5**                .799   .612   .666    .573        .844      .729
        1.0, 1.0 (seed 1)           .711   .597   .631    .559        .514      -

    (seed 1 of 1.0, 0.5: .813, .597, .662, .587, .845, .733.) At 1.0 per second the corridor's people found
    fall to a precision of 0.87 (0.99 at 0.5): too many particles change mode every step for a blob to stay
    compact. With the paper's memoryless model instead (a new direction every step), the same filter's tracks
    gave .478, .290, .442, .377, .479, .446 (seed 0).
    """

    heading_noise: float = 1.0
    speed_noise: float = 0.3
    speed_reversion: float = 0.5
    p_stop: float = 0.5
    p_start: float = 0.5

    def __post_init__(self) -> None:
        check_positive(self.heading_noise, "PersistentMotion.heading_noise", allow_zero=True)
        check_positive(self.speed_noise, "PersistentMotion.speed_noise", allow_zero=True)
        check_positive(self.speed_reversion, "PersistentMotion.speed_reversion", allow_zero=True)
        check_probability(self.p_stop, "PersistentMotion.p_stop")
        check_probability(self.p_start, "PersistentMotion.p_start")


def sample_speeds(motion: PeopleMotion, n: int, *, rng: np.random.Generator) -> NDArray[np.float64]:
    """``n`` walking speeds (m/s) from N(mu, sigma) truncated to [0, v_max], sampled exactly (inverse CDF)."""
    return speeds_from_uniform(motion, rng.random(n))


def speeds_from_uniform(motion: PeopleMotion, u: NDArray[np.float64]) -> NDArray[np.float64]:
    """Walking speeds (m/s) of the truncated normal by inverse CDF from uniforms ``u`` in [0, 1), any shape."""
    lo = special.ndtr(-motion.mu / motion.sigma)
    hi = special.ndtr((motion.v_max - motion.mu) / motion.sigma)
    s = motion.mu + motion.sigma * special.ndtri(lo + u * (hi - lo))
    return np.clip(s, 0.0, motion.v_max, out=s)


def sample_velocity_prior(
    motion: PeopleMotion, n: int, *, rng: np.random.Generator
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Velocities ``(vx, vy)`` (m/s), each ``(n,)``, from the paper's motion prior.

    Zero with probability ``p_stationary``, else a truncated-normal speed in a uniform direction.
    """
    u = rng.random(n)
    vx = np.zeros(n)
    vy = np.zeros(n)
    p_stat = motion.p_stationary
    if p_stat >= 1.0:
        return vx, vy
    moving = np.flatnonzero(u >= p_stat)
    # Given u >= p_stat, (u - p_stat) / (1 - p_stat) is uniform on [0, 1): it serves as the speed's uniform.
    speed = speeds_from_uniform(motion, (u[moving] - p_stat) / (1.0 - p_stat))
    heading = rng.random(moving.size) * (2.0 * math.pi)
    vx[moving] = speed * np.cos(heading)
    vy[moving] = speed * np.sin(heading)
    return vx, vy


def redraw_in_cells(state: ParticleState, spec: GridSpec, *, rng: np.random.Generator) -> None:
    """Move every particle to a uniform position inside the cell that holds it (fields replaced by new arrays).

    With this, the paper-model prediction of the particles is an unbiased estimate of the linear grid
    prediction with the integrated kernel (the grid forgets where in a cell a person is).
    """
    u, v = spec.to_fractional(state.x, state.y)
    r = rng.random((2, state.size))
    state.x, state.y = spec.cell_centre(np.floor(u) + r[0] - 0.5, np.floor(v) + r[1] - 0.5)


def move_paper(state: ParticleState, motion: PeopleMotion, dt: float, *, rng: np.random.Generator) -> None:
    """The paper's people motion, sampled per particle: new memoryless velocity, then move.

    The state's fields are replaced by new arrays (the old arrays are not written to).
    """
    vx, vy = sample_velocity_prior(motion, state.size, rng=rng)
    state.vx, state.vy = vx, vy
    state.x = state.x + vx * dt
    state.y = state.y + vy * dt


def move_persistent(
    state: ParticleState,
    motion: PeopleMotion,
    params: PersistentMotion,
    dt: float,
    *,
    rng: np.random.Generator,
) -> None:
    """The velocity-persistent people motion (fields replaced by new arrays); see the module docstring.

    Compiled (:func:`pfpeople.particle.step_kernels.persistent_walk`, which makes the draws from ``rng``, and
    ``persistent_velocities``) when :func:`gridbridge.jit.enabled`, else :func:`_move_persistent_numpy`: the same
    draws in the same order and the same particles bit for bit.
    """
    if not jit.enabled("pfpeople"):
        _move_persistent_numpy(state, motion, params, dt, rng=rng)
        return
    heading = np.arctan2(state.vy, state.vx)  # numpy's (its SIMD atan2 is not the C library's)
    rates = (1.0 - (1.0 - params.p_stop) ** dt, 1.0 - (1.0 - params.p_start) ** dt)
    sqdt = math.sqrt(dt)
    walk = (
        float(params.heading_noise * sqdt),
        float(params.speed_reversion),
        float(motion.mu),
        float(dt),
        float(params.speed_noise * sqdt),
        float(motion.v_max),
    )
    speed, heading, new_idx, zero, u_speed = kernels.persistent_walk(rng, state.vx, state.vy, heading, rates, walk)
    speed[new_idx] = speeds_from_uniform(motion, u_speed)
    out = kernels.persistent_velocities(state.x, state.y, speed, heading, zero, float(dt))
    state.x, state.y, state.vx, state.vy = out[0], out[1], out[2], out[3]


def _move_persistent_numpy(
    state: ParticleState,
    motion: PeopleMotion,
    params: PersistentMotion,
    dt: float,
    *,
    rng: np.random.Generator,
) -> None:
    """:func:`move_persistent` in numpy (the compiled kernels' twin)."""
    n = state.size
    speed = np.hypot(state.vx, state.vy)
    heading = np.arctan2(state.vy, state.vx)
    walking = speed > 0.0
    u = rng.random(n)
    p_stop = 1.0 - (1.0 - params.p_stop) ** dt
    p_start = 1.0 - (1.0 - params.p_start) ** dt
    stops = walking & (u < p_stop)
    starts = ~walking & (u < p_start)
    noise = rng.standard_normal((2, n))
    sqdt = math.sqrt(dt)
    heading = heading + params.heading_noise * sqdt * noise[0]
    speed = speed + params.speed_reversion * (motion.mu - speed) * dt + params.speed_noise * sqdt * noise[1]
    speed = np.abs(speed)  # reflect at 0 ...
    speed = np.where(speed > motion.v_max, 2.0 * motion.v_max - speed, speed)  # ... and at v_max
    speed = np.clip(speed, 0.0, motion.v_max)
    new_idx = np.flatnonzero(starts)
    fresh_speed = sample_speeds(motion, new_idx.size, rng=rng)
    fresh_heading = rng.random(new_idx.size) * (2.0 * math.pi)
    speed[new_idx] = fresh_speed
    heading[new_idx] = fresh_heading
    stand = stops | ~(walking | starts)
    state.vx = np.where(stand, 0.0, speed * np.cos(heading))  # +0 where standing (never -0)
    state.vy = np.where(stand, 0.0, speed * np.sin(heading))
    state.x = state.x + state.vx * dt
    state.y = state.y + state.vy * dt


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
