"""The compiled step's particle arrays: a pool of those the filter has let go of, reused by later steps instead of
fresh allocations (:class:`BufferPool`), and the prediction's buffer the particles are compacted into
(:class:`PassBuffer`).

A 1e6-particle step writes about ten arrays of 8 MB. Allocated afresh every step, their pages are faulted in
anew each time (the C library returns freed memory of this size to the system), which costs as much as the
filter's arithmetic. The pool keeps the arrays the filter drops and hands one out again only while nothing
else refers to it (CPython's reference count: no :class:`ParticleStep`, state, view or user variable holds
it), so an array a caller still holds is never written into: the promise of
:attr:`pfpeople.ParticleStep.particles` stands.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pfpeople.particle.state import ParticleState

__all__ = ["BufferPool", "PassBuffer", "arrays_of", "owner"]


def _refs(items: Sequence[Any], i: int) -> int:
    a = items[i]
    return sys.getrefcount(a)


def _baseline() -> int:
    items = [np.empty(1)]
    return _refs(items, 0)


#: The reference count :func:`_refs` sees for an array only the pool holds.
_ALONE = _baseline()


class BufferPool:
    """A few 1-D arrays for reuse (at most ``max_items``; the oldest dropped first).

    Parameters
    ----------
    max_items : int
        Arrays kept.
    """

    def __init__(self, max_items: int = 12) -> None:
        self.max_items = max_items
        self._free: list[NDArray[np.generic]] = []

    def __len__(self) -> int:
        return len(self._free)

    def give(self, *arrays: NDArray[np.generic] | None) -> None:
        """Offer arrays (or the arrays they view) for reuse; they are reused only once nothing else holds them."""
        for arr in arrays:
            if arr is None:
                continue
            base = arr if arr.base is None else arr.base
            if not isinstance(base, np.ndarray) or base.ndim != 1 or not base.flags.writeable:
                continue
            if any(base is held for held in self._free):
                continue
            self._free.append(base)
        del self._free[: max(len(self._free) - self.max_items, 0)]

    def take(self, size: int) -> NDArray[np.float64]:
        """A float64 array of ``size`` entries (uninitialised): a view of a pooled one nothing else holds, of at
        most 1.25 x ``size`` + 1024 entries, or of a new one of about 1.6 % more."""
        return self._take(size, np.dtype(np.float64))

    def take_index(self, size: int) -> NDArray[np.intp]:
        """As :meth:`take`, of dtype intp (cell and ancestor indices)."""
        return self._take(size, np.dtype(np.intp))

    def _take(self, size: int, dtype: np.dtype[Any]) -> NDArray[Any]:
        for i in range(len(self._free)):
            if _refs(self._free, i) != _ALONE:  # someone else holds it (checked before this frame refers to it)
                continue
            cand = self._free[i]
            if cand.dtype == dtype and size <= cand.size <= size + size // 4 + 1024:
                del self._free[i]
                return cand[:size]
        # A little room above the size asked for, so that the filter's arrays of slightly different lengths
        # (a prediction's capacity, the particle count, the count with births) can stand in for one another.
        return np.empty(size + size // 64 + 1024, dtype=dtype)[:size]


def owner(a: NDArray[np.generic]) -> object:
    """The array owning ``a``'s memory (``a`` itself when it owns it)."""
    return a if a.base is None else a.base


def arrays_of(st: ParticleState) -> tuple[NDArray[np.float64], ...]:
    """The five arrays of ``st``: x, y, vx, vy, w."""
    return (st.x, st.y, st.vx, st.vy, st.w)


class PassBuffer:
    """The compiled prediction's buffer: rows x, y, vx, vy, w and the cells of up to ``capacity`` particles (from
    ``pool``), the columns in use, and the per-cell sums of the particles written.

    Parameters
    ----------
    pool : BufferPool
        Where the rows come from.
    capacity : int
        Columns.
    n_cells : int
        Grid cells.
    squares : bool
        Also sum the squared masses per cell (:attr:`sq`).

    Attributes
    ----------
    out : tuple of 5 ndarrays, shape (capacity,) each
        x, y, vx, vy (m, m/s) and mass of the particles in columns ``0 .. used - 1``.
    cells : ndarray of intp, shape (capacity,)
        Their flat cells.
    used : int
        Columns written.
    prior, mass, counts, sq : ndarray, shape (n_cells,)
        The people prior, the particles' mass, count and squared mass per cell (``sq`` None without ``squares``).
    """

    def __init__(self, pool: BufferPool, capacity: int, n_cells: int, *, squares: bool) -> None:
        self.prior, self.mass, self.counts = np.zeros(n_cells), np.zeros(n_cells), np.zeros(n_cells, dtype=np.intp)
        self.out = tuple(pool.take(capacity) for _ in range(5))
        self.cells = pool.take_index(capacity)
        self.used = 0
        self.sq: NDArray[np.float64] | None = np.zeros(n_cells) if squares else None

    @property
    def sums(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.intp], NDArray[np.float64]]:
        """``(prior, mass, counts, sq)`` as a drawing pass accumulates them (``sq`` must be kept)."""
        assert self.sq is not None
        return self.prior, self.mass, self.counts, self.sq

    def append(self, part: ParticleState, where: NDArray[np.intp]) -> None:
        """Write ``part`` (cells ``where``) after the columns in use."""
        end = self.used + part.size
        if end > self.cells.size:
            raise RuntimeError(f"particle buffer of {self.cells.size} too small for {end} particles")
        for r, arr in enumerate(arrays_of(part)):
            self.out[r][self.used : end] = arr
        self.cells[self.used : end] = where
        self.used = end

    def holds(self, st: ParticleState, more: int) -> bool:
        """Whether ``st`` is the buffer's columns in use and ``more`` particles fit after them."""
        return (
            self.used == st.size
            and owner(st.x) is owner(self.out[0])
            and owner(st.w) is owner(self.out[4])
            and st.size + more <= self.cells.size
        )

    def state(self) -> tuple[ParticleState, NDArray[np.intp]]:
        """The particles in use (views of the buffer) and their cells."""
        j = self.used
        x, y, vx, vy, w = (r[:j] for r in self.out)
        return ParticleState.of_checked(x, y, vx, vy, w), self.cells[:j]
