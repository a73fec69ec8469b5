"""The particle filter, rasterised into the same semantic grid as the reference grid filter: a loop over its
components.

Particles carry occupancy mass (:mod:`pfpeople.particle.state`): the sum of weights in a cell is that cell's
probability of holding a person, i.e. the grid filter's belief. One step (same input as
:meth:`gridbridge.GridFilter.step`) is :meth:`ParticleFilter.predict` then :meth:`ParticleFilter.update`:

1-2. people motion, sensor motion (eqs. 5-11), the births at the border, the empty cells' prior:
     :mod:`pfpeople.particle.predictor` (the models in ``predictor/paper.py``, ``persistent.py``, ``ego.py``; the
     births in ``births.py``; the empty cells in ``empty_cells.py``);
     here: the prior of the update, the rasterised mass clipped to [0, 1], appearances added;
3-4. Bayes update per cell (eqs. 12-14, with the filter's likelihood: the grid filter's code), births in empty
     cells: :mod:`pfpeople.particle.updater`;
5.   resampling by cell when the effective sample size or the count says so: :mod:`pfpeople.particle.resampler`.

Each model is one object with a reference form (numpy) and, optionally, a compiled form (numba); which forms a filter
runs is decided once, when it is built (:mod:`pfpeople.particle.forms`): the loop below does not change with them.
The compiled forms give the reference forms' particles bit for bit, except where a model draws inside its kernels
(the paper's people motion; the persistent one with ``compiled_draws``; the systematic resampling): the same
distributions, other draws (``tests/pfpeople/particle/test_compiled_draws.py``).

Equivalence (tested in ``tests/pfpeople/particle/test_pf_equivalence.py``): with ``PaperSampling(redraw_in_cell=True)``
and a standing robot, the expected rasterised prior equals the linear grid filter's prior with the integrated kernel
(``GridFilter(form="linear")``): the PF is an unbiased Monte Carlo estimate of that prediction, with error
~ 1/sqrt(N). With the robot moving, the grid's bilinear warp (applied to a belief assumed uniform within cells) and
its sigma points are approximations that the particles do not make, which leaves a floor.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

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
    fov_mask,
    jit,
)
from gridbridge.components import Appearance, BeliefBounds
from gridbridge.filter import Prediction, filter_models, remounted, with_fields_of_view
from gridbridge.likelihoods import DetectionLikelihood, update_components
from gridbridge.limits import check_dt
from gridbridge.people_motion import check_people_step
from gridbridge.validation import check_int, check_probability
from pfpeople.particle.forms import Settings, checked_components, checked_rng, forms_for
from pfpeople.particle.limits import check_particle_count
from pfpeople.particle.predictor.births import BIRTH_FLOOR
from pfpeople.particle.predictor.protocols import EgoSampler, PeopleSampler, Predicted
from pfpeople.particle.resampler.policy import Resampler
from pfpeople.particle.state import ParticleState

__all__ = ["BIRTH_FLOOR", "ParticleFilter", "ParticleStep"]

log = logging.getLogger(__name__)


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

    The model is in the components, each defaulting to the paper's; the filter is the loop of the module docstring.

    Parameters
    ----------
    spec : GridSpec, optional
        The grid (default: the paper's 30 x 30 cells of 0.3 m).
    detectors : sequence of DetectorModel
        Detector models, in the order of the detections passed to :meth:`step`.
    n_particles : int
        Particle count N restored by every resampling (between resamplings up to the resampler's capacity, e.g.
        ``(1 + max_overflow) N``); at least the number of grid cells.
    rng : numpy.random.Generator
        The only source of randomness: same seed, same output.
    people_motion : PeopleSampler, optional
        People motion in sampling form (default :class:`~pfpeople.particle.predictor.paper.PaperSampling`: the
        paper's memoryless model; :class:`~pfpeople.particle.predictor.persistent.PersistentSampling`: walkers keep
        heading and speed; or a model of your own, :class:`~pfpeople.particle.predictor.protocols.PeopleSampler`).
    ego_motion : EgoSampler, optional
        Sensor motion in sampling form (default :class:`~pfpeople.particle.predictor.ego.VelocityEgoSampling`: the
        default odometry noise, at most 4096 draws per step).
    resampling : Resampler, optional
        When and how to resample (default :class:`~pfpeople.particle.resampler.policy.Resampling`: systematic when
        ESS < N / 2 or the births overflow N).
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
        ego_motion: EgoSampler | None = None,
        resampling: Resampler | None = None,
        likelihood: DetectionLikelihood | None = None,
        appearance: Appearance | None = None,
        bounds: BeliefBounds | None = None,
        initial: float = 0.5,
        outside: float = 0.5,
        n_birth: int = 2,
    ) -> None:
        people, ego, policy = checked_components(people_motion, ego_motion, resampling)
        self.people_motion, self.ego_motion, self.resampling = people, ego, policy
        self.spec, self.detectors, self.motion, self.noise = filter_models(spec, detectors, people.motion, ego.noise)
        self.n_particles = check_particle_count(n_particles, self.spec, self.motion, policy, len(self.detectors))
        self.rng = checked_rng(rng)
        self.initial = check_probability(initial, "initial")
        self.outside = check_probability(outside, "outside")
        self.n_birth = check_int(n_birth, "n_birth", minimum=1)
        self.likelihood, self.appearance, self.bounds = update_components(likelihood, appearance, bounds)
        self.observed = np.logical_or.reduce([fov_mask(self.spec, m) for m in self.detectors]).ravel()
        settings = Settings(self.spec, self.bounds, self.n_particles, self.n_birth, self.outside)
        self._forms = forms_for(people, ego, policy, settings, compiled=jit.enabled("pfpeople"))
        self.state = ParticleState.empty()
        self.belief: NDArray[np.float64] = np.zeros(self.spec.shape)
        #: The prediction waiting for its update and the update's prior (flat).
        self._pending: tuple[Predicted, NDArray[np.float64]] | None = None
        #: Steps whose resampling was skipped because every weight was 0 (logged as a warning).
        self.resampling_skipped = 0
        self.reset()

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
        per_cell = np.full(spec.n_cells, self.n_particles // spec.n_cells, dtype=np.intp)
        per_cell[: self.n_particles % spec.n_cells] += 1
        cells = np.repeat(np.arange(spec.n_cells, dtype=np.intp), per_cell)
        self.state = self._forms.births.born(cells, bel.ravel()[cells] / per_cell[cells], self.rng)
        self.belief = bel
        self._pending = None

    @property
    def particles(self) -> ParticleState:
        """The current particles (the live state; copy before changing it)."""
        return self.state

    def people_inflow(self, dt: float) -> NDArray[np.float64]:
        """Mass entering each cell from outside over ``dt`` (nx, ny): ``outside * sum_{k out} T(c <- k)``."""
        return self._forms.births.people_inflow(dt)

    def predict(self, odometry: Odometry | tuple[float, float] | None, dt: float) -> Prediction:
        """Both predictions (phases 1-2 and the empty cells' prior; :mod:`pfpeople.particle.predictor`).

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
        predicted = self._forms.predictor.predict(self.state, as_odometry(odometry), dt, self.belief, self.rng)
        self.state = predicted.state
        prior = np.clip(predicted.sensor_prior, 0.0, 1.0)
        if self.appearance is not None:  # appearances scale the particles of a cell up
            prior = self.appearance.apply(prior, dt, where=self.observed)
        self._pending = (predicted, prior)
        self.belief = prior.reshape(self.spec.shape)
        return Prediction(
            predicted.people_prior.reshape(self.spec.shape), predicted.sensor_prior.reshape(self.spec.shape)
        )

    def update(self, detections: Sequence[ArrayLike | None]) -> ParticleStep:
        """Measurement update, births in empty cells and resampling (phases 3-5; :mod:`pfpeople.particle.updater`).

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

    def _update(self, lik: Likelihood) -> ParticleStep:
        predicted, prior = self._held() if self._pending is None else self._pending
        out = self._forms.updater.update(predicted, prior, lik.likelihood, self.rng)
        if out.skipped is not None:
            self.resampling_skipped += 1
            log.warning(
                "particle filter: total weight %g, resampling skipped (%d steps so far)",
                out.skipped,
                self.resampling_skipped,
            )
        self.state, self._pending = out.state, None
        self.belief = out.posterior.reshape(self.spec.shape)
        return ParticleStep(
            people_prior=predicted.people_prior.reshape(self.spec.shape),
            sensor_prior=predicted.sensor_prior.reshape(self.spec.shape),
            fired=lik.fired,
            covered=lik.covered,
            detector_likelihoods=lik.detector_likelihoods,
            likelihood=lik.likelihood,
            posterior=self.belief.copy(),
            particles=out.state.shallow_copy(),
            resampled=out.resampled,
        )

    def _held(self) -> tuple[Predicted, NDArray[np.float64]]:
        """A prediction of zero length: the particles' rasterised mass (empty cells: the belief), and its clip."""
        cells = self.spec.flat_index(self.state.x, self.state.y)
        if np.any(cells < 0):
            raise ValueError("particles outside the grid: reset() or predict() before update()")
        n_cells = self.spec.n_cells
        mass = np.bincount(cells, weights=self.state.w, minlength=n_cells).astype(np.float64, copy=False)
        empty = np.bincount(cells, minlength=n_cells) == 0
        mass[empty] = self.belief.ravel()[empty]
        return Predicted(self.state, cells, empty, mass, mass), np.clip(mass, 0.0, 1.0)
