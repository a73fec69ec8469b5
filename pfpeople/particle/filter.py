"""The particle filter, rasterised into the same semantic grid as the reference grid filter.

Particles carry occupancy mass (:mod:`pfpeople.particle.state`): the sum of weights in a cell is that cell's
probability of holding a person, i.e. the grid filter's belief. One step (same input as
:meth:`gridbridge.GridFilter.step`; :meth:`ParticleFilter.predict` is phases 1-2 and the empty-cell prior of
phase 4, :meth:`ParticleFilter.update` the rest, each phase one private method):

1. **People motion** (eqs. 5-9, sampling form: the ``people_motion`` component, :mod:`pfpeople.particle.components`).
   Optionally (its ``redraw_in_cell``) each particle is first re-drawn uniformly inside its cell. Particles that
   leave the grid are dropped. Inflow: the grid reads belief ``outside`` (0.5) beyond its border, so the mass
   entering inside cell c is ``outside * sum_{k outside} T(c <- k)`` with the integrated kernel T (computed once
   per (grid, dt) as a convolution of an all-zero grid with ``cval=outside``); it is born as particles in those
   cells.
2. **Sensor motion** (eqs. 10-11). Each particle samples Thrun's velocity motion model and moves into the new
   sensor frame with rotation. Particles that leave are dropped. Inflow: the grid's warp reads ``outside``
   beyond the border, so the entering mass is ``warp_belief(zeros, outside=outside)`` (the grid's own sigma
   point warp); it is born as particles.
3. **Update** (eqs. 12-14). The prior of cell c is its rasterised mass m_c (the inflows included); the
   likelihood L_c comes from :func:`gridbridge.likelihood_from_detections`, the code the grid filter uses;
   the posterior is ``p_c = bayes_update(m_c, L_c)`` and the particles in c are scaled by ``p_c / m_c``, so they
   share the posterior in proportion to their weights. Monte Carlo noise can put slightly more than 1 into a
   cell; m_c is clipped to [0, 1] for eq. 12 only.
4. **Empty cells** (no particle after the prediction). *Empty-cell prior*: such a cell gets the analytic
   linear prediction of the previous posterior (integrated-kernel convolution, then the grid's sensor warp,
   both with border value ``outside``); it is computed only in steps that have an empty cell. If its posterior
   exceeds ``BIRTH_FLOOR`` (1e-12), ``n_birth`` particles are born there sharing that mass, uniform in the cell,
   with velocities from the motion prior (as Nuss et al.). Below the floor the cell's posterior is set to 0
   (the mass ignored is below 1e-12 per cell).
5. **Resampling** (:func:`pfpeople.particle.resampling.resample_by_cell`; the ``resampling`` component) when
   ESS = (sum w)^2 / sum w^2 falls below ``ess_threshold * n_particles`` or births pushed the count above
   ``(1 + max_overflow) * n_particles``. It restores exactly ``n_particles`` particles, keeps every cell's mass,
   and keeps at least one particle in every cell with mass.

Births at the border fill the free slots (particles that left): each inflow cell gets one particle plus a share
of the free slots in proportion to its mass (the people-motion births use half of the free slots, the
sensor-motion births the rest), so the count stays at or below ``n_particles`` unless there are more inflow
cells than free slots, which triggers a resampling. On the paper's grid 224 cells receive inflow in a 0.1 s step,
more than a step usually frees, so with ``max_overflow = 0`` most steps resample whatever the ESS. With a slack
(``max_overflow = 0.1``, the recommended mode's; about 3 % births per step on the person-following bag) the births
of a few steps accumulate: on the person-following bag 29 % of the steps resample (22 % for the count, 8 % for
the ESS), with a median ESS of 0.93 N between resamplings, and the filter step costs about a fifth less.

Equivalence (tested in ``tests/pfpeople/particle/test_pf_equivalence.py``): with ``PaperSampling(redraw_in_cell=True)``
and a standing robot, the expected rasterised prior equals the linear grid filter's prior with the integrated kernel
(``GridFilter(form="linear")``): the PF is an unbiased Monte Carlo estimate of that prediction, with error
~ 1/sqrt(N). With the robot moving, the grid's bilinear warp (applied to a belief
assumed uniform within cells) and its sigma points are approximations that the particles do not make, which
leaves a floor.

Ego-motion poses (the ``ego_motion`` component): with at most ``pool`` particles every particle draws its own
displacement; above, ``pool`` i.i.d. exact draws are shared (particle k uses draw k mod ``pool``), so each
particle's displacement is still an exact draw while the cost of the trigonometry stays fixed.

Compiled step: with numba (and ``PFPEOPLE_NUMBA`` not ``0``, :mod:`gridbridge.jit`) phases 1-2 run as one pass
over the particles (:mod:`pfpeople.particle.step_kernels`: people motion, sensor motion, the particles that left
dropped, both priors summed), phase 3 scales the weights in one pass and phase 5 resamples in two passes without a sort
(when the prediction's sums per cell tell that the step resamples, from the unscaled weights, without the scaling
pass); the arrays come from a pool of those the filter let go of (:mod:`pfpeople.particle.buffers`). With the paper's
people motion (:class:`~pfpeople.particle.components.PaperSampling` without ``redraw_in_cell``, the default) the
people motion, the births and the systematic resampling draw inside the kernels from SplitMix64 streams seeded by
:attr:`ParticleFilter.rng` (:mod:`pfpeople.particle.rng_kernels`): a seed still gives the same particles every time,
but not the numpy path's; the distributions are the same (``tests/pfpeople/particle/test_compiled_draws.py``, also
the belief's agreement with the numpy path to the Monte Carlo noise). Any other configuration makes the numpy path's
random draws in the same order and the same arithmetic in the same order, and gives its particles bit for bit
(``tests/pfpeople/particle/test_kernels_particles.py``) as long as it does not resample systematically.

Bias of the empty-cell prior: a cell that is empty by chance gets the analytic prior instead of its (zero)
particle mass, so the prior's expectation exceeds the linear grid's by P(empty) * prior. It matters only
when cells hold about one particle: measured after one step from the uniform start (standing robot, 20 seeds),
the total prior mass is +5.3 % at N = 1000 on the 900-cell grid, +0.3 % at N = 2000, +0.03 % at N = 5000.
Use at least about 5 particles per cell.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge import (
    PAPER_DETECTORS,
    DetectorModel,
    FilterStep,
    GridSpec,
    Likelihood,
    Odometry,
    as_odometry,
    bayes_update,
    ego_motion_sigma_points,
    fov_mask,
    jit,
    people_motion_kernel,
    predict_people,
    warp_belief,
)
from gridbridge import kernels as grid_kernels
from gridbridge.components import Appearance, BeliefBounds
from gridbridge.ego_motion import border_inflow
from gridbridge.filter import Prediction, filter_models, remounted, with_fields_of_view
from gridbridge.likelihoods import DetectionLikelihood, update_components
from gridbridge.limits import check_dt, check_grid_size
from gridbridge.people_motion import check_people_step, outside_inflow, quantise_dt
from gridbridge.validation import check_int, check_probability
from pfpeople.limits import check_particles
from pfpeople.particle import rng_kernels
from pfpeople.particle import step_kernels as kernels
from pfpeople.particle.buffers import BufferPool
from pfpeople.particle.components import (
    PaperSampling,
    PeopleSampler,
    PersistentSampling,
    Resampling,
    VelocityEgoSampling,
)
from pfpeople.particle.propagation import apply_ego_motion, redraw_in_cells, sample_velocity_prior
from pfpeople.particle.resampling import resample_by_cell, resample_scaled, resample_state, systematic
from pfpeople.particle.state import ParticleState, uniform_in_cells

__all__ = ["BIRTH_FLOOR", "ParticleFilter", "ParticleStep"]

log = logging.getLogger(__name__)

#: Cells whose posterior (or inflow) mass is at most this get no particles.
BIRTH_FLOOR = 1e-12

_Rows = tuple[NDArray[np.float64], ...]
#: What the compiled prediction returns: particles, cells, count per cell, people and sensor priors, sigma points and
#: the squared masses per cell (None but for the paper's people motion).
_Compiled = tuple[
    "ParticleState",
    NDArray[np.intp],
    NDArray[np.intp],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64] | None,
]

#: The sensor displacement rows of a standing robot (the compiled sensor motion leaves the particles alone).
_NO_POSES = np.zeros((4, 1))


@dataclass(frozen=True, eq=False)
class ParticleStep(FilterStep):
    """The stages of :class:`gridbridge.FilterStep` plus the particles after the step.

    Attributes
    ----------
    particles : ParticleState
        The particles after update and resampling: a shallow copy of the filter's state, sharing its arrays
        (later steps replace the filter's arrays and never write into them; copy before writing into these).
    resampled : bool
        Whether this step resampled.
    """

    particles: ParticleState
    resampled: bool = False


class ParticleFilter:
    """People particle filter whose rasterised weights are the semantic grid's belief, composed of components.

    The model is in the components (:mod:`pfpeople.particle.components` for the particle side, the update's shared with
    :class:`gridbridge.GridFilter`), each defaulting to the paper's; the filter is the loop of the module docstring.

    Parameters
    ----------
    spec : GridSpec, optional
        The grid (default: the paper's 30 x 30 cells of 0.3 m).
    detectors : sequence of DetectorModel
        Detector models, in the order of the detections passed to :meth:`step`.
    n_particles : int
        Particle count N restored by every resampling (between resamplings up to ``(1 + max_overflow) N``, see
        ``resampling``); at least the number of grid cells.
    rng : numpy.random.Generator
        The only source of randomness: same seed, same output.
    people_motion : PeopleSampler, optional
        People motion in sampling form (default :class:`~pfpeople.particle.components.PaperSampling`: the paper's
        memoryless model; :class:`~pfpeople.particle.components.PersistentSampling`: walkers keep heading and speed).
    ego_motion : VelocityEgoSampling, optional
        Sensor motion in sampling form (default: the default odometry noise, at most 4096 draws per step).
    resampling : Resampling, optional
        When and how to resample (default: systematic when ESS < N / 2 or the births overflow N).
    likelihood : DetectionLikelihood, optional
        Detections -> per-cell likelihood (default: the paper's De Morgan fusion, shared with the grid filter).
    appearance : Appearance, optional
        Birth probability added to the prior of the update in observed cells (particles scaled up, or born in
        empty cells).
    bounds : BeliefBounds, optional
        Clamp of the posterior.
    initial : float
        Initial belief of every cell.
    outside : float
        Belief outside the grid (0.5 in the paper): the inflow across the border in both motions.
    n_birth : int
        Particles born in an empty cell whose posterior has mass.

    Attributes
    ----------
    motion : PeopleMotion
        ``people_motion.motion``: the prior of the births' velocities and the kernel of the border inflow.
    noise : SensorMotionNoise
        ``ego_motion.noise``: also the grid's sigma points of the border inflow and the empty-cell prior.
    """

    def __init__(
        self,
        spec: GridSpec | None = None,
        *,
        detectors: Sequence[DetectorModel] = PAPER_DETECTORS,
        n_particles: int = 10_000,
        rng: np.random.Generator,
        people_motion: PeopleSampler | None = None,
        ego_motion: VelocityEgoSampling | None = None,
        resampling: Resampling | None = None,
        likelihood: DetectionLikelihood | None = None,
        appearance: Appearance | None = None,
        bounds: BeliefBounds | None = None,
        initial: float = 0.5,
        outside: float = 0.5,
        n_birth: int = 2,
    ) -> None:
        components = _sampling_components(people_motion, ego_motion, resampling)
        self.people_motion, self.ego_motion, self.resampling = components
        self.spec, self.detectors, self.motion, self.noise = filter_models(
            spec, detectors, self.people_motion.motion, self.ego_motion.noise
        )
        self.n_particles = self._checked_count(n_particles)
        if not isinstance(rng, np.random.Generator):
            raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        self.rng = rng
        self.initial = check_probability(initial, "initial")
        self.outside = check_probability(outside, "outside")
        self.n_birth = _check_count(n_birth, "n_birth")
        self.likelihood, self.appearance, self.bounds = update_components(likelihood, appearance, bounds)
        self.observed = np.logical_or.reduce([fov_mask(self.spec, m) for m in self.detectors]).ravel()
        self._inflow_cache: dict[float, NDArray[np.float64]] = {}
        self._ego_inflow_cache: dict[bytes, NDArray[np.float64]] = {}
        self._inflow_cells_cache: dict[int, tuple[object, NDArray[np.intp], NDArray[np.float64], float]] = {}
        self.state = ParticleState.empty()
        self.belief: NDArray[np.float64] = np.zeros(self.spec.shape)
        self._pending: _Pending | None = None
        #: The compiled prediction's buffer (rows x, y, vx, vy, w), its cells and the columns in use.
        self._buffer: tuple[_Rows, NDArray[np.intp], int] | None = None
        #: Arrays of earlier steps, reused by the compiled path once nothing else holds them.
        self._pool = BufferPool()
        #: Steps whose resampling was skipped because every weight was 0 (logged as a warning).
        self.resampling_skipped = 0
        self.reset()

    def _checked_count(self, n_particles: int) -> int:
        """``n_particles`` checked: a count of at least the grid's cells whose largest count between resamplings
        fits the memory limits (:func:`pfpeople.limits.check_particles`)."""
        n = _check_count(n_particles, "n_particles")
        check_grid_size(self.spec.nx, self.spec.ny, self.spec.resolution, v_max=self.motion.v_max, dt=self.motion.dt)
        where = "n_particles" if self.resampling.max_overflow == 0 else "n_particles x (1 + max_overflow)"
        most = self.resampling.capacity(n)
        check_particles(most, n_cells=self.spec.n_cells, n_detectors=len(self.detectors), where=where)
        if n < self.spec.n_cells:
            raise ValueError(f"n_particles must be at least the number of grid cells ({self.spec.n_cells}), got {n}")
        return n

    # ------------------------------------------------------------------ state

    def set_detector_mounts(self, mounts: Sequence[tuple[float, float, float]]) -> None:
        """Move the detectors: ``(mount_x, mount_y, mount_yaw)`` per detector (m, rad; a panning laser's mount
        at this frame). Their fields of view follow from the next update."""
        self.detectors = remounted(self.detectors, mounts)
        self.observed = np.logical_or.reduce([fov_mask(self.spec, m) for m in self.detectors]).ravel()

    def set_detector_fields_of_view(self, views: Sequence[tuple[float, float]]) -> None:
        """Narrow or restore the detectors' fields of view: ``(fov_min, fov_max)`` per detector (rad), as
        :meth:`gridbridge.GridFilter.set_detector_fields_of_view`."""
        self.detectors = with_fields_of_view(self.detectors, views)
        self.observed = np.logical_or.reduce([fov_mask(self.spec, m) for m in self.detectors]).ravel()

    def reset(self, belief: ArrayLike | None = None) -> None:
        """Restart: ``n_particles`` spread evenly over the cells, uniform within each, carrying ``belief``.

        ``belief`` (nx, ny) defaults to ``initial`` everywhere. Cell c gets ``N // n_cells`` particles (the
        first ``N % n_cells`` cells one more), each with mass ``belief_c / count_c``, velocities from the prior.
        """
        spec = self.spec
        bel = np.full(spec.shape, self.initial) if belief is None else spec.check_grid(belief, "belief").copy()
        n_cells = spec.n_cells
        per_cell = np.full(n_cells, self.n_particles // n_cells, dtype=np.intp)
        per_cell[: self.n_particles % n_cells] += 1
        cells = np.repeat(np.arange(n_cells, dtype=np.intp), per_cell)
        self.state = self._born(cells, bel.ravel()[cells] / per_cell[cells])
        self.belief = bel
        self._pending = None
        self._buffer = None

    @property
    def particles(self) -> ParticleState:
        """The current particles (the live state; copy before changing it)."""
        return self.state

    def _born(self, cells: NDArray[np.intp], weights: NDArray[np.float64]) -> ParticleState:
        """New particles in ``cells`` (flat indices), uniform in the cell, velocities from the motion prior (drawn
        inside a kernel, :func:`step_kernels.born_particles`, where the people motion is: :meth:`_draws_inside`)."""
        if self._draws_inside():
            seeds = self.rng.integers(0, 2**64, size=4, dtype=np.uint64)
            x, y, vx, vy = kernels.born_particles(np.asarray(cells, dtype=np.intp), seeds, self._walk(), self._grid())
            return ParticleState.of_checked(x, y, vx, vy, np.asarray(weights, dtype=np.float64))
        x, y = uniform_in_cells(self.spec, cells, rng=self.rng)
        vx, vy = sample_velocity_prior(self.motion, cells.size, rng=self.rng)
        return ParticleState(x=x, y=y, vx=vx, vy=vy, w=weights)

    def _draws_inside(self) -> bool:
        """Whether the compiled step draws the people motion and the births inside its kernels: the paper's people
        motion, or the persistent one with ``compiled_draws``, without the re-draw in cells (any other sampler
        draws as the numpy path, bit for bit)."""
        people = self.people_motion
        inside = type(people) is PaperSampling or (type(people) is PersistentSampling and people.compiled_draws)
        return jit.enabled("pfpeople") and inside and not people.redraw_in_cell

    def _walk(self) -> rng_kernels.WalkParams:
        """The paper's people motion as the kernels take it (:func:`rng_kernels.walk_params`)."""
        m = self.motion
        return rng_kernels.walk_params(m.p_stationary, m.mu, m.sigma, m.v_max)

    def _move_drawn(
        self,
        st: ParticleState,
        seeds: NDArray[np.uint64],
        dt: float,
        rows: NDArray[np.float64],
        moves: bool,
        grid: tuple[float, float, float, int, int],
        into: tuple[_Rows, NDArray[np.intp]],
        sums: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.intp], NDArray[np.float64]],
    ) -> tuple[int, int]:
        """Phases 1-2 with the people motion drawn inside the pass (:meth:`_draws_inside`): the paper's
        (:func:`step_kernels.paper_move_ego_compact`) or the persistent one
        (:func:`step_kernels.persistent_move_ego_compact`). Returns the survivors' count and the count inside
        after the people motion."""
        buf, cells = into
        if type(self.people_motion) is PersistentSampling:
            src = (st.x, st.y, st.vx, st.vy, st.w)
            return kernels.persistent_move_ego_compact(
                src, seeds, self._walk(), self._persist(dt), rows, moves, grid, buf, cells, sums
            )
        return kernels.paper_move_ego_compact(
            st.x, st.y, st.w, seeds, self._walk(), dt, rows, moves, grid, buf, cells, sums
        )

    def _persist(self, dt: float) -> tuple[float, float, float, float, float, float]:
        """The persistent people motion over ``dt`` s as :func:`step_kernels.persistent_move_ego_compact` takes it."""
        p = cast(PersistentSampling, self.people_motion).persistent
        sqdt = math.sqrt(dt)
        rates = (1.0 - (1.0 - p.p_stop) ** dt, 1.0 - (1.0 - p.p_start) ** dt)
        return (*rates, p.heading_noise * sqdt, p.speed_reversion, float(dt), p.speed_noise * sqdt)

    def _born_from_mass(self, mass: NDArray[np.float64], free: int) -> tuple[ParticleState, NDArray[np.intp]]:
        """Particles carrying ``mass`` (flat, per cell): one per cell above the floor plus a share of ``free``."""
        cells, m, total = self._inflow_cells(mass)
        if cells.size == 0:
            return ParticleState.empty(), np.zeros(0, dtype=np.intp)
        extra = max(free - cells.size, 0)
        counts = 1 + np.floor(extra * m / total).astype(np.intp)
        rep = np.repeat(cells, counts)
        return self._born(rep, np.repeat(m / counts, counts)), rep

    def _inflow_cells(self, mass: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.float64], float]:
        """The cells of ``mass`` above the floor, their masses and the sum of these: kept for the inflow grids the
        filter caches (read-only arrays, the same every step of the same dt and odometry), computed for others."""
        owner = _owner(mass)
        cached = self._inflow_cells_cache.get(id(owner))
        if cached is not None and cached[0] is owner:
            return cached[1], cached[2], cached[3]
        cells = np.flatnonzero(mass > BIRTH_FLOOR)
        m = mass[cells]
        total = float(m.sum())
        if isinstance(owner, np.ndarray) and not owner.flags.writeable:
            if len(self._inflow_cells_cache) >= 64:
                self._inflow_cells_cache.clear()
            self._inflow_cells_cache[id(owner)] = (owner, cells, m, total)
        return cells, m, total

    # ------------------------------------------------------------ prediction

    def people_inflow(self, dt: float) -> NDArray[np.float64]:
        """Mass entering each cell from outside over ``dt`` (nx, ny): ``outside * sum_{k out} T(c <- k)``."""
        key = quantise_dt(float(dt))  # the kernel's own dt grid: the cache stays small on jittering clocks
        cached = self._inflow_cache.get(key)
        if cached is None:
            kernel = people_motion_kernel(self.spec, self.motion, dt=dt, form="integrated")
            cached = outside_inflow(self.spec.shape, kernel, self.outside)
            cached.setflags(write=False)
            self._inflow_cache[key] = cached
        return cached

    def _ego_inflow(self, poses: NDArray[np.float64], pose_w: NDArray[np.float64]) -> NDArray[np.float64]:
        """Mass entering each cell (flat) across the border in the sensor motion: the grid's warp of an empty
        grid with border value ``outside`` (cached per sigma points: the same odometry gives the same warp)."""
        key = poses.tobytes() + pose_w.tobytes()
        cached = self._ego_inflow_cache.get(key)
        if cached is None:
            cached = border_inflow(self.spec, poses, pose_w, outside=self.outside).ravel()
            cached.setflags(write=False)
            if len(self._ego_inflow_cache) >= 64:
                self._ego_inflow_cache.clear()
            self._ego_inflow_cache[key] = cached
        return cached

    def _empty_cell_prior(
        self, dt: float, poses: NDArray[np.float64], pose_w: NDArray[np.float64], empty: NDArray[np.bool_]
    ) -> NDArray[np.float64]:
        """The linear grid prior of the previous posterior, warped with this step's sigma points, in the ``empty``
        cells (flat mask). Compiled: the prior only at the cells the warp's taps read
        (:func:`gridbridge.kernels.warp_taps`, :func:`gridbridge.kernels.convolve_at`), the warp only at the empty
        cells (:func:`gridbridge.kernels.warp_at`): the same floats as the whole grid's."""
        kernel = people_motion_kernel(self.spec, self.motion, dt=dt, form="integrated")
        p = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
        if not jit.enabled() or (len(p) == 1 and np.all(p[0] == 0.0)):  # (warp_belief's identity: a copy)
            people = predict_people(self.belief, kernel, outside=self.outside, form="linear")
            return warp_belief(people, self.spec, poses, pose_w, outside=self.outside).ravel()[empty]
        w = np.asarray(pose_w, dtype=np.float64).ravel()
        grid = (float(self.spec.x0), float(self.spec.y0), float(self.spec.resolution))
        cells = np.flatnonzero(empty)
        p = np.ascontiguousarray(p)
        taps = grid_kernels.warp_taps(self.spec.shape, grid, p, cells)
        bel = np.ascontiguousarray(self.belief, dtype=np.float64)
        people = grid_kernels.convolve_at(bel, np.ascontiguousarray(kernel), float(self.outside), taps)
        return grid_kernels.warp_at(people, grid, p, w / w.sum(), float(self.outside), cells)

    def predict(self, odometry: Odometry | tuple[float, float] | None, dt: float) -> Prediction:
        """Both predictions (phases 1-2 and the empty-cell prior of phase 4 in the module docstring).

        The particles move; the belief becomes the prior of the update: the rasterised mass with empty cells
        filled, clipped to [0, 1], appearances added. Arguments as in :meth:`step`; on bad input nothing changes.

        Returns
        -------
        Prediction
            ``people_prior`` and ``sensor_prior``, ``(nx, ny)`` each, the rasterised mass after each prediction
            (``sensor_prior`` with the empty cells filled, before the clip and the appearances).
        """
        dt = check_dt(dt)  # a number in (0, MAX_DT_S], before anything is allocated
        check_people_step(self.spec, self.motion, dt)
        odo = as_odometry(odometry)
        if jit.enabled("pfpeople"):
            st, cells, counts, people_prior, sensor_prior, poses, pose_w, sq = self._predict_compiled(odo, dt)
            empty = counts == 0
        else:
            # The filter never writes into particle arrays in place, so a shallow copy protects self.state.
            moved = self._predict_people(self.state.shallow_copy(), dt)
            st, cells, sensor_prior, poses, pose_w = self._predict_sensor(moved, odo, dt)
            people_prior, sq = moved.prior, None
            empty = np.bincount(cells, minlength=self.spec.n_cells) == 0
        if empty.any():
            sensor_prior[empty] = self._empty_cell_prior(dt, poses, pose_w, empty)
        self.state = st
        self._pending = self._prediction(cells, empty, people_prior, sensor_prior, dt, sq)
        self.belief = self._pending.prior.reshape(self.spec.shape)
        return Prediction(people_prior.reshape(self.spec.shape), sensor_prior.reshape(self.spec.shape))

    def update(self, detections: Sequence[ArrayLike | None]) -> ParticleStep:
        """Measurement update, births in empty cells and resampling (phases 3-5 in the module docstring).

        Without a :meth:`predict` since the last update the prior is the particles' rasterised mass (empty cells:
        the belief). ``detections`` as in :meth:`step`; on bad input nothing changes.

        Returns
        -------
        ParticleStep
            The stages of the step (the priors of the last :meth:`predict`) and the particles.
        """
        return self._update(self.likelihood(self.spec, self.detectors, list(detections)))

    def step(
        self,
        detections: Sequence[ArrayLike | None],
        odometry: Odometry | tuple[float, float] | None,
        dt: float,
    ) -> ParticleStep:
        """One filter step, :meth:`predict` then :meth:`update`: the arguments of :meth:`gridbridge.GridFilter.step`,
        bad input likewise changing nothing (the detections are checked before the prediction).

        Returns a :class:`ParticleStep` (the stages rasterised into (nx, ny) grids, plus the particles);
        ``self.state`` becomes the new particles.
        """
        check_dt(dt)  # before the likelihoods are computed
        lik = self.likelihood(self.spec, self.detectors, list(detections))
        self.predict(odometry, dt)
        return self._update(lik)

    # ---------------------------------------------------------------- phases

    def _predict_people(self, st: ParticleState, dt: float) -> _PeopleMoved:
        """Phase 1: people motion of ``st`` (fields replaced), and the births of the inflow across the border."""
        spec, n_cells = self.spec, self.spec.n_cells
        if self.people_motion.redraw_in_cell:
            redraw_in_cells(st, spec, rng=self.rng)
        self.people_motion.move(st, dt, rng=self.rng)
        # Particles that left are dropped; to compress the arrays once per step they are only masked here.
        cells = spec.flat_index(st.x, st.y)
        inside = cells >= 0
        n_inside = int(np.count_nonzero(inside))
        # Half of the free slots are left to the births of the sensor-motion stage.
        free = self.n_particles - n_inside
        born, born_cells = self._born_from_mass(self.people_inflow(dt).ravel(), free - max(free, 0) // 2)
        prior = np.bincount(cells + 1, weights=st.w, minlength=n_cells + 1)[1:].astype(np.float64)
        prior += np.bincount(born_cells, weights=born.w, minlength=n_cells)
        return _PeopleMoved(st, cells, inside, n_inside, born, born_cells, prior)

    def _predict_sensor(
        self, moved: _PeopleMoved, odo: Odometry | None, dt: float
    ) -> tuple[ParticleState, NDArray[np.intp], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Phase 2: ego-motion of the particles and the newborn (each with its own pose draws), births of the
        inflow, the particles that left dropped. Returns the particles, their cells, the rasterised mass (flat)
        and the sigma points ``(poses, weights)`` of the grid's warp."""
        spec, n_cells = self.spec, self.spec.n_cells
        poses, pose_w = ego_motion_sigma_points(odo, dt, self.noise)
        st, cells, inside, born = moved.state, moved.cells, moved.inside, moved.born
        if not np.any(poses != 0.0):  # standing: nothing moves, the people prior is the sensor prior
            if moved.n_inside < st.size:
                st, cells = st.take(inside), cells[inside]
            st = ParticleState.concatenate([st, born])
            return st, np.concatenate((cells, moved.born_cells)), moved.prior.copy(), poses, pose_w
        for part in (st, born):
            if part.size:
                sampled = self.ego_motion.poses(odo, dt, part.size, rng=self.rng)
                apply_ego_motion(part, sampled)
        cells = spec.flat_index(st.x, st.y)
        inside = inside & (cells >= 0)
        born_moved = spec.flat_index(born.x, born.y)
        born_in = born_moved >= 0
        ego_in = self._ego_inflow(poses, pose_w)
        n_now = moved.n_inside + int(np.count_nonzero(born_in))
        born2, born2_cells = self._born_from_mass(ego_in, self.n_particles - n_now)
        st = ParticleState.concatenate([st.take(inside), born.take(born_in), born2])
        cells = np.concatenate((cells[inside], born_moved[born_in], born2_cells))
        mass = np.bincount(cells, weights=st.w, minlength=n_cells).astype(np.float64, copy=False)
        return st, cells, mass, poses, pose_w

    def _grid(self) -> tuple[float, float, float, int, int]:
        """The grid as the kernels take it: ``(x0, y0, resolution, nx, ny)``."""
        spec, res = self.spec, float(self.spec.resolution)
        return (float(spec.x0), float(spec.y0), res, int(spec.nx), int(spec.ny))

    def _people_velocities(
        self, dt: float
    ) -> tuple[ParticleState, NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]:
        """Phase 1's draws for a people-motion sampler other than the paper's plain one (those of the numpy path, in
        its order): the particles to move (re-drawn in their cells with ``redraw_in_cell``), the indices of those
        that move (all) and their velocities (m/s)."""
        st = self.state
        moved = st.shallow_copy()
        if self.people_motion.redraw_in_cell:
            redraw_in_cells(moved, self.spec, rng=self.rng)
        x, y = moved.x, moved.y  # the positions the motion starts from (the kernel moves them)
        self.people_motion.move(moved, dt, rng=self.rng)  # its velocities (its positions are the kernel's)
        before = ParticleState(x=x, y=y, vx=moved.vx, vy=moved.vy, w=st.w)
        return before, np.arange(st.size, dtype=np.intp), moved.vx, moved.vy

    def _predict_compiled(self, odo: Odometry | None, dt: float) -> _Compiled:
        """Phases 1-2 in one pass over the particles (compiled).

        The paper's people motion (:class:`PaperSampling` without the re-draw), and the persistent one with
        ``compiled_draws``, are drawn inside the pass (:meth:`_move_drawn`, seeded from :attr:`rng`): the same
        distributions as the numpy path, other draws. Any other sampler draws as on the numpy path, whose particles
        the pass then gives bit for bit; its births at the border need the count inside after the people motion
        first, so a counting pass (:func:`step_kernels.people_prior`) precedes.
        """
        n_cells, grid = self.spec.n_cells, self._grid()
        poses, pose_w = ego_motion_sigma_points(odo, dt, self.noise)
        moves = bool(np.any(poses != 0.0))
        st = self.state
        prior, mass, counts, sq = np.zeros(n_cells), np.zeros(n_cells), np.zeros(n_cells, dtype=np.intp), None
        cap = max(st.size, self.n_particles) + (3 + self.n_birth) * n_cells + 8
        buf, cells = tuple(self._pool.take(cap) for _ in range(5)), self._pool.take_index(cap)
        if self._draws_inside():
            rows = self._ego_rows(odo, dt, st.size, moves)
            seeds, sq = self.rng.integers(0, 2**64, size=4, dtype=np.uint64), np.zeros(n_cells)
            j, n_inside = self._move_drawn(st, seeds, dt, rows, moves, grid, (buf, cells), (prior, mass, counts, sq))
            born, born_cells = self._people_births(dt, n_inside)
            born_rows = self._ego_rows(odo, dt, born.size, moves)
        else:
            before, moving, vx_m, vy_m = self._people_velocities(dt)
            n_inside = kernels.people_prior(before.x, before.y, before.w, moving, vx_m, vy_m, dt, grid, prior)
            born, born_cells = self._people_births(dt, n_inside)
            rows, born_rows = (self._ego_rows(odo, dt, part.size, moves) for part in (before, born))
            given = (before.x, before.y, before.w, moving, vx_m, vy_m, dt, rows, moves, grid, buf, cells, mass, counts)
            j, _ = kernels.move_ego_compact(*given, np.zeros(n_cells))
        prior += np.bincount(born_cells, weights=born.w, minlength=n_cells)
        j_st, born_src = j, np.stack((born.x, born.y, born.vx, born.vy))
        j = kernels.ego_compact(born_src, born.w, born_rows, moves, False, grid, buf, cells, j, mass, counts)
        if moves:
            n_now = n_inside + (j - j_st)
            born2, born2_cells = self._born_from_mass(self._ego_inflow(poses, pose_w), self.n_particles - n_now)
            j = self._append(buf, cells, j, born2, born2_cells)
            kernels.accumulate(born2_cells, born2.w, mass, counts)
        else:  # standing: the people prior is the sensor prior
            mass = prior.copy()
        if sq is not None and j > j_st:  # the births' squared masses
            sq += np.bincount(cells[j_st:j], weights=np.square(buf[4][j_st:j]), minlength=n_cells)
        self._buffer = (buf, cells, j)
        self._pool.give(*_arrays(self.state))  # the old state: reused once no step record holds it
        st = ParticleState.of_checked(buf[0][:j], buf[1][:j], buf[2][:j], buf[3][:j], buf[4][:j])
        return st, cells[:j], counts, prior, mass, poses, pose_w, sq

    def _people_births(self, dt: float, n_inside: int) -> tuple[ParticleState, NDArray[np.intp]]:
        """The births of the people motion's inflow across the border, given the count inside after it (half of
        the free slots)."""
        free = self.n_particles - n_inside
        return self._born_from_mass(self.people_inflow(dt).ravel(), free - max(free, 0) // 2)

    def _ego_rows(self, odo: Odometry | None, dt: float, n: int, moves: bool) -> NDArray[np.float64]:
        """The sensor displacements of ``n`` particles as the kernels take them (4, S), or none for a standing
        robot (then the kernels leave the particles alone); drawn in the kernel where the people motion is
        (:meth:`_draws_inside`) and the component's :meth:`~VelocityEgoSampling.rows` is the built-in one."""
        if not (moves and n):
            return _NO_POSES
        if self._draws_inside() and type(self.ego_motion).rows is VelocityEgoSampling.rows:
            return self.ego_motion.rows_drawn(odo, dt, n, seed=self.rng.integers(0, 2**64, dtype=np.uint64))
        return self.ego_motion.rows(odo, dt, n, rng=self.rng)

    @staticmethod
    def _append(buf: _Rows, cells: NDArray[np.intp], j: int, part: ParticleState, where: NDArray[np.intp]) -> int:
        """Write ``part`` (cells ``where``) into entries ``j, j + 1, ...`` of a buffer; returns the end."""
        end = j + part.size
        if end > cells.size:
            raise RuntimeError(f"particle buffer of {cells.size} too small for {end} particles")
        for r, arr in enumerate((part.x, part.y, part.vx, part.vy, part.w)):
            buf[r][j:end] = arr
        cells[j:end] = where
        return end

    def _prediction(
        self,
        cells: NDArray[np.intp],
        empty: NDArray[np.bool_],
        people_prior: NDArray[np.float64],
        sensor_prior: NDArray[np.float64],
        dt: float,
        sq: NDArray[np.float64] | None = None,
    ) -> _Pending:
        """The prior of eq. 12: the sensor prior clipped to [0, 1] (Monte Carlo noise), appearances added."""
        prior = np.clip(sensor_prior, 0.0, 1.0)
        if self.appearance is not None and dt > 0.0:  # appearances scale the particles of a cell up
            prior = self.appearance.apply(prior, dt, where=self.observed)
        return _Pending(cells, empty, people_prior, sensor_prior, prior, sq)

    def _held(self) -> _Pending:
        """A prediction of zero length: the particles' rasterised mass (empty cells: the belief)."""
        cells = self.spec.flat_index(self.state.x, self.state.y)
        if np.any(cells < 0):
            raise ValueError("particles outside the grid: reset() or predict() before update()")
        n_cells = self.spec.n_cells
        mass = np.bincount(cells, weights=self.state.w, minlength=n_cells).astype(np.float64, copy=False)
        empty = np.bincount(cells, minlength=n_cells) == 0
        mass[empty] = self.belief.ravel()[empty]
        return self._prediction(cells, empty, mass, mass, 0.0)

    def _update(self, lik: Likelihood) -> ParticleStep:
        pending = self._held() if self._pending is None else self._pending
        st, cells, posterior, sums = self._update_weights(self.state.shallow_copy(), pending, lik)
        st, resampled = (st, True) if sums is _RESAMPLED else self._resample(st, cells, sums)
        self.state, self._pending, self._buffer = st, None, None
        self.belief = posterior.reshape(self.spec.shape)
        return ParticleStep(
            people_prior=pending.people_prior.reshape(self.spec.shape),
            sensor_prior=pending.sensor_prior.reshape(self.spec.shape),
            fired=lik.fired,
            covered=lik.covered,
            detector_likelihoods=lik.detector_likelihoods,
            likelihood=lik.likelihood,
            posterior=self.belief.copy(),
            particles=st.shallow_copy(),
            resampled=resampled,
        )

    def _update_weights(
        self, st: ParticleState, pending: _Pending, lik: Likelihood
    ) -> tuple[ParticleState, NDArray[np.intp], NDArray[np.float64], _Sums | None]:
        """Phases 3-4: Bayes update (eq. 12) per cell, particles scaled to their cell's posterior, births in the
        empty cells with posterior mass. Returns the particles, their cells, the posterior (flat) and, compiled,
        the new weights' sums (:class:`_Sums`)."""
        cells, empty = pending.cells, pending.empty
        posterior = bayes_update(pending.prior, lik.likelihood.ravel())
        if self.bounds is not None:
            posterior = self.bounds.apply(posterior)
        held = pending.sensor_prior > 0.0
        factor = np.divide(posterior, pending.sensor_prior, out=np.zeros(self.spec.n_cells), where=held & ~empty)
        rep = np.zeros(0, dtype=np.intp)
        if empty.any():
            birth_cells = np.flatnonzero(empty & (posterior > BIRTH_FLOOR))
            posterior[empty & (posterior <= BIRTH_FLOOR)] = 0.0
            rep = np.repeat(birth_cells, self.n_birth)
        if jit.enabled("pfpeople"):
            st, cells, sums = self._update_compiled(st, pending, factor, rep, posterior)
            return st, cells, posterior, sums
        st.w = st.w * factor[cells]
        if rep.size:
            st = ParticleState.concatenate([st, self._born(rep, posterior[rep] / self.n_birth)])
            cells = np.concatenate((cells, rep))
        return st, cells, posterior, None

    def _update_compiled(
        self,
        st: ParticleState,
        pending: _Pending,
        factor: NDArray[np.float64],
        rep: NDArray[np.intp],
        posterior: NDArray[np.float64],
    ) -> tuple[ParticleState, NDArray[np.intp], _Sums]:
        """The compiled phases 3-4, and phase 5 when it can be told beforehand.

        The births in empty cells are written after the particles in the prediction's buffer (no copy of the
        particles) when they are still its first columns. With the paper's people motion, the systematic scheme and
        the built-in policy, the effective sample size of the scaled weights is known from the prediction's sums per
        cell (``sum_c f_c^2 Q_c``, ``Q_c`` the squared masses): a step that resamples then draws from the unscaled
        weights and the factors (:func:`resample_scaled`) and returns the new particles with :data:`_RESAMPLED`.
        Otherwise the weights are scaled in one pass that also sums them (:func:`step_kernels.scale_sums`), returned
        with the sums.
        """
        st, cells = self._bear(st, pending.cells, rep, posterior)
        f = factor.copy()
        f[rep] = 1.0  # the births' cells were empty: their weights are final
        policy, n_cells = self.resampling, self.spec.n_cells
        if pending.sq is not None and policy.resampler is systematic and type(policy).due is Resampling.due:
            mass = f * pending.sensor_prior
            sq = f * f * pending.sq
            if rep.size:
                mass[rep], sq[rep] = posterior[rep], np.bincount(rep, weights=np.square(st.w[-rep.size :]))[rep]
            total = float(mass.sum())
            ess = total**2 / float(sq.sum()) if total > 0.0 else 0.0
            if policy.due_ess(st.size, ess, self.n_particles) and total > 0.0:
                rows = (st.x, st.y, st.vx, st.vy)
                out = resample_scaled(
                    cells, st.w, f, self.n_particles, rows, mass=mass, total=total, rng=self.rng, pool=self._pool
                )
                self._pool.give(*_arrays(st), cells)  # the prediction's arrays: reused once nothing holds them
                return ParticleState.of_checked(*out), cells, _RESAMPLED
        w = self._pool.take(st.size)
        mass, total, sum_sq, status = kernels.scale_sums(st.w, cells, f, w, n_cells)
        if status:  # pragma: no cover - the filter's own weights and cells are always valid
            raise RuntimeError(f"particle filter: invalid weights or cells after the update (status {status})")
        return ParticleState.of_checked(st.x, st.y, st.vx, st.vy, w), cells, _Sums(mass, total, sum_sq)

    def _bear(
        self, st: ParticleState, cells: NDArray[np.intp], rep: NDArray[np.intp], posterior: NDArray[np.float64]
    ) -> tuple[ParticleState, NDArray[np.intp]]:
        """The particles with the births in empty cells ``rep`` (each carrying ``posterior / n_birth``) after them:
        written into the prediction's buffer when the particles are still its first columns, else concatenated."""
        n, k = st.size, rep.size
        if k == 0:
            return st, cells
        born = self._born(rep, posterior[rep] / self.n_birth)
        buf, buf_cells, used = self._buffer if self._buffer is not None else (None, None, -1)
        if (
            buf is None
            or buf_cells is None
            or used != n
            or _owner(st.x) is not _owner(buf[0])
            or _owner(st.w) is not _owner(buf[4])
            or n + k > buf_cells.size
        ):
            return ParticleState.concatenate([st, born]), np.concatenate((cells, rep))
        end = self._append(buf, buf_cells, n, born, rep)
        x, y, vx, vy, w = (r[:end] for r in buf)
        return ParticleState.of_checked(x, y, vx, vy, w), buf_cells[:end]

    def _resample(
        self, st: ParticleState, cells: NDArray[np.intp], sums: _Sums | None = None
    ) -> tuple[ParticleState, bool]:
        """Phase 5: resample by cell when the ESS is low or births pushed the count above
        ``(1 + max_overflow) * n_particles``.

        ``sums`` (compiled) are the weights' sums, from which the ESS and the masses per cell are taken. With a
        total weight of 0 (every posterior 0) there is nothing to resample: the step keeps the particles, logs a
        warning and counts it in :attr:`resampling_skipped`.
        """
        n_target, policy = self.n_particles, self.resampling
        if sums is not None and type(policy).due is Resampling.due:  # the ESS from the sums: no pass over w
            due = policy.due_ess(st.w.size, sums.ess, n_target)
        else:
            due = policy.due(st.w, n_target)
        if not due:
            return st, False
        total = float(st.w.sum()) if sums is None else sums.total
        if not total > 0.0:
            self.resampling_skipped += 1
            log.warning(
                "particle filter: total weight %g, resampling skipped (%d steps so far)", total, self.resampling_skipped
            )
            return st, False
        n_cells, fn = self.spec.n_cells, policy.resampler
        if jit.enabled("pfpeople"):
            rows = (st.x, st.y, st.vx, st.vy)
            cell_sums = None if sums is None else (sums.mass, sums.total)
            out = resample_state(
                cells,
                st.w,
                n_target,
                rows,
                n_cells=n_cells,
                rng=self.rng,
                resampler=fn,
                pool=self._pool,
                sums=cell_sums,
            )
            self._pool.give(*_arrays(st), cells)  # the prediction's arrays: reused once nothing holds them
            return ParticleState.of_checked(*out), True
        anc, new_w = resample_by_cell(cells, st.w, n_target, n_cells=n_cells, rng=self.rng, resampler=fn)
        st = st.take(anc)
        st.w = new_w
        return st, True


class _Sums(NamedTuple):
    """The new weights' sums of the compiled update: per cell (n_cells,), their total and sum of squares."""

    mass: NDArray[np.float64]
    total: float
    sum_sq: float

    @property
    def ess(self) -> float:
        """The effective sample size ``total^2 / sum_sq`` (0 for all-zero weights)."""
        return self.total**2 / self.sum_sq if self.sum_sq > 0.0 else 0.0


#: What the compiled update returns in place of the sums when it has resampled already.
_RESAMPLED = _Sums(np.zeros(0), 0.0, 0.0)


class _PeopleMoved(NamedTuple):
    """The particles after the people motion (phase 1): cells are flat indices, -1 outside the grid."""

    state: ParticleState
    cells: NDArray[np.intp]
    inside: NDArray[np.bool_]
    n_inside: int
    born: ParticleState
    born_cells: NDArray[np.intp]
    prior: NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class _Pending:
    """A prediction waiting for its update; flat ``(n_cells,)`` grids, ``cells`` the cell of each particle."""

    cells: NDArray[np.intp]
    empty: NDArray[np.bool_]
    people_prior: NDArray[np.float64]
    sensor_prior: NDArray[np.float64]
    prior: NDArray[np.float64]
    #: The particles' squared masses summed per cell (compiled, the paper's people motion; else None).
    sq: NDArray[np.float64] | None = None


def _owner(a: NDArray[np.float64]) -> object:
    """The array owning ``a``'s memory (``a`` itself when it owns it)."""
    return a if a.base is None else a.base


def _arrays(st: ParticleState) -> tuple[NDArray[np.float64], ...]:
    return (st.x, st.y, st.vx, st.vy, st.w)


def _sampling_components(
    people_motion: object, ego_motion: object, resampling: object
) -> tuple[PeopleSampler, VelocityEgoSampling, Resampling]:
    """The particle side's components, checked (``TypeError`` naming the argument), the paper's by default."""
    people = PaperSampling() if people_motion is None else people_motion
    if not isinstance(people, PeopleSampler):
        raise TypeError(f"people_motion must be a PeopleSampler component, got {type(people).__name__}")
    ego = VelocityEgoSampling() if ego_motion is None else ego_motion
    if not isinstance(ego, VelocityEgoSampling):
        raise TypeError(f"ego_motion must be a VelocityEgoSampling component, got {type(ego).__name__}")
    policy = Resampling() if resampling is None else resampling
    if not isinstance(policy, Resampling):
        raise TypeError(f"resampling must be a Resampling component, got {type(policy).__name__}")
    return people, ego, policy


def _check_count(value: int, name: str) -> int:
    """A count >= 1: :func:`gridbridge.validation.check_int`."""
    return check_int(value, name, minimum=1)
