"""Particle-filter components: the sampling forms of the models and the resampling policy, as small objects.

:class:`pfpeople.ParticleFilter` is composed of components as :class:`gridbridge.GridFilter` is
(:mod:`gridbridge.components`): the model lives in the components, the filter is the loop. The update side is
shared with the grid filter (:class:`~gridbridge.likelihoods.DetectionLikelihood`,
:class:`~gridbridge.components.Appearance`, :class:`~gridbridge.components.BeliefBounds`); the particle side is:

===========================  ===================================================================================
component                    what it does
===========================  ===================================================================================
:class:`PaperSampling`       people motion, eqs. 5-9 sampled: a memoryless velocity from the paper's prior every
                             step (what the grid's linear prediction integrates;
                             :func:`pfpeople.particle.propagation.move_paper`)
:class:`PersistentSampling`  people motion whose walkers keep heading and speed from step to step
                             (:class:`~pfpeople.particle.propagation.PersistentMotion`; the grid cannot represent it)
:class:`VelocityEgoSampling` sensor motion, eqs. 10-11: Thrun's velocity motion model sampled per particle, at most
                             ``pool`` distinct draws per step (:func:`pfpeople.particle.propagation.sample_ego_poses`)
:class:`Resampling`          when (ESS below a threshold, births above a slack) and how (the scheme) the particles
                             are resampled by cell (:func:`pfpeople.particle.resampling.resample_by_cell`)
===========================  ===================================================================================

A people-motion sampler is any object with the :class:`PeopleSampler` interface (its ``motion`` gives the birth
velocities and the border inflow); the two built-in ones carry the ``name`` the run configuration's ``[filter]
motion_model`` key uses (:data:`PEOPLE_SAMPLERS`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from gridbridge.ego_motion import _OMEGA_EPS, Odometry
from gridbridge.params import PeopleMotion, SensorMotionNoise
from gridbridge.validation import check_choice, check_int, check_positive
from pfpeople.particle import step_kernels as kernels
from pfpeople.particle.propagation import PersistentMotion, move_paper, move_persistent, sample_ego_poses
from pfpeople.particle.resampling import RESAMPLERS, effective_sample_size, get_resampler
from pfpeople.particle.state import ParticleState

__all__ = [
    "PEOPLE_SAMPLERS",
    "PaperSampling",
    "PeopleSampler",
    "PersistentSampling",
    "Resampling",
    "VelocityEgoSampling",
]

#: A resampling scheme as a callable: ``f(weights, n, rng=rng) -> ancestors`` (:mod:`pfpeople.particle.resampling`).
Resampler = Callable[..., NDArray[np.intp]]


@runtime_checkable
class PeopleSampler(Protocol):
    """People motion in sampling form (eqs. 5-9 or a variant): moves particles over one step.

    ``move`` replaces the state's fields with new arrays (it never writes into them): velocities (m/s) and
    positions (m) after ``dt`` s, in the old sensor frame. ``motion`` is the paper's prior, from which newborn
    particles draw their velocities and whose integrated kernel gives the inflow across the border.
    ``redraw_in_cell``: each particle is first re-drawn uniformly inside its cell (the grid's assumption).
    """

    @property
    def motion(self) -> PeopleMotion: ...

    @property
    def redraw_in_cell(self) -> bool: ...

    def move(self, state: ParticleState, dt: float, *, rng: np.random.Generator) -> None: ...


def _check_sampler(motion: object, redraw_in_cell: object, where: str) -> None:
    if not isinstance(motion, PeopleMotion):
        raise TypeError(f"{where}.motion must be a PeopleMotion, got {type(motion).__name__}")
    if not isinstance(redraw_in_cell, bool):
        raise TypeError(f"{where}.redraw_in_cell must be a bool, got {type(redraw_in_cell).__name__}")


@dataclass(frozen=True, kw_only=True)
class PaperSampling:
    """The paper's people motion sampled per particle: stay with ``p_stationary``, else walk at a truncated-normal
    speed in a uniform direction, drawn afresh every step (:func:`pfpeople.particle.propagation.move_paper`).

    Parameters
    ----------
    motion : PeopleMotion
        Table 1 model.
    redraw_in_cell : bool
        Re-draw each particle uniformly in its cell before it moves: the prediction is then an unbiased estimate
        of the linear grid prediction (:class:`gridbridge.components.LinearPrediction`).
    """

    name: ClassVar[str] = "paper"
    motion: PeopleMotion = field(default_factory=PeopleMotion)
    redraw_in_cell: bool = False

    def __post_init__(self) -> None:
        _check_sampler(self.motion, self.redraw_in_cell, "PaperSampling")

    def move(self, state: ParticleState, dt: float, *, rng: np.random.Generator) -> None:
        """New memoryless velocities, then the move over ``dt`` s (fields replaced)."""
        move_paper(state, self.motion, dt, rng=rng)


@dataclass(frozen=True, kw_only=True)
class PersistentSampling:
    """Velocity-persistent people motion: walkers keep heading and speed with noise, stop and start at rates
    (:func:`pfpeople.particle.propagation.move_persistent`).

    Parameters
    ----------
    motion : PeopleMotion
        The paper's prior: the speed a walker relaxes to, ``v_max``, the velocities of those who start.
    persistent : PersistentMotion
        The persistence (heading and speed noise, stop and start rates).
    redraw_in_cell : bool
        Re-draw each particle uniformly in its cell before it moves.
    compiled_draws : bool
        With the compiled step (:func:`gridbridge.jit.enabled`, no re-draw in cells), draw the people motion, the
        births and the sensor motion's noise inside its kernels, as for :class:`PaperSampling`
        (:func:`pfpeople.particle.step_kernels.persistent_move_ego_compact`): the same distributions, other draws
        than the numpy path's, and no normal draw for a particle that stands. False (default): the numpy path's
        draws, bit for bit.
    """

    name: ClassVar[str] = "persistent"
    motion: PeopleMotion = field(default_factory=PeopleMotion)
    persistent: PersistentMotion = field(default_factory=PersistentMotion)
    redraw_in_cell: bool = False
    compiled_draws: bool = False

    def __post_init__(self) -> None:
        _check_sampler(self.motion, self.redraw_in_cell, "PersistentSampling")
        if not isinstance(self.compiled_draws, bool):
            raise TypeError(
                f"PersistentSampling.compiled_draws must be a bool, got {type(self.compiled_draws).__name__}"
            )
        if not isinstance(self.persistent, PersistentMotion):
            raise TypeError(
                f"PersistentSampling.persistent must be a PersistentMotion, got {type(self.persistent).__name__}"
            )

    def move(self, state: ParticleState, dt: float, *, rng: np.random.Generator) -> None:
        """Velocities carried on with noise, then the move over ``dt`` s (fields replaced)."""
        move_persistent(state, self.motion, self.persistent, dt, rng=rng)


#: The built-in people-motion samplers by the name of the run configuration's ``[filter] motion_model`` key.
PEOPLE_SAMPLERS: dict[str, type[PaperSampling] | type[PersistentSampling]] = {
    "paper": PaperSampling,
    "persistent": PersistentSampling,
}


@dataclass(frozen=True, kw_only=True)
class VelocityEgoSampling:
    """Sensor motion (eqs. 10-11) sampled per particle: Thrun's velocity motion model with ``noise``.

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
        """``min(n, pool)`` displacements ``(dx, dy, dtheta)`` of the sensor frame (m, m, rad), shape (S, 3)."""
        return sample_ego_poses(odometry, dt, self.noise, min(n, self.pool), rng=rng)

    def rows(self, odometry: Odometry | None, dt: float, n: int, *, rng: np.random.Generator) -> NDArray[np.float64]:
        """:meth:`poses` (the same draws and arithmetic, compiled) as rows dx, dy, cos(dtheta), sin(dtheta),
        shape (4, S)."""
        dt = check_positive(dt, "dt")
        o = Odometry() if odometry is None else odometry
        sd = np.sqrt(np.asarray(self.noise.variances(o.v, o.omega), dtype=np.float64))
        control = (float(o.v), float(o.omega), float(o.vy))
        return kernels.ego_rows_from(rng, min(n, self.pool), sd, control, dt, _OMEGA_EPS)

    def rows_drawn(self, odometry: Odometry | None, dt: float, n: int, *, seed: np.uint64 | int) -> NDArray[np.float64]:
        """:meth:`rows` with the normal draws made in the kernel from a SplitMix64 stream (``seed``, 64 bits;
        :func:`pfpeople.particle.step_kernels.ego_rows_drawn`): the same distribution, other draws; shape (4, S)."""
        dt = check_positive(dt, "dt")
        o = Odometry() if odometry is None else odometry
        sd = np.sqrt(np.asarray(self.noise.variances(o.v, o.omega), dtype=np.float64))
        control = (float(o.v), float(o.omega), float(o.vy))
        return kernels.ego_rows_drawn(np.uint64(seed), min(n, self.pool), sd, control, dt, _OMEGA_EPS)


@dataclass(frozen=True, kw_only=True)
class Resampling:
    """When and how the particle filter resamples by cell (:func:`pfpeople.particle.resampling.resample_by_cell`).

    A step resamples when ESS = (sum w)^2 / sum w^2 falls below ``ess_threshold * N`` or births pushed the count
    above ``(1 + max_overflow) * N``; resampling restores exactly N particles and keeps every cell's mass.

    Parameters
    ----------
    scheme : {"systematic", "stratified", "residual", "multinomial"} or callable
        The draws (:data:`pfpeople.particle.resampling.RESAMPLERS`), or a callable ``f(weights, n, rng=rng) ->
        ancestors`` (e.g. a baseline for benchmarks).
    ess_threshold : float
        >= 0; a value above 1 resamples every step, 0 only on overflow.
    max_overflow : float
        >= 0. Births may push the count up to ``(1 + max_overflow) * N`` before they trigger a resampling (0:
        every overflow resamples); a slack lets the births of several steps accumulate.
    """

    scheme: str | Resampler = "systematic"
    ess_threshold: float = 0.5
    max_overflow: float = 0.0

    def __post_init__(self) -> None:
        if isinstance(self.scheme, str):
            check_choice(self.scheme, "Resampling.scheme", tuple(RESAMPLERS))
        elif not callable(self.scheme):
            kind = type(self.scheme).__name__
            raise TypeError(f"Resampling.scheme must be a name in {tuple(RESAMPLERS)} or a callable, got {kind}")
        check_positive(self.ess_threshold, "Resampling.ess_threshold", allow_zero=True)
        check_positive(self.max_overflow, "Resampling.max_overflow", allow_zero=True)

    @property
    def resampler(self) -> Resampler:
        """The scheme as a callable."""
        return get_resampler(self.scheme) if isinstance(self.scheme, str) else self.scheme

    def capacity(self, n: int) -> int:
        """The largest particle count between resamplings for a target of ``n``."""
        return math.ceil(n * (1.0 + self.max_overflow))

    def due(self, weights: NDArray[np.float64], n: int) -> bool:
        """Whether particles of masses ``weights`` (shape (K,)) are resampled to a target of ``n``."""
        return self.due_ess(weights.size, effective_sample_size(weights), n)

    def due_ess(self, size: int, ess: float, n: int) -> bool:
        """:meth:`due` for ``size`` particles of effective sample size ``ess`` (``(sum w)^2 / sum w^2``)."""
        return bool(size > n * (1.0 + self.max_overflow) or ess < self.ess_threshold * n)
