"""Plain-loop reference implementations of the grid filter's equations.

Written for clarity, one cell at a time, straight from the paper's equations; the vectorised code in
:mod:`gridbridge.people_motion` and :mod:`gridbridge.measurement` is tested against them, and the grid
benchmark uses them as the naive baseline measured in the same run.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def predict_people_loop(
    bel: NDArray[np.float64], kernel: NDArray[np.float64], outside: float, form: str
) -> NDArray[np.float64]:
    """Eq. 6 with eq. 8 (``form="paper"``) or the linear sum (``"linear"``), looping over cells and offsets."""
    nx, ny = bel.shape
    r = kernel.shape[0] // 2
    out = np.zeros_like(bel)
    for i in range(nx):
        for j in range(ny):
            lin, s = 0.0, 0.0
            for a in range(-r, r + 1):
                for b in range(-r, r + 1):
                    si, sj = i - a, j - b  # source cell of a displacement (a, b)
                    src = bel[si, sj] if (0 <= si < nx and 0 <= sj < ny) else outside
                    p_k = kernel[r + a, r + b]
                    lin += p_k * src
                    if (a, b) != (0, 0):
                        q = p_k * src
                        s += q / (1.0 - q)
            if form == "linear":
                out[i, j] = lin
            else:
                out[i, j] = kernel[r, r] * bel[i, j] + s / (1.0 + s) * (1.0 - bel[i, j])
    return out


def fuse_and_update_loop(
    prior: NDArray[np.float64], fired: NDArray[np.bool_], ppv: NDArray[np.float64], fnr: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Eqs. 13, 14 and 12 for hard detections and full fields of view, one cell at a time."""
    out = np.empty_like(prior)
    d, nx, ny = fired.shape
    for i in range(nx):
        for j in range(ny):
            if fired[:, i, j].any():
                prod = 1.0
                for k in range(d):
                    prod *= 1.0 - (ppv[k] if fired[k, i, j] else fnr[k])
                lik = 1.0 - prod
            else:
                lik = float(min(fnr))
            num = lik * prior[i, j]
            out[i, j] = num / (num + (1.0 - lik) * (1.0 - prior[i, j]))
    return out
