"""Compiled kernels of the resampling by cell (:mod:`gridbridge.jit`; :mod:`pfpeople.particle.resampler.by_cell`).

Bit-identical to the numpy code (the same draws, the same IEEE operations in the same order: cell sums in particle
order, as ``np.bincount``; running sums sequential, as ``np.cumsum``): :func:`cell_mass`, :func:`forced_ancestors`,
:func:`systematic_into`, :func:`gather_resampled`. Without a sort (the same distribution, other ancestors):
:func:`cell_systematic_ancestors` with :func:`gather_ancestors`, which find each cell's forced ancestor on the running
sums in particle order, not in the particles sorted by cell (``tests/pfpeople/particle/test_compiled_draws.py``).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from gridbridge.jit import jit

__all__ = [
    "cell_mass",
    "cell_systematic_ancestors",
    "forced_ancestors",
    "gather_ancestors",
    "gather_resampled",
    "systematic_into",
]

#: Five particle arrays x, y, vx, vy, w (m, m, m/s, m/s, mass), each of shape (C,) (numba: a UniTuple).
Rows5 = tuple[NDArray[np.float64], ...]


@jit
def cell_mass(
    cells: NDArray[np.intp], w: NDArray[np.float64], n_cells: int
) -> tuple[NDArray[np.float64], NDArray[np.intp], float, int]:
    """Mass and particle count per cell (``np.bincount`` order), the total mass and a status.

    Returns ``(mass, counts, total, status)``: ``total`` is the running sum in particle order (``np.cumsum``'s
    last value); status 0 ok, 1 a weight negative or not finite, 2 a cell outside ``[0, n_cells)`` (the sums
    are then incomplete).
    """
    mass = np.zeros(n_cells)
    counts = np.zeros(n_cells, dtype=np.intp)
    total = 0.0
    status = 0
    for k in range(cells.size):
        wk = w[k]
        if not (wk >= 0.0 and wk < np.inf):
            return mass, counts, total, 1
        c = cells[k]
        total += wk
        if c < 0 or c >= n_cells:
            status = 2  # reported after the weights are all checked, as the numpy code orders its errors
            continue
        mass[c] += wk
        counts[c] += 1
    return mass, counts, total, status


@jit
def forced_ancestors(
    cells: NDArray[np.intp],
    w: NDArray[np.float64],
    counts: NDArray[np.intp],
    mass: NDArray[np.float64],
    occupied: NDArray[np.intp],
    u: NDArray[np.float64],
    out: NDArray[np.intp],
    order: NDArray[np.intp],
) -> None:
    """One ancestor per occupied cell, by weight within the cell (the first stage of
    :func:`~pfpeople.particle.resampler.by_cell.resample_by_cell`), written to ``out[:K]``.

    The particles are ordered by cell (a stable counting sort: ``np.argsort(kind="stable")``'s order), their
    weights summed in that order; the ancestor of cell c is the first in c whose running sum exceeds
    ``before_c + u_c M_c``, else the cell's last (``np.searchsorted`` clipped to the cell). ``order`` (N,) is
    scratch space for the sort.
    """
    n, n_cells = cells.size, counts.size
    start = np.empty(n_cells, dtype=np.intp)
    acc_i = 0
    for c in range(n_cells):
        start[c] = acc_i
        acc_i += counts[c]
    fill = start.copy()
    for k in range(n):
        c = cells[k]
        order[fill[c]] = k
        fill[c] += 1
    acc = 0.0  # the running sum over the particles in cell order (np.cumsum of the sorted weights)
    q = 0
    for c in range(n_cells):
        lo, end = start[c], start[c] + counts[c]
        if q < occupied.size and occupied[q] == c:
            target = acc + u[q] * mass[c]
            found = end - 1
            for t in range(lo, end):
                acc += w[order[t]]
                if found == end - 1 and t < end - 1 and acc > target:
                    found = t
            out[q] = order[found]
            q += 1
        else:
            for t in range(lo, end):
                acc += w[order[t]]


@jit
def systematic_into(w: NDArray[np.float64], m: int, off: float, out: NDArray[np.intp], start: int) -> None:
    """Systematic resampling of ``m`` ancestors (positions ``(k + off) / m``) into ``out[start:start + m]``:
    :func:`~pfpeople.particle.resampler.schemes.systematic` with its offset given, for weights with a positive sum."""
    n = w.size
    total = 0.0
    for i in range(n):
        total += w[i]
    acc = 0.0
    prev = 0
    j = start
    for i in range(n):
        acc += w[i]
        below = _systematic_count(acc, total, m, off, i == n - 1)
        for _ in range(below - prev):
            out[j] = i
            j += 1
        prev = below


@jit
def gather_resampled(
    anc: NDArray[np.intp],
    cells: NDArray[np.intp],
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    vx: NDArray[np.float64],
    vy: NDArray[np.float64],
    mass: NDArray[np.float64],
    n_cells: int,
    out: Rows5,
) -> NDArray[np.intp]:
    """The resampled particles: ``x[anc], y[anc], vx[anc], vy[anc]`` and the new weights ``M_c / n_c``.

    They are written to ``out`` (5 arrays x, y, vx, vy, w, shape (n,) each); returns ``new_cells = cells[anc]``.
    """
    n = anc.size
    n_new = np.zeros(n_cells, dtype=np.intp)
    new_cells = np.empty(n, dtype=np.intp)
    for t in range(n):
        c = cells[anc[t]]
        new_cells[t] = c
        n_new[c] += 1
    share = np.zeros(n_cells)
    for c in range(n_cells):
        if n_new[c] > 0:
            share[c] = mass[c] / n_new[c]
    ox, oy, ovx, ovy, ow = out
    for t in range(n):
        a = anc[t]
        ox[t], oy[t], ovx[t], ovy[t], ow[t] = x[a], y[a], vx[a], vy[a], share[new_cells[t]]
    return new_cells


@jit
def _systematic_count(acc: float, total: float, m: int, off: float, last: bool) -> int:
    """Positions ``(k + off) / m`` below the normalised running sum ``acc / total`` (``m`` for the last)."""
    if last:
        return m
    b = math.ceil(m * (acc / total) - off)
    return 0 if b < 0.0 else (m if b > m else int(b))


@jit
def cell_systematic_ancestors(
    cells: NDArray[np.intp],
    w: NDArray[np.float64],
    factor: NDArray[np.float64],
    draws: tuple[NDArray[np.float64], float, int, float],
    anc: NDArray[np.intp],
    forced: NDArray[np.intp],
    n_new: NDArray[np.intp],
) -> None:
    """The draws of :func:`~pfpeople.particle.resampler.by_cell.resample_by_cell` (systematic) in one pass, without a
    sort.

    The particles' weights are ``w[i] factor[cells[i]]``; ``draws = (target, total, m, off)``. The forced ancestor of
    cell c is the first particle (in particle order) at which the cell's running sum exceeds ``target[c]``
    (``u_c M_c``; ``inf`` for a cell without mass), else (round-off) the cell's last particle of positive weight:
    particle i of c with probability ``w_i / M_c``, as the numpy code's search in the sorted cell. The ``m``
    systematic ancestors (positions ``(k + off) / m`` on the running sum over all particles, of sum ``total``; the
    last particle takes what round-off leaves) are written, sorted, to ``anc[K:K + m]`` (K = ``anc.size - m - 3``;
    the 3 entries after them are room: each particle is written three times without a branch, the next
    overwriting what it does not own).

    ``forced`` (n_cells,) must hold -1 and receives the forced ancestors, ``n_new`` (n_cells,) must hold the forced
    count per cell (1 or 0) and receives the new particles per cell.
    """
    target, total, m, off = draws
    n, k = w.size, anc.size - m - 3
    rem = target.copy()  # the target less the cell's running sum; inf once the cell has its forced ancestor
    scale = m / total
    acc, prev = 0.0, 0
    for i in range(n):
        c = cells[i]
        wi = w[i] * factor[c]
        acc += wi
        below = min(max(math.ceil(acc * scale - off), 0), m)
        anc[k + prev], anc[k + prev + 1], anc[k + prev + 2] = i, i, i
        for t in range(k + prev + 3, k + below):  # a fourth copy and more: rare
            anc[t] = i
        n_new[c] += below - prev
        prev = below
        r = rem[c] - wi
        rem[c] = r
        if r < 0.0:  # taken once per cell
            forced[c], rem[c] = i, np.inf
    if n and prev < m:  # round-off left positions above the last running sum: the last particle's
        anc[k + prev : k + m] = n - 1
        n_new[cells[n - 1]] += m - prev
    _forced_fallback(cells, w, factor, target, forced)


@jit
def _forced_fallback(
    cells: NDArray[np.intp],
    w: NDArray[np.float64],
    factor: NDArray[np.float64],
    target: NDArray[np.float64],
    forced: NDArray[np.intp],
) -> None:
    """The cells with mass (finite ``target``) whose running sum never passed the target (it was computed from sums
    rounded otherwise): their last particle of positive weight as the forced ancestor (one pass from the end,
    only when some cell needs it)."""
    missing = 0
    for c in range(target.size):
        missing += forced[c] < 0 and target[c] < np.inf
    i = cells.size - 1
    while missing > 0 and i >= 0:
        c = cells[i]
        if forced[c] < 0 and target[c] < np.inf and w[i] * factor[c] > 0.0:
            forced[c] = i
            missing -= 1
        i -= 1


@jit
def gather_ancestors(
    anc: NDArray[np.intp],
    cells: NDArray[np.intp],
    src: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    share: NDArray[np.float64],
    out: Rows5,
) -> None:
    """The resampled particles: ``x[anc], y[anc], vx[anc], vy[anc]`` and the weights ``share[cells[anc]]`` (each
    cell's mass over its new count) into ``out`` (x, y, vx, vy, w; ``anc.size`` entries each)."""
    x, y, vx, vy = src
    ox, oy, ovx, ovy, ow = out
    for t in range(anc.size):
        a = anc[t]
        ox[t], oy[t], ovx[t], ovy[t], ow[t] = x[a], y[a], vx[a], vy[a], share[cells[a]]
