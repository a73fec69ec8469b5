"""The front end's compiled kernels (segmentation, segment features, far leg blobs, the clutter map's free-space
tracing): their switch, numpy's summation order, and the warm-up before a run.

The switch is :mod:`gridbridge.jit`'s, scope ``"pfpeople"`` (numba importable and ``PFPEOPLE_NUMBA`` not
``0``): :func:`enabled` is read at every call, ``gridbridge.jit.override(on, "pfpeople")`` switches within a
process. Each kernel has a numpy twin (the code that came before it) and both give the same floats bit for bit
(``tests/test_numba_kernels.py``): the compiled loops add in numpy's order (:func:`pairwise_sum` is numpy's
pairwise summation, which ``np.add.reduce`` and ``np.add.reduceat`` use) and leave the transcendental functions
whose numpy implementation may be vectorised differently (``arctan2``, ``cos``, ``sin``) to numpy.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from gridbridge import jit as _jit

__all__ = ["AVAILABLE", "enabled", "njit", "pairwise_sum", "warm_up"]

#: numba imports.
AVAILABLE: bool = _jit.AVAILABLE
#: The decorator of the kernels (``numba.njit(cache=True, nogil=True, error_model="numpy")``; the function itself
#: without numba).
njit = _jit.jit


def enabled() -> bool:
    """True when the front end's compiled kernels are used (:func:`gridbridge.jit.enabled` of ``"pfpeople"``)."""
    return _jit.enabled("pfpeople")


@njit
def pairwise_sum(a: NDArray[np.float64], lo: int, n: int) -> float:  # pragma: no cover - compiled
    """``a[lo:lo + n]`` summed in the order of numpy's pairwise summation (``pairwise_sum`` of
    ``numpy/_core/src/umath/loops_utils.h.src``: 8 accumulators up to 128 values, halves above)."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[lo + i]
        return res
    if n <= 128:
        r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
        r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
        m = n - n % 8
        for i in range(8, m, 8):
            j = lo + i
            r0 += a[j]
            r1 += a[j + 1]
            r2 += a[j + 2]
            r3 += a[j + 3]
            r4 += a[j + 4]
            r5 += a[j + 5]
            r6 += a[j + 6]
            r7 += a[j + 7]
        res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        for i in range(m, n):
            res += a[lo + i]
        return res
    n2 = n // 2
    n2 -= n2 % 8
    return pairwise_sum(a, lo, n2) + pairwise_sum(a, lo + n2, n - n2)


def warm_up() -> None:
    """Load (or compile) every kernel now, so the first scan of a run does not wait for it.

    The first compiled call of a process starts numba's code generator (about half a second; loading each cached
    kernel then takes milliseconds, compiling one the first time about a second). Nothing happens when
    :func:`enabled` is False.
    """
    if not enabled():
        return
    from pfpeople.clutter_kernels import update_evidence
    from pfpeople.detectors import _kernels

    x = np.array([0.0, 0.01, 0.02, 1.0])
    beams = np.arange(4, dtype=np.intp)
    pts, _b, starts, counts, _r0, _r1, _n = _kernels.jump_segments(x, x, x + 1.0, beams, 0.13, 3)
    ct, _dt, ci, _di = _kernels.features_angles(pts, starts, counts)
    _kernels.features_rest(pts, starts, counts, np.zeros(ct.size), np.zeros(ci.size))
    _kernels.far_blobs(pts, _b, starts, counts, _r0, _r1, np.zeros(7))
    ev = np.zeros(4)
    no = np.zeros(0, dtype=np.intp)
    params = np.array([1.0, 1.0, 0.1, 20.0, 0.05, -1.0])
    update_evidence(ev, 2, no, no, np.zeros((1, 2)), np.ones(1, dtype=np.intp), np.ones(1), np.zeros(2), no, params)
