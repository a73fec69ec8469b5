"""Resampling by cell: the occupancy-grid resampling of the particle filter, in numpy and compiled.

:func:`resample_by_cell` keeps the particle count at ``n`` and every cell's mass unchanged (one particle forced in
every cell with mass, the rest by a scheme of :mod:`pfpeople.particle.resampler.schemes`). With numba
(:mod:`gridbridge.jit`) it runs compiled kernels (:func:`resample_plan`) that make the same draws and return the same
ancestors and weights bit for bit. :func:`resample_state` (the compiled filter's) also gathers the particles; with
:func:`~pfpeople.particle.resampler.schemes.systematic` it draws the same scheme without sorting the particles by
cell (:func:`resample_scaled`): the same distribution of ancestors, not the same ancestors.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge import jit
from pfpeople.particle.buffers import BufferPool
from pfpeople.particle.resampler import kernels
from pfpeople.particle.resampler.schemes import get_resampler, systematic

__all__ = ["resample_by_cell", "resample_plan", "resample_scaled", "resample_state"]


def resample_by_cell(
    cells: ArrayLike,
    weights: ArrayLike,
    n: int,
    *,
    n_cells: int,
    rng: np.random.Generator,
    resampler: str | Callable[..., NDArray[np.intp]] = "systematic",
) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """Resample occupancy-mass particles to exactly ``n``, keeping every cell's mass.

    Scheme: every cell with positive mass first gets one particle, drawn within the cell in proportion to
    weight (so no cell that holds mass loses all its particles); the other ``n - K`` (K = cells with mass)
    are drawn from all particles by weight with ``resampler``. Each new particle in cell c then carries
    ``M_c / n_c`` (the cell's mass shared equally by its ``n_c`` new particles), so cell masses are preserved
    to round-off. Every new particle is marginally a weight-proportional draw from its cell's particles.

    Parameters
    ----------
    cells : array_like of int, shape (N,)
        Flat cell index of each particle, in ``[0, n_cells)``.
    weights : array_like, shape (N,)
        Occupancy masses, >= 0.
    n : int
        Particle count after resampling; must be at least the number of cells with positive mass.
    n_cells : int
        Number of grid cells.
    rng : numpy.random.Generator
    resampler : str or callable
        A name in :data:`~pfpeople.particle.resampler.schemes.RESAMPLERS`, or ``f(weights, n, rng=rng) -> ancestors``.

    Returns
    -------
    ancestors : ndarray of intp, shape (n,)
    new_weights : ndarray, shape (n,)
    """
    fn = get_resampler(resampler) if isinstance(resampler, str) else resampler
    c = np.asarray(cells, dtype=np.intp)
    w = np.asarray(weights, dtype=float)
    if c.shape != w.shape or c.ndim != 1:
        raise ValueError(f"cells and weights must be 1-D of equal length, got {c.shape} and {w.shape}")
    if jit.enabled("pfpeople"):
        ancestors, mass = resample_plan(c, w, n, n_cells=n_cells, rng=rng, resampler=fn)
    else:
        forced, mass = _forced_numpy(c, w, n, n_cells, rng)
        k = forced.size
        rest = fn(w, n - k, rng=rng) if n > k else np.zeros(0, dtype=np.intp)
        ancestors = np.concatenate((forced, rest))
    return ancestors, _shares(c[ancestors], mass, n_cells)


def _shares(new_cells: NDArray[np.intp], mass: NDArray[np.float64], n_cells: int) -> NDArray[np.float64]:
    """The new weights (n,): each cell's mass ``mass`` (n_cells,) shared equally by its new particles, whose cells
    are ``new_cells`` (n,)."""
    n_new = np.bincount(new_cells, minlength=n_cells)
    share = np.divide(mass, n_new, out=np.zeros(n_cells), where=n_new > 0)
    return share[new_cells]


def _forced_numpy(
    c: NDArray[np.intp], w: NDArray[np.float64], n: int, n_cells: int, rng: np.random.Generator
) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """Checks of :func:`resample_by_cell` and its one ancestor per occupied cell, drawn within the cell by weight
    (numpy). Returns the forced ancestors (K,), sorted by cell, and the mass per cell (n_cells,)."""
    if not np.all(np.isfinite(w)) or (w.size and w.min() < 0.0):
        raise ValueError("weights must be finite and non-negative")
    if c.size and (c.min() < 0 or c.max() >= n_cells):
        raise ValueError(f"cells must lie in [0, {n_cells})")
    mass = np.bincount(c, weights=w, minlength=n_cells).astype(np.float64, copy=False)
    occupied = np.flatnonzero(mass > 0.0)
    k = occupied.size
    if k == 0:
        raise ValueError("weights are all zero: nothing to resample")
    if n < k:
        raise ValueError(f"n={n} particles cannot keep one in each of the {k} cells holding mass")
    # Sort by cell (radix sort on small ints); the draw is a position in the cell's stretch of the running sum.
    key = c.astype(np.int16 if n_cells <= np.iinfo(np.int16).max else np.int32)
    order = np.argsort(key, kind="stable")
    cum = np.cumsum(w[order])
    counts = np.bincount(c, minlength=n_cells)
    end = np.cumsum(counts)
    start = end - counts
    before = np.where(start > 0, cum[np.maximum(start - 1, 0)], 0.0)
    target = before[occupied] + rng.random(k) * mass[occupied]
    pos = np.searchsorted(cum, target, side="right")
    pos = np.clip(pos, start[occupied], end[occupied] - 1)
    return order[pos], mass


def _forced_compiled(
    c: NDArray[np.intp],
    w: NDArray[np.float64],
    n: int,
    n_cells: int,
    rng: np.random.Generator,
    pool: BufferPool | None = None,
) -> tuple[NDArray[np.intp], NDArray[np.float64], float]:
    """Checks of :func:`resample_by_cell` and its one ancestor per occupied cell (compiled; the same draws).

    Returns the forced ancestors (K,), the mass per cell and the total mass (running sum in particle order).
    """
    mass, counts, total, status = kernels.cell_mass(c, w, n_cells)
    if status == 1:
        raise ValueError("weights must be finite and non-negative")
    if status == 2:
        raise ValueError(f"cells must lie in [0, {n_cells})")
    occupied = np.flatnonzero(mass > 0.0)
    k = occupied.size
    if k == 0:
        raise ValueError("weights are all zero: nothing to resample")
    if n < k:
        raise ValueError(f"n={n} particles cannot keep one in each of the {k} cells holding mass")
    forced = np.empty(k, dtype=np.intp)
    order = np.empty(c.size, dtype=np.intp) if pool is None else pool.take_index(c.size)
    kernels.forced_ancestors(c, w, counts, mass, occupied, rng.random(k), forced, order)
    if pool is not None:
        pool.give(order)
    return forced, mass, float(total)


def resample_plan(
    cells: NDArray[np.intp],
    weights: NDArray[np.float64],
    n: int,
    *,
    n_cells: int,
    rng: np.random.Generator,
    resampler: Callable[..., NDArray[np.intp]],
) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """The ancestors of :func:`resample_by_cell` and the cell masses, with the compiled kernels.

    The same draws in the same order as :func:`resample_by_cell`'s numpy code, and the same ancestors bit for bit
    (``resampler`` is :func:`systematic` compiled, any other callable called as there).

    Parameters
    ----------
    cells : ndarray of intp, shape (N,)
        Flat cell of each particle, in ``[0, n_cells)``.
    weights : ndarray, shape (N,)
        Occupancy masses, finite and >= 0.
    n, n_cells, rng, resampler
        As :func:`resample_by_cell` (``resampler`` a callable).

    Returns
    -------
    ancestors : ndarray of intp, shape (n,)
    mass : ndarray, shape (n_cells,)
        The mass per cell (``np.bincount(cells, weights)``).
    """
    c = np.ascontiguousarray(cells, dtype=np.intp)
    w = np.ascontiguousarray(weights, dtype=np.float64)
    forced, mass, _ = _forced_compiled(c, w, n, n_cells, rng)
    k = forced.size
    if n == k:
        return forced, mass
    if resampler is not systematic:  # whatever a callable returns follows, as in the numpy code
        rest = np.asarray(resampler(w, n - k, rng=rng), dtype=np.intp)
        return np.concatenate((forced, rest)), mass
    ancestors = np.empty(n, dtype=np.intp)
    ancestors[:k] = forced
    kernels.systematic_into(w, n - k, float(rng.random()), ancestors, k)
    return ancestors, mass


def resample_state(
    cells: NDArray[np.intp],
    weights: NDArray[np.float64],
    n: int,
    rows: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    *,
    n_cells: int,
    rng: np.random.Generator,
    resampler: Callable[..., NDArray[np.intp]],
    pool: BufferPool | None = None,
    sums: tuple[NDArray[np.float64], float] | None = None,
) -> tuple[NDArray[np.float64], ...]:
    """:func:`resample_by_cell` and the gather of the particles in one go (compiled).

    With :func:`systematic` (the filter's default) the scheme is :func:`resample_by_cell`'s, drawn in two passes
    over the particles and without sorting them (:func:`kernels.cell_systematic_ancestors`, then
    :func:`kernels.gather_ancestors`): each cell's forced ancestor is found on the running sum of the cell's
    weights in particle order instead of in the particles sorted by cell, which draws particle i of cell c with
    the same probability ``w_i / M_c`` but not the same particle as the numpy code. Its offspring counts have the
    same distribution (``tests/pfpeople/particle/test_kernels_particles.py``). Any other resampler gives
    :func:`resample_plan`'s ancestors, the numpy code's bit for bit.

    Parameters
    ----------
    cells, weights, n, n_cells, rng, resampler
        As :func:`resample_plan`.
    rows : tuple of 4 ndarrays, shape (N,) each
        The particles' x, y, vx, vy.
    pool : BufferPool, optional
        Where the new arrays and the scratch space come from (new arrays without).
    sums : tuple, optional
        ``(mass, total)``: the weights summed per cell (n_cells,) and in all, in particle order (as
        :func:`pfpeople.particle.updater.kernels.scale_sums` gives them; the weights are then taken as checked).
        Computed here without.

    Returns
    -------
    tuple of 5 ndarrays, shape (n,) each
        x, y, vx, vy of the ancestors and the new weights (each cell's mass shared by its new particles).
    """
    c = np.ascontiguousarray(cells, dtype=np.intp)
    w = np.ascontiguousarray(weights, dtype=np.float64)
    if resampler is not systematic:
        ancestors, mass = resample_plan(c, w, n, n_cells=n_cells, rng=rng, resampler=resampler)
        out = tuple(np.empty(ancestors.size) if pool is None else pool.take(ancestors.size) for _ in range(5))
        kernels.gather_resampled(ancestors, c, *rows, mass, n_cells, out)
        return out
    mass, total = _checked_sums(c, w, n_cells) if sums is None else sums
    return resample_scaled(c, w, np.ones(n_cells), n, rows, mass=mass, total=total, rng=rng, pool=pool)


def resample_scaled(
    cells: NDArray[np.intp],
    w: NDArray[np.float64],
    factor: NDArray[np.float64],
    n: int,
    rows: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    *,
    mass: NDArray[np.float64],
    total: float,
    rng: np.random.Generator,
    pool: BufferPool | None = None,
) -> tuple[NDArray[np.float64], ...]:
    """:func:`resample_state`'s systematic resampling (compiled) of particles whose weights are ``w * factor[cells]``,
    without writing those weights.

    Parameters
    ----------
    cells : ndarray of intp, shape (N,)
        The particles' cells, in ``[0, n_cells)``.
    w, factor : ndarray, shapes (N,) and (n_cells,)
        The weights as above (finite, >= 0).
    n : int
        Particles after resampling, at least the cells holding mass.
    rows : tuple of 4 ndarrays, shape (N,) each
        The particles' x, y, vx, vy.
    mass : ndarray, shape (n_cells,)
        The weights' sum per cell, shared by the cell's new particles. It may differ from the sums in particle order
        by round-off (a forced draw then falls back on the cell's last particle of positive weight, with a
        probability of that round-off).
    total : float
        Their sum, likewise.
    rng, pool
        As :func:`resample_state`.

    Returns
    -------
    tuple of 5 ndarrays, shape (n,) each
        x, y, vx, vy of the ancestors and the new weights (each cell's mass shared by its new particles).
    """
    occupied = _occupied(mass, n)
    k, m = occupied.size, n - occupied.size
    target = np.full(mass.size, np.inf)  # u_c M_c, kept below M_c so that the cell's last particle reaches it
    target[occupied] = np.minimum(rng.random(k) * mass[occupied], np.nextafter(mass[occupied], 0.0))
    off = float(rng.random()) if m > 0 else 0.0
    forced = np.full(mass.size, -1, dtype=np.intp)
    n_new = (mass > 0.0).astype(np.intp)
    anc = np.empty(n + 3, dtype=np.intp) if pool is None else pool.take_index(n + 3)
    kernels.cell_systematic_ancestors(cells, w, factor, (target, total, m, off), anc, forced, n_new)
    anc[:k] = forced[occupied]
    share = np.divide(mass, n_new, out=np.zeros(mass.size), where=n_new > 0)
    out = tuple(np.empty(n) if pool is None else pool.take(n) for _ in range(5))
    kernels.gather_ancestors(anc[:n], cells, rows, share, out)
    if pool is not None:
        pool.give(anc)
    return out


def _checked_sums(c: NDArray[np.intp], w: NDArray[np.float64], n_cells: int) -> tuple[NDArray[np.float64], float]:
    """The mass per cell (n_cells,) and the total of weights ``w`` in cells ``c``, checked as
    :func:`resample_by_cell` checks them."""
    mass, _, total, status = kernels.cell_mass(c, w, n_cells)
    if status == 1:
        raise ValueError("weights must be finite and non-negative")
    if status == 2:
        raise ValueError(f"cells must lie in [0, {n_cells})")
    return mass, float(total)


def _occupied(mass: NDArray[np.float64], n: int) -> NDArray[np.intp]:
    """The cells holding mass (K,), checked against a target of ``n`` particles (at least one per cell)."""
    occupied = np.flatnonzero(mass > 0.0)
    if occupied.size == 0:
        raise ValueError("weights are all zero: nothing to resample")
    if n < occupied.size:
        raise ValueError(f"n={n} particles cannot keep one in each of the {occupied.size} cells holding mass")
    return occupied
