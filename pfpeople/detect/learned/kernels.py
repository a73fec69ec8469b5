"""Compiled loops of the learned detector (numba, :mod:`gridbridge.jit` scope ``"pfpeople"``).

:func:`cutout_samples` is :func:`pfpeople.detect.learned.cutouts.cutouts`'s sampling in one pass over the
``(C, points)`` samples (no temporaries); :func:`claim_votes` is the greedy vote grouping of
:func:`pfpeople.detect.learned.votes.group_votes`. Each gives its numpy twin's result to float rounding
(``tests/pfpeople/detect/learned``: the two paths compared on real and random scans).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from gridbridge.jit import jit

__all__ = ["claim_votes", "cutout_samples"]


@jit
def cutout_samples(  # pragma: no cover - compiled
    far: NDArray[np.float64],
    angle_min: float,
    increment: float,
    full_turn: bool,
    bearings: NDArray[np.float64],
    centres: NDArray[np.float64],
    width: float,
    depth: float,
    out: NDArray[np.float32],
) -> None:
    """Fill ``out`` ``(C, P)`` with the normalised cut-outs of the scan ``far`` (ranges, ``inf`` where nothing
    returned) around ``(bearings, centres)`` (rad, m); see :mod:`pfpeople.detect.learned.cutouts`."""
    n = far.size
    c_count, p = out.shape
    for i in range(c_count):
        c = centres[i]
        half = math.atan(0.5 * width / max(c, 0.01))
        lo_edge, hi_edge = c - depth, c + depth
        for j in range(p):
            t = -1.0 + 2.0 * j / (p - 1)
            u = (bearings[i] + half * t - angle_min) / increment
            if full_turn:
                u = u % n
            elif u < 0.0 or u > n - 1:
                out[i, j] = 1.0
                continue
            lo = min(max(math.floor(u), 0.0), n - 1.0)
            k = int(lo)
            k2 = (k + 1) % n if full_turn else min(k + 1, n - 1)
            frac = min(max(u - lo, 0.0), 1.0)
            a = min(max(far[k], lo_edge), hi_edge)
            b = min(max(far[k2], lo_edge), hi_edge)
            out[i, j] = ((a + frac * (b - a)) - c) / depth


@jit
def claim_votes(pos: NDArray[np.float64], radius: float) -> NDArray[np.int64]:  # pragma: no cover - compiled
    """Greedy claims of votes sorted by descending score ``pos`` ``(N, 2)``: each vote's detection index (the
    best unclaimed vote claims every unclaimed vote within ``radius``)."""
    n = pos.shape[0]
    owner = np.full(n, -1, dtype=np.int64)
    r2 = radius * radius
    m = 0
    for i in range(n):
        if owner[i] >= 0:
            continue
        for j in range(i, n):
            if owner[j] < 0:
                dx = pos[j, 0] - pos[i, 0]
                dy = pos[j, 1] - pos[i, 1]
                if dx * dx + dy * dy <= r2:
                    owner[j] = m
        m += 1
    return owner
