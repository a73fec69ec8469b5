"""The compiled see-through test of the motion detector (numba, :mod:`gridbridge.jit` scope ``"pfpeople"``).

:func:`moved_flags` gives :func:`pfpeople.detect.motion._moved_numpy`'s answers (the same integer beam arithmetic,
the same comparisons) in one pass without temporaries; ``tests/pfpeople/detect/test_motion.py`` compares them.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from gridbridge.jit import jit

__all__ = ["moved_flags"]


@jit
def moved_flags(  # pragma: no cover - compiled
    qr: NDArray[np.float64],
    qb: NDArray[np.float64],
    far: NDArray[np.float64],
    angle_min: float,
    increment: float,
    margin: float,
    tolerance: float,
    turn: float,
    range_max: float,
) -> NDArray[np.bool_]:
    """Whether a past scan (beams ``far``: the range beyond which each saw nothing; ``angle_min``, ``increment``)
    saw through each point at range ``qr`` and bearing ``qb`` (m, rad, that scan's frame): the nearest beam and
    ``max(1, ceil(atan(tolerance / r) / |increment|))`` beams on each side returned at least ``margin`` beyond (a
    point farther than ``range_max - margin`` is never seen through)."""
    n = far.size
    out = np.zeros(qr.size, dtype=np.bool_)
    two_pi = 2.0 * math.pi
    for i in range(qr.size):
        if increment > 0:
            rel = (qb[i] - angle_min) % two_pi
        else:
            rel = -((angle_min - qb[i]) % two_pi)
        k = int(np.rint(rel / increment))
        side = max(1, math.ceil((math.atan(tolerance / max(qr[i], 1e-6)) + turn) / abs(increment)))
        if k - side < 0 or k + side >= n:
            continue
        need = qr[i] + margin
        if need > range_max:
            continue
        ok = True
        for j in range(k - side, k + side + 1):
            if not far[j] >= need:
                ok = False
                break
        out[i] = ok
    return out
