"""Which form of each component a particle filter runs: chosen once, when the filter is built.

Without the compiled kernels (``PFPEOPLE_NUMBA=0``, or numba missing: :func:`gridbridge.jit.enabled`) the filter runs
every model's reference form (:class:`~pfpeople.particle.predictor.reference.ReferencePredictor`,
:class:`~pfpeople.particle.updater.update.ReferenceUpdater`). With them it runs the compiled step: a
:class:`~pfpeople.particle.predictor.compiled.DrawingPredictor` when the people-motion model draws inside its pass
(``draws_inside`` and ``drawn_pass``), else a :class:`~pfpeople.particle.predictor.compiled.CompiledPredictor` on the
model's ``move_compiled``, and the :class:`~pfpeople.particle.updater.update.CompiledUpdater` on the resampler's
``resample_compiled``. A model without a compiled form runs its reference form inside the compiled step: the same
particles, slower; a log line says so once per model class.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from gridbridge import GridSpec
from gridbridge.components import BeliefBounds
from pfpeople.particle.buffers import BufferPool
from pfpeople.particle.predictor.births import Births, DrawnBirths
from pfpeople.particle.predictor.compiled import CompiledPredictor, DrawingPredictor, Move
from pfpeople.particle.predictor.ego import VelocityEgoSampling
from pfpeople.particle.predictor.paper import PaperSampling
from pfpeople.particle.predictor.protocols import EgoSampler, PeopleSampler, Predictor
from pfpeople.particle.predictor.reference import ReferencePredictor
from pfpeople.particle.resampler.policy import Resampler, Resampling
from pfpeople.particle.updater.update import CompiledUpdater, ReferenceUpdater

__all__ = ["Forms", "ResampleByReference", "Settings", "checked_components", "checked_rng", "forms_for"]

log = logging.getLogger(__name__)

#: The (role, model class) pairs already named in the log as running their reference form in the compiled step.
_NOTICED: set[tuple[str, type]] = set()


class Forms(NamedTuple):
    """The filter's births, predictor (phases 1-2) and updater (phases 3-5), in one form."""

    births: Births
    predictor: Predictor
    updater: ReferenceUpdater


class Settings(NamedTuple):
    """What the forms share with the filter: its grid, posterior bounds, particle count, births per empty cell and
    border belief."""

    spec: GridSpec
    bounds: BeliefBounds | None
    n_particles: int
    n_birth: int
    outside: float


def checked_components(
    people_motion: object, ego_motion: object, resampling: object
) -> tuple[PeopleSampler, EgoSampler, Resampler]:
    """A filter's motion models and resampler, checked against their protocols (``TypeError`` naming the argument),
    the paper's by default."""
    people = PaperSampling() if people_motion is None else people_motion
    if not isinstance(people, PeopleSampler):
        raise TypeError(f"people_motion must be a PeopleSampler component, got {type(people).__name__}")
    ego = VelocityEgoSampling() if ego_motion is None else ego_motion
    if not isinstance(ego, EgoSampler):
        raise TypeError(
            f"ego_motion must be a VelocityEgoSampling or another EgoSampler component, got {type(ego).__name__}"
        )
    policy = Resampling() if resampling is None else resampling
    if not isinstance(policy, Resampler):
        raise TypeError(f"resampling must be a Resampling or another Resampler component, got {type(policy).__name__}")
    return people, ego, policy


def checked_rng(rng: object) -> np.random.Generator:
    """``rng`` if it is a ``numpy.random.Generator`` (the filter's only source of randomness), else ``TypeError``."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    return rng


def forms_for(
    people: PeopleSampler, ego: EgoSampler, resampler: Resampler, settings: Settings, *, compiled: bool
) -> Forms:
    """The forms of a filter with these components: the reference forms, or (``compiled``) the compiled ones."""
    spec, n, n_birth = settings.spec, settings.n_particles, settings.n_birth
    if not compiled:
        births = Births(spec, people.motion, settings.outside)
        predictor = ReferencePredictor(spec, people, ego, births, n_particles=n, outside=settings.outside)
        updater = ReferenceUpdater(spec, settings.bounds, births, resampler, n_particles=n, n_birth=n_birth)
        return Forms(births, predictor, updater)
    pool = BufferPool()
    drawn = bool(getattr(people, "draws_inside", False)) and hasattr(people, "drawn_pass")
    births = (DrawnBirths if drawn else Births)(spec, people.motion, settings.outside)
    kind = DrawingPredictor if drawn else CompiledPredictor
    move = _compiled_move(people)
    compiled_predictor = kind(
        spec, people, ego, births, move=move, n_particles=n, outside=settings.outside, n_birth=n_birth, pool=pool
    )
    if not hasattr(ego, "rows"):
        _notice("ego motion", ego, "rows")
    scaled = getattr(resampler, "resample_scaled", None) if getattr(resampler, "draws_scaled", False) else None
    resample = _compiled_resample(resampler)
    updater = CompiledUpdater(
        spec,
        settings.bounds,
        births,
        resampler,
        n_particles=n,
        n_birth=n_birth,
        resample=resample,
        scaled=scaled,
        pool=pool,
    )
    return Forms(births, compiled_predictor, updater)


def _compiled_move(people: PeopleSampler) -> Move:
    """The people model's ``move_compiled``, else its reference ``move`` (named in the log when the model has no
    compiled form at all)."""
    move: Move | None = getattr(people, "move_compiled", None)
    if move is not None:
        return move
    if not hasattr(people, "drawn_pass"):
        _notice("people motion", people, "move_compiled")
    return people.move


def _compiled_resample(resampler: Resampler) -> Callable[..., tuple[NDArray[np.float64], ...]]:
    """The resampler's ``resample_compiled``, else its reference form with the particles gathered (logged once)."""
    compiled: Callable[..., tuple[NDArray[np.float64], ...]] | None = getattr(resampler, "resample_compiled", None)
    if compiled is not None:
        return compiled
    _notice("resampler", resampler, "resample_compiled")
    return ResampleByReference(resampler)


class ResampleByReference:
    """A resampler's reference form called as a compiled form: the ancestors' rows gathered with numpy."""

    def __init__(self, resampler: Resampler) -> None:
        self.resampler = resampler

    def __call__(
        self,
        cells: NDArray[np.intp],
        weights: NDArray[np.float64],
        n: int,
        rows: tuple[NDArray[np.float64], ...],
        *,
        n_cells: int,
        rng: np.random.Generator,
        pool: BufferPool | None = None,
        sums: object = None,
    ) -> tuple[NDArray[np.float64], ...]:
        """x, y, vx, vy of the ancestors and the new weights."""
        anc, new_w = self.resampler.resample(cells, weights, n, n_cells=n_cells, rng=rng)
        return (*(r[anc] for r in rows), np.asarray(new_w, dtype=np.float64))


def _notice(role: str, model: object, method: str) -> None:
    """Say once per model class that the compiled filter runs this model's reference form."""
    key = (role, type(model))
    if key in _NOTICED:
        return
    _NOTICED.add(key)
    log.warning(
        "particle filter: the %s %s has no compiled form (%s): the compiled filter runs its reference form in numpy, "
        "the same particles, slower (docs/architecture.md, 'Your own motion model')",
        role,
        type(model).__name__,
        method,
    )
