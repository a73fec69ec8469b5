"""Whether a beam that hits a surface returns: the surface's reflectivity, the range and the angle of incidence.

A time-of-flight laser reports a return when the echo's power clears its detection threshold. For a diffuse
(Lambertian) surface of reflectivity ``rho`` hit at range ``r`` with angle of incidence ``theta`` (between the beam
and the surface normal), the echo's power is proportional to ``rho cos(theta) / r^2``. Data sheets state the
threshold as the range at which a 10 %-reflectance target at normal incidence is still detected (e.g. 8 m for a
laser with a 25 m range on white walls): ``R10``. With the detection noise of a real receiver the threshold is soft:

    P(return) = sigmoid( ( ln(rho cos(theta) / r^2) - ln(0.1 / R10^2) ) / SOFTNESS )

so a 10 % target at normal incidence returns half the beams at ``R10``, more nearer, fewer farther, and fewer at a
grazing angle. This is what makes real people hard to see: dark trousers (``rho`` 0.03-0.1) at 3-7 m put only a few
returns on the scan, the edges of a leg (grazing) return less than its front, and one leg may return nothing while
the other is seen. White walls seen head-on return to the laser's full range.

``range_at_10pct = 0`` (:class:`~evaluation.scenarios.scan.scene.LaserConfig`) turns the model off: every hit
returns (the ideal laser of the scenes written before it).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["SOFTNESS", "incidence_cosines", "return_probability"]

#: Width (natural-log units of echo power) of the detection threshold's soft edge: a target half as bright as the
#: threshold returns about 20 % of beams, twice as bright about 80 %.
SOFTNESS = 0.5


def incidence_cosines(
    cos_a: NDArray[np.float64],
    sin_a: NDArray[np.float64],
    ranges: NDArray[np.float64],
    hit: NDArray[np.int64],
    circles: NDArray[np.float64],
    segments: NDArray[np.float64],
) -> NDArray[np.float64]:
    """``|cos(theta)|`` of every beam at its hit (1 where it hits nothing).

    Parameters
    ----------
    cos_a, sin_a : ndarray, shape (N,)
        The beams' direction (scan frame).
    ranges : ndarray, shape (N,)
        True first-hit distances (m).
    hit : ndarray, shape (N,)
        The primitive hit (:func:`~evaluation.scenarios.scan.raycast.cast_rays`: circles first, then segments; -1
        none).
    circles : ndarray, shape (C, 3)
        ``(x, y, radius)`` (m, scan frame).
    segments : ndarray, shape (S, 4)
        ``(x0, y0, x1, y1)`` (m, scan frame).
    """
    out = np.ones(ranges.shape)
    n_c = circles.shape[0]
    on_c = (hit >= 0) & (hit < n_c)
    if on_c.any():
        c = circles[hit[on_c]]
        hx = ranges[on_c] * cos_a[on_c] - c[:, 0]
        hy = ranges[on_c] * sin_a[on_c] - c[:, 1]
        norm = np.maximum(np.hypot(hx, hy), 1e-12)
        out[on_c] = np.abs(cos_a[on_c] * hx + sin_a[on_c] * hy) / norm
    on_s = hit >= n_c
    if on_s.any():
        s = segments[hit[on_s] - n_c]
        ex, ey = s[:, 2] - s[:, 0], s[:, 3] - s[:, 1]
        norm = np.maximum(np.hypot(ex, ey), 1e-12)
        out[on_s] = np.abs(cos_a[on_s] * ey - sin_a[on_s] * ex) / norm
    return out


def return_probability(
    reflectivity: NDArray[np.float64], cos_inc: NDArray[np.float64], ranges: NDArray[np.float64], range_at_10pct: float
) -> NDArray[np.float64]:
    """P(return) of each beam (module docstring); 1 where the beam hits nothing (``inf`` range)."""
    p = np.ones(ranges.shape)
    ok = np.isfinite(ranges) & (ranges > 0)
    power = np.log(np.maximum(reflectivity[ok] * cos_inc[ok], 1e-12) / ranges[ok] ** 2)
    threshold = math.log(0.1 / range_at_10pct**2)
    p[ok] = 1.0 / (1.0 + np.exp(-(power - threshold) / SOFTNESS))
    return p
