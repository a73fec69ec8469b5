"""Phases 3-5 of the particle filter step: the Bayes update per cell (eq. 12), the particles scaled to it, births in
the empty cells, and the resampling when it is due; in numpy (:class:`ReferenceUpdater`) and compiled
(:class:`CompiledUpdater`).

3. **Update** (eqs. 12-14). The prior of cell c is its rasterised mass m_c (the inflows included, clipped to [0, 1]
   against Monte Carlo noise, appearances added); the likelihood L_c comes from the filter's likelihood component
   (:class:`~gridbridge.likelihoods.DeMorganLikelihood`, eqs. 13-14, or the calibrated
   :class:`~gridbridge.likelihoods.IndependentLikelihood`: the code the grid filter uses); the posterior is
   ``p_c = bayes_update(m_c, L_c)``, then the bounds, and the particles in c are scaled by ``p_c / m_c``, so they
   share the posterior in proportion to their weights.
4. **Empty cells** (no particle after the prediction; their prior is the grid's,
   :mod:`pfpeople.particle.predictor.empty_cells`). If the posterior exceeds
   :data:`~pfpeople.particle.predictor.births.BIRTH_FLOOR` (1e-12), ``n_birth`` particles are born there sharing
   that mass, uniform in the cell, with velocities from the motion prior. Below the floor the cell's posterior is set
   to 0 (the mass ignored is below 1e-12 per cell).
5. **Resampling** (the filter's :class:`~pfpeople.particle.resampler.policy.Resampler`) when it is due; with a total
   weight of 0 (every posterior 0) there is nothing to resample: the step keeps its particles and says so
   (:attr:`Updated.skipped`).

The compiled updater scales the weights in one pass that also sums them (:func:`.kernels.scale_sums`), writes the
births in empty cells after the particles in the prediction's buffer, and, when the prediction summed the squared
masses per cell (a drawing pass) and the resampler draws scaled weights, knows the effective sample size of the scaled
weights without that pass (``sum_c f_c^2 Q_c``): a step that resamples then draws from the unscaled weights and the
factors.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from gridbridge import GridSpec, bayes_update
from gridbridge.components import BeliefBounds
from pfpeople.particle.buffers import BufferPool, arrays_of
from pfpeople.particle.predictor.births import BIRTH_FLOOR, Births
from pfpeople.particle.predictor.protocols import Predicted
from pfpeople.particle.resampler.policy import Resampler
from pfpeople.particle.resampler.schemes import effective_sample_size
from pfpeople.particle.state import ParticleState
from pfpeople.particle.updater.kernels import scale_sums

__all__ = ["CellUpdate", "CompiledUpdater", "ReferenceUpdater", "Updated"]

_Rows4 = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]


class CellUpdate(NamedTuple):
    """Eq. 12 cell by cell, flat ``(n_cells,)``: the posterior, each cell's factor ``posterior / sensor prior`` (0
    in empty cells) and the cells of the births in empty cells (each repeated ``n_birth`` times, (K,))."""

    posterior: NDArray[np.float64]
    factor: NDArray[np.float64]
    births: NDArray[np.intp]


class Updated(NamedTuple):
    """The particles after phases 3-5, the posterior (flat), whether they were resampled and, when a resampling was
    due but every weight was 0, the total weight (else None)."""

    state: ParticleState
    posterior: NDArray[np.float64]
    resampled: bool
    skipped: float | None = None


class ReferenceUpdater:
    """Phases 3-5 in numpy (the module docstring).

    Parameters
    ----------
    spec : GridSpec
        The grid.
    bounds : BeliefBounds or None
        Clamp of the posterior.
    births : Births
        The empty cells' newborns.
    resampler : Resampler
        When and how to resample (its reference form here).
    n_particles, n_birth : int
        The particle count restored by a resampling; particles born per empty cell.
    """

    def __init__(
        self,
        spec: GridSpec,
        bounds: BeliefBounds | None,
        births: Births,
        resampler: Resampler,
        *,
        n_particles: int,
        n_birth: int,
    ) -> None:
        self.spec, self.bounds, self.births, self.resampler = spec, bounds, births, resampler
        self.n_particles, self.n_birth = n_particles, n_birth

    def cell_update(self, predicted: Predicted, prior: NDArray[np.float64], lik: NDArray[np.float64]) -> CellUpdate:
        """Eq. 12 per cell of the update's ``prior`` (flat) and the fused likelihood ``lik`` (nx, ny), the bounds,
        and the empty cells' births (phases 3-4)."""
        empty = predicted.empty
        posterior = bayes_update(prior, lik.ravel())
        if self.bounds is not None:
            posterior = self.bounds.apply(posterior)
        held = predicted.sensor_prior > 0.0
        factor = np.divide(posterior, predicted.sensor_prior, out=np.zeros(self.spec.n_cells), where=held & ~empty)
        rep = np.zeros(0, dtype=np.intp)
        if empty.any():
            birth_cells = np.flatnonzero(empty & (posterior > BIRTH_FLOOR))
            posterior[empty & (posterior <= BIRTH_FLOOR)] = 0.0
            rep = np.repeat(birth_cells, self.n_birth)
        return CellUpdate(posterior, factor, rep)

    def update(
        self, predicted: Predicted, prior: NDArray[np.float64], lik: NDArray[np.float64], rng: np.random.Generator
    ) -> Updated:
        """Phases 3-5 of the ``predicted`` particles (their arrays are not written) with the update's ``prior``
        (flat) and the fused likelihood ``lik`` (nx, ny)."""
        upd = self.cell_update(predicted, prior, lik)
        st, cells = predicted.state.shallow_copy(), predicted.cells
        st.w = st.w * upd.factor[cells]
        rep = upd.births
        if rep.size:
            st = ParticleState.concatenate([st, self.births.born(rep, upd.posterior[rep] / self.n_birth, rng)])
            cells = np.concatenate((cells, rep))
        if not self.resampler.due_ess(st.w.size, effective_sample_size(st.w), self.n_particles):
            return Updated(st, upd.posterior, False)
        total = float(st.w.sum())
        if not total > 0.0:
            return Updated(st, upd.posterior, False, total)
        anc, new_w = self.resampler.resample(cells, st.w, self.n_particles, n_cells=self.spec.n_cells, rng=rng)
        st = st.take(anc)
        st.w = new_w
        return Updated(st, upd.posterior, True)


class CompiledUpdater(ReferenceUpdater):
    """Phases 3-5 compiled (the module docstring); ``resample`` is the resampler's compiled form, ``scaled`` its
    ``resample_scaled`` when it draws scaled weights (else None), ``pool`` the filter's arrays for reuse."""

    def __init__(
        self,
        spec: GridSpec,
        bounds: BeliefBounds | None,
        births: Births,
        resampler: Resampler,
        *,
        n_particles: int,
        n_birth: int,
        resample: Callable[..., tuple[NDArray[np.float64], ...]],
        scaled: Callable[..., tuple[NDArray[np.float64], ...]] | None,
        pool: BufferPool,
    ) -> None:
        super().__init__(spec, bounds, births, resampler, n_particles=n_particles, n_birth=n_birth)
        self.resample, self.scaled, self.pool = resample, scaled, pool

    def update(
        self, predicted: Predicted, prior: NDArray[np.float64], lik: NDArray[np.float64], rng: np.random.Generator
    ) -> Updated:
        """As :meth:`ReferenceUpdater.update`, compiled."""
        upd = self.cell_update(predicted, prior, lik)
        st, cells = self._bear(predicted, upd, rng)
        f = upd.factor.copy()
        f[upd.births] = 1.0  # the births' cells were empty: their weights are final
        if predicted.sq is not None and self.scaled is not None:
            drawn = self._resample_predicted(st, cells, f, predicted, upd, rng)
            if drawn is not None:
                return Updated(drawn, upd.posterior, True)
        w = self.pool.take(st.size)
        mass, total, sum_sq, status = scale_sums(st.w, cells, f, w, self.spec.n_cells)
        if status:  # pragma: no cover - the filter's own weights and cells are always valid
            raise RuntimeError(f"particle filter: invalid weights or cells after the update (status {status})")
        st = ParticleState.of_checked(st.x, st.y, st.vx, st.vy, w)
        ess = total**2 / sum_sq if sum_sq > 0.0 else 0.0
        if not self.resampler.due_ess(st.w.size, ess, self.n_particles):
            return Updated(st, upd.posterior, False)
        if not total > 0.0:
            return Updated(st, upd.posterior, False, total)
        args = (cells, st.w, self.n_particles, (st.x, st.y, st.vx, st.vy))
        out = self.resample(*args, n_cells=self.spec.n_cells, rng=rng, pool=self.pool, sums=(mass, total))
        self.pool.give(*arrays_of(st), cells)  # the prediction's arrays: reused once nothing holds them
        return Updated(ParticleState.of_checked(*out), upd.posterior, True)

    def _bear(
        self, predicted: Predicted, upd: CellUpdate, rng: np.random.Generator
    ) -> tuple[ParticleState, NDArray[np.intp]]:
        """The predicted particles with the births in empty cells after them (each carrying ``posterior /
        n_birth``): written into the prediction's buffer when the particles are still its first columns, else
        concatenated."""
        st, cells, rep = predicted.state.shallow_copy(), predicted.cells, upd.births
        if rep.size == 0:
            return st, cells
        born = self.births.born(rep, upd.posterior[rep] / self.n_birth, rng)
        buf = predicted.buffer
        if buf is None or not buf.holds(st, rep.size):
            return ParticleState.concatenate([st, born]), np.concatenate((cells, rep))
        buf.append(born, rep)
        return buf.state()

    def _resample_predicted(
        self,
        st: ParticleState,
        cells: NDArray[np.intp],
        f: NDArray[np.float64],
        predicted: Predicted,
        upd: CellUpdate,
        rng: np.random.Generator,
    ) -> ParticleState | None:
        """The resampling decided from the prediction's sums per cell (the masses ``f M_c``, the squared masses ``f^2
        Q_c``; the births' cells their own) and drawn from the unscaled weights ``st.w`` and the factors ``f``; None
        when it is not due (or every weight is 0): the caller scales the weights."""
        assert predicted.sq is not None and self.scaled is not None
        rep = upd.births
        mass = f * predicted.sensor_prior
        sq = f * f * predicted.sq
        if rep.size:
            mass[rep], sq[rep] = upd.posterior[rep], np.bincount(rep, weights=np.square(st.w[-rep.size :]))[rep]
        total = float(mass.sum())
        ess = total**2 / float(sq.sum()) if total > 0.0 else 0.0
        if not (self.resampler.due_ess(st.size, ess, self.n_particles) and total > 0.0):
            return None
        rows = (st.x, st.y, st.vx, st.vy)
        out = self.scaled(cells, st.w, f, self.n_particles, rows, mass=mass, total=total, rng=rng, pool=self.pool)
        self.pool.give(*arrays_of(st), cells)  # the prediction's arrays: reused once nothing holds them
        return ParticleState.of_checked(*out)
