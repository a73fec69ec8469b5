"""When and how the particle filter resamples: the :class:`Resampler` protocol and the built-in :class:`Resampling`.

A step resamples when the effective sample size ESS = (sum w)^2 / sum w^2 falls below a threshold or births pushed
the count above a slack; resampling restores exactly N particles by cell, keeping every cell's mass
(:func:`~pfpeople.particle.resampler.by_cell.resample_by_cell`).

Births at the border fill the free slots (particles that left; :mod:`pfpeople.particle.predictor.births`), so the
count stays at or below N unless there are more inflow cells than free slots. On the paper's grid 224 cells receive
inflow in a 0.1 s step, more than a step usually frees, so with ``max_overflow = 0`` most steps resample whatever the
ESS. With a slack (``max_overflow = 0.1``, the recommended mode's; about 3 % births per step on the
person-following bag) the births of a few steps accumulate: on the person-following bag 29 % of the steps resample
(22 % for the count, 8 % for the ESS), with a median ESS of 0.93 N between resamplings, and the filter step costs
about a fifth less.

A resampler is one class with both forms:

* its reference form :meth:`Resampler.resample` (numpy): ancestors and new weights;
* its compiled form ``resample_compiled(cells, weights, n, rows, *, n_cells, rng, pool=None, sums=None)``
  (optional): the resampled particles themselves (x, y, vx, vy, w). Without one the compiled filter runs the
  reference form and says so once in the log. A resampler whose ``draws_scaled`` is true also has
  ``resample_scaled(cells, w, factor, n, rows, *, mass, total, rng, pool=None)``, which resamples particles of
  weights ``w * factor[cells]`` without writing them: the compiled update then decides and draws from the
  prediction's sums per cell, without a pass over the scaled weights.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from gridbridge.validation import check_choice, check_positive
from pfpeople.particle.buffers import BufferPool
from pfpeople.particle.resampler.by_cell import resample_by_cell, resample_scaled, resample_state
from pfpeople.particle.resampler.schemes import RESAMPLERS, effective_sample_size, get_resampler, systematic

__all__ = ["Resampler", "Resampling"]

#: A resampling scheme as a callable: ``f(weights, n, rng=rng) -> ancestors`` (:mod:`.schemes`).
Scheme = Callable[..., NDArray[np.intp]]
_Rows4 = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]


@runtime_checkable
class Resampler(Protocol):
    """When and how to resample particles by cell (see the module docstring)."""

    def capacity(self, n: int) -> int:
        """The largest particle count between resamplings for a target of ``n``."""
        ...

    def due_ess(self, size: int, ess: float, n: int) -> bool:
        """Whether ``size`` particles of effective sample size ``ess`` are resampled to a target of ``n``."""
        ...

    def resample(
        self, cells: NDArray[np.intp], weights: NDArray[np.float64], n: int, *, n_cells: int, rng: np.random.Generator
    ) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
        """Reference form: ``n`` ancestors of the particles in flat ``cells`` (K,) of masses ``weights`` (K,), and
        the new weights (n,), every cell's mass kept."""
        ...


@dataclass(frozen=True, kw_only=True)
class Resampling:
    """When and how the particle filter resamples by cell (:func:`~.by_cell.resample_by_cell`).

    A step resamples when ESS = (sum w)^2 / sum w^2 falls below ``ess_threshold * N`` or births pushed the count
    above ``(1 + max_overflow) * N``; resampling restores exactly N particles and keeps every cell's mass.
    Reference form :meth:`resample`; compiled forms :meth:`resample_compiled` and, for the systematic scheme,
    :meth:`resample_scaled`.

    Parameters
    ----------
    scheme : {"systematic", "stratified", "residual", "multinomial"} or callable
        The draws (:data:`~.schemes.RESAMPLERS`), or a callable ``f(weights, n, rng=rng) -> ancestors`` (e.g. a
        baseline for benchmarks).
    ess_threshold : float
        >= 0; a value above 1 resamples every step, 0 only on overflow.
    max_overflow : float
        >= 0. Births may push the count up to ``(1 + max_overflow) * N`` before they trigger a resampling (0:
        every overflow resamples); a slack lets the births of several steps accumulate.
    """

    scheme: str | Scheme = "systematic"
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
    def resampler(self) -> Scheme:
        """The scheme as a callable."""
        return get_resampler(self.scheme) if isinstance(self.scheme, str) else self.scheme

    @property
    def draws_scaled(self) -> bool:
        """Whether :meth:`resample_scaled` applies: the systematic scheme."""
        return self.resampler is systematic

    def capacity(self, n: int) -> int:
        """The largest particle count between resamplings for a target of ``n``."""
        return math.ceil(n * (1.0 + self.max_overflow))

    def due(self, weights: NDArray[np.float64], n: int) -> bool:
        """Whether particles of masses ``weights`` (shape (K,)) are resampled to a target of ``n``."""
        return self.due_ess(weights.size, effective_sample_size(weights), n)

    def due_ess(self, size: int, ess: float, n: int) -> bool:
        """:meth:`due` for ``size`` particles of effective sample size ``ess`` (``(sum w)^2 / sum w^2``)."""
        return bool(size > n * (1.0 + self.max_overflow) or ess < self.ess_threshold * n)

    def resample(
        self, cells: NDArray[np.intp], weights: NDArray[np.float64], n: int, *, n_cells: int, rng: np.random.Generator
    ) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
        """Reference form: :func:`~.by_cell.resample_by_cell` with the scheme."""
        return resample_by_cell(cells, weights, n, n_cells=n_cells, rng=rng, resampler=self.resampler)

    def resample_compiled(
        self,
        cells: NDArray[np.intp],
        weights: NDArray[np.float64],
        n: int,
        rows: _Rows4,
        *,
        n_cells: int,
        rng: np.random.Generator,
        pool: BufferPool | None = None,
        sums: tuple[NDArray[np.float64], float] | None = None,
    ) -> tuple[NDArray[np.float64], ...]:
        """Compiled form: :func:`~.by_cell.resample_state` (the particles' ``rows`` x, y, vx, vy gathered; the
        reference form's ancestors but for the systematic scheme, drawn without a sort)."""
        return resample_state(
            cells, weights, n, rows, n_cells=n_cells, rng=rng, resampler=self.resampler, pool=pool, sums=sums
        )

    def resample_scaled(
        self,
        cells: NDArray[np.intp],
        w: NDArray[np.float64],
        factor: NDArray[np.float64],
        n: int,
        rows: _Rows4,
        *,
        mass: NDArray[np.float64],
        total: float,
        rng: np.random.Generator,
        pool: BufferPool | None = None,
    ) -> tuple[NDArray[np.float64], ...]:
        """Compiled form for particles of weights ``w * factor[cells]`` (:func:`~.by_cell.resample_scaled`;
        :attr:`draws_scaled` only)."""
        if not self.draws_scaled:
            raise ValueError(f"Resampling.resample_scaled draws the systematic scheme only, not {self.scheme!r}")
        return resample_scaled(cells, w, factor, n, rows, mass=mass, total=total, rng=rng, pool=pool)
