"""The compiled intersection loop of :func:`evaluation.scenarios.scan.raycast.cast_rays` (numba).

The switch is :mod:`gridbridge.jit`'s, scope ``"evaluation"`` (numba importable and ``PFPEOPLE_NUMBA`` not ``0``).
:func:`first_hits` visits the same (beam, primitive) pairs as the numpy code, in the same order (circles, then
segments; per bearing window shift, primitive by primitive, beams ascending), computes each pair's range with the
same IEEE operations in the same order (no fused multiply-add: numba contracts nothing without ``fastmath``;
``math.sqrt`` is correctly rounded as ``np.sqrt``) and keeps, per beam, the smallest range and the last primitive
that reached it (numpy's ``np.minimum.at`` then ``hit[beam[win]] = prim[win]``, where the last repeated index
wins). The ranges and hits are the same bit for bit (``tests/evaluation/scenarios/test_scan_sim.py``).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from gridbridge.jit import jit

__all__ = ["first_hits"]


@jit
def _keep(best: NDArray[np.float64], hit: NDArray[np.int64], i: int, t: float, k: int) -> None:  # pragma: no cover
    """Beam ``i`` meets primitive ``k`` at ``t``: the nearer hit, or on a tie the later primitive."""
    if t < best[i]:
        best[i] = t
        hit[i] = k
    elif t == best[i]:
        hit[i] = k


@jit
def first_hits(
    cos_a: NDArray[np.float64],
    sin_a: NDArray[np.float64],
    circ: NDArray[np.float64],
    c_lo: NDArray[np.int64],
    c_hi: NDArray[np.int64],
    seg: NDArray[np.float64],
    s_lo: NDArray[np.int64],
    s_hi: NDArray[np.int64],
    best: NDArray[np.float64],
    hit: NDArray[np.int64],
) -> None:  # pragma: no cover - compiled
    """The first hit of every beam over the windowed pairs, into ``best`` (inf: none) and ``hit`` (-1: none).

    Parameters
    ----------
    cos_a, sin_a : ndarray, shape (N,)
        The beams' unit directions.
    circ : ndarray, shape (C, 3)
        ``(x, y, radius)`` of the circles.
    c_lo, c_hi : ndarray of int64, shape (W, C)
        Per window shift and circle, the first and last beam index tested (inclusive; none when ``hi < lo``).
    seg : ndarray, shape (S, 4)
        ``(x0, y0, x1, y1)`` of the segments.
    s_lo, s_hi : ndarray of int64, shape (W, S)
        The same for the segments.
    best, hit : ndarray, shape (N,)
        Filled with inf and -1 by the caller; updated in place (segment ``k`` is hit ``C + k``).
    """
    n_circ = circ.shape[0]
    for w in range(c_lo.shape[0]):
        for k in range(n_circ):
            px, py, pr = circ[k, 0], circ[k, 1], circ[k, 2]
            for i in range(c_lo[w, k], c_hi[w, k] + 1):
                dx, dy = cos_a[i], sin_a[i]
                b = dx * px + dy * py
                disc = b * b - (px * px + py * py - pr * pr)
                if disc >= 0.0:
                    t = b - math.sqrt(disc)
                    if t > 0.0:
                        _keep(best, hit, i, t, k)
    for w in range(s_lo.shape[0]):
        for k in range(seg.shape[0]):
            sx, sy = seg[k, 0], seg[k, 1]
            ex, ey = seg[k, 2] - sx, seg[k, 3] - sy
            for i in range(s_lo[w, k], s_hi[w, k] + 1):
                dx, dy = cos_a[i], sin_a[i]
                den = dx * ey - dy * ex
                if abs(den) > 1e-12:
                    t = (sx * ey - sy * ex) / den
                    s = (sx * dy - sy * dx) / den
                    if t > 0.0 and s >= 0.0 and s <= 1.0:
                        _keep(best, hit, i, t, n_circ + k)
