"""Particle arrays the filter has let go of, reused by later steps instead of fresh allocations.

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

__all__ = ["BufferPool"]


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

    def _take(self, size: int, dt: np.dtype[Any]) -> NDArray[Any]:
        for i in range(len(self._free)):
            if _refs(self._free, i) != _ALONE:  # someone else holds it (checked before this frame refers to it)
                continue
            cand = self._free[i]
            if cand.dtype == dt and size <= cand.size <= size + size // 4 + 1024:
                del self._free[i]
                return cand[:size]
        # A little room above the size asked for, so that the filter's arrays of slightly different lengths
        # (a prediction's capacity, the particle count, the count with births) can stand in for one another.
        return np.empty(size + size // 64 + 1024, dtype=dt)[:size]
