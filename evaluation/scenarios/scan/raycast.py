"""Vectorised 2-D laser ray casting over circles and line segments.

A beam from the origin of the scan frame along the unit direction ``d = (cos a, sin a)`` hits

- a circle of centre ``c`` and radius ``r`` at ``t = d.c - sqrt((d.c)^2 - (|c|^2 - r^2))`` when the
  discriminant is non-negative and ``t > 0`` (the near intersection; a laser inside a circle sees nothing
  of it);
- a segment ``p0 + s e``, ``e = p1 - p0``, ``s in [0, 1]``: solving ``t d = p0 + s e`` with 2-D cross
  products (``a x b = a_x b_y - a_y b_x``) gives ``t = (p0 x e) / (d x e)`` and ``s = (p0 x d) / (d x e)``
  (beams parallel to the segment miss it).

All (beam, primitive) pairs whose bearings can meet are evaluated at once as flat arrays (no Python loop
over beams or primitives); the range of a beam is the smallest positive ``t``. With evenly spaced beams the
windows' pairs are intersected by a compiled loop (:mod:`.raycast_kernels`; the numpy code with
``PFPEOPLE_NUMBA=0``: the same ranges and hits bit for bit). Timing: ``python -m evaluation.bench.raycast``
(this code compiled, its numpy code and the previous release, same run; ``docs/speed.md``).

Reported ranges (REP-117 conventions, which most ROS 1/2 laser drivers follow): a beam without a return
(nothing hit, a hit beyond ``range_max`` or a random dropout) reads ``no_return``: ``"inf"`` (+Inf,
REP-117's "no return"), ``"nan"``, ``"above_max"`` (``range_max + 1`` m, as older drivers that report
"max range + something") or ``"at_max"`` (exactly ``range_max``, as some drivers write); a measured range below
``range_min`` reads ``-inf`` (REP-117's "too close").

Mixed pixels: a beam's footprint has a width, so a beam at a depth edge (its neighbour's true range differs by
more than ``MIXED_PIXEL_EDGE_M``) returns, with probability ``mixed_pixel``, a range between the two surfaces
(``r + u (r_neighbour - r)``, ``u ~ U(0, 1)``): the "veiling" points real lasers show beside legs and furniture.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from evaluation.scenarios.scan.raycast_kernels import first_hits
from gridbridge import jit as _jit

__all__ = ["NO_RETURN_KINDS", "beam_angles", "cast_rays", "measure_ranges", "no_return_value"]

NO_RETURN_KINDS = ("inf", "nan", "above_max", "at_max")
#: Adjacent beams whose true ranges differ by more than this (m) straddle a depth edge (mixed pixels).
MIXED_PIXEL_EDGE_M = 0.1


def beam_angles(angle_min: float, angle_max: float, n_beams: int) -> NDArray[np.float64]:
    """Bearings (rad, scan frame) of ``n_beams`` beams from ``angle_min`` to ``angle_max`` inclusive.

    The angle increment of the scan is ``(angle_max - angle_min) / (n_beams - 1)``.
    """
    if isinstance(n_beams, bool) or not isinstance(n_beams, int | np.integer) or n_beams < 2:
        raise ValueError(f"n_beams must be an integer >= 2, got {n_beams!r}")
    if not (math.isfinite(angle_min) and math.isfinite(angle_max)) or angle_max <= angle_min:
        raise ValueError(f"angle_max ({angle_max!r}) must exceed angle_min ({angle_min!r})")
    return np.linspace(angle_min, angle_max, int(n_beams))


def _window_bounds(
    rel: NDArray[np.float64], half: NDArray[np.float64], inc: float, n: int, bounds: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The beams that can see each primitive: for angular windows ``[rel - half, rel + half]`` (rel in [0, 2 pi)
    from the first beam), as is and shifted by -+2 pi (a window across the first beam's bearing), the first and
    last beam ``i`` with ``lo <= i inc <= hi`` and ``bounds[k, 0] <= i <= bounds[k, 1]``.

    Returns
    -------
    first, last : ndarray of int64, shape (3, K)
        Per shift (0, -2 pi, +2 pi) and primitive; no beam where ``last < first``.
    """
    shifts = np.array([[0.0], [-2 * math.pi], [2 * math.pi]])
    lo, hi = rel - half + shifts, rel + half + shifts
    first = np.maximum(np.clip(np.ceil(lo / inc - 1e-9), 0, n).astype(np.int64), bounds[:, 0])
    last = np.minimum(np.clip(np.floor(hi / inc + 1e-9), -1, n - 1).astype(np.int64), bounds[:, 1])
    return first, last


def _window_pairs(first: NDArray[np.int64], last: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """(beam, primitive) index pairs of :func:`_window_bounds`'s windows: per shift, primitive by primitive, beams
    ascending."""
    beams, prims = [], []
    for i0, i1 in zip(first, last, strict=True):
        counts = np.maximum(i1 - i0 + 1, 0)
        total = int(counts.sum())
        prims.append(np.repeat(np.arange(i0.size, dtype=np.int64), counts))
        start = np.repeat(np.cumsum(counts) - counts, counts)
        beams.append(np.repeat(i0, counts) + (np.arange(total, dtype=np.int64) - start))
    return np.concatenate(beams), np.concatenate(prims)


def _all_pairs(n: int, bounds: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Every (beam, primitive) pair within ``bounds``, beam by beam (unevenly spaced beams)."""
    k = bounds.shape[0]
    bi, pi_ = np.repeat(np.arange(n), k), np.tile(np.arange(k), n)
    inside = (bi >= bounds[pi_, 0]) & (bi <= bounds[pi_, 1])
    return bi[inside], pi_[inside]


def _circle_windows(
    circ: NDArray[np.float64], a0: float, inc: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Bearing windows ``(rel, half)`` of the circles: a circle at distance ``d`` spans ``theta_c +- asin(r / d)``."""
    cx, cy, r = circ[:, 0], circ[:, 1], circ[:, 2]
    d = np.hypot(cx, cy)
    outside = d > r
    half = np.arcsin(np.clip(r / np.where(outside, d, 1.0), 0.0, 1.0)) + 0.5 * inc
    half = np.where(outside, half, -1.0)  # a laser inside a circle sees nothing of it
    return np.mod(np.arctan2(cy, cx) - a0, 2.0 * math.pi), half


def _segment_windows(
    seg: NDArray[np.float64], a0: float, inc: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Bearing windows ``(mid, half)`` of the segments: the shorter arc between the end points' bearings."""
    th0 = np.arctan2(seg[:, 1], seg[:, 0])
    th1 = np.arctan2(seg[:, 3], seg[:, 2])
    diff = np.mod(th1 - th0 + math.pi, 2.0 * math.pi) - math.pi
    return np.mod(th0 + 0.5 * diff - a0, 2.0 * math.pi), 0.5 * np.abs(diff) + inc


def _windows(
    circ: NDArray[np.float64],
    seg: NDArray[np.float64],
    a0: float,
    inc: float,
    n: int,
    bounds: tuple[NDArray[np.int64], NDArray[np.int64]],
) -> tuple[NDArray[np.int64], ...]:
    """:func:`_window_bounds` of the circles and the segments, in one pass: ``c_first, c_last, s_first, s_last``."""
    (c_rel, c_half), (s_rel, s_half) = _circle_windows(circ, a0, inc), _segment_windows(seg, a0, inc)
    first, last = _window_bounds(
        np.concatenate((c_rel, s_rel)), np.concatenate((c_half, s_half)), inc, n, np.concatenate(bounds)
    )
    k = len(circ)
    return first[:, :k], last[:, :k], first[:, k:], last[:, k:]


def _evenly_spaced(a: NDArray[np.float64], inc: float) -> bool:
    """Whether the beams ``a`` are ``inc`` apart (within 1e-9 rad; ``np.allclose``, its quick case first)."""
    d = np.diff(a)
    if math.isfinite(inc) and bool(np.all(np.abs(d - inc) <= 1e-9)):  # implies np.allclose's answer
        return True
    return bool(np.allclose(d, inc, rtol=0.0, atol=1e-9))


def _circle_hits(
    cos_a: NDArray[np.float64],
    sin_a: NDArray[np.float64],
    circ: NDArray[np.float64],
    bi: NDArray[np.int64],
    pi_: NDArray[np.int64],
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """The pairs ``(bi, pi_)`` whose beam meets its circle in front of the laser: beams, circles, ranges."""
    dx, dy = cos_a[bi], sin_a[bi]
    px, py, pr = circ[pi_, 0], circ[pi_, 1], circ[pi_, 2]
    b = dx * px + dy * py
    disc = b * b - (px * px + py * py - pr * pr)
    ok = disc >= 0.0
    t = b - np.sqrt(np.where(ok, disc, 0.0))
    keep = ok & (t > 0.0)
    return bi[keep], pi_[keep], t[keep]


def _segment_hits(
    cos_a: NDArray[np.float64],
    sin_a: NDArray[np.float64],
    seg: NDArray[np.float64],
    bi: NDArray[np.int64],
    pi_: NDArray[np.int64],
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """The pairs ``(bi, pi_)`` whose beam crosses its segment in front of the laser: beams, segments, ranges."""
    dx, dy = cos_a[bi], sin_a[bi]
    sx, sy = seg[pi_, 0], seg[pi_, 1]
    ex, ey = seg[pi_, 2] - sx, seg[pi_, 3] - sy
    den = dx * ey - dy * ex  # d x e
    ok = np.abs(den) > 1e-12
    sden = np.where(ok, den, 1.0)
    t = (sx * ey - sy * ex) / sden  # (p0 x e) / (d x e)
    s = (sx * dy - sy * dx) / sden  # (p0 x d) / (d x e)
    keep = ok & (t > 0.0) & (s >= 0.0) & (s <= 1.0)
    return bi[keep], pi_[keep], t[keep]


def _beam_bounds(given: ArrayLike | None, k: int, n: int, name: str) -> NDArray[np.int64]:
    """``circle_beams`` / ``segment_beams`` of :func:`cast_rays` as a (k, 2) array (default: every beam)."""
    if given is None:
        return np.broadcast_to(np.array([0, n - 1], dtype=np.int64), (k, 2))
    b = np.asarray(given, dtype=np.int64).reshape(-1, 2)
    if b.shape[0] != k:
        raise ValueError(f"cast_rays: {name} must have one [first, last] row per primitive ({k}), got {b.shape[0]}")
    return b


def cast_rays(
    angles: ArrayLike,
    *,
    circles: ArrayLike = (),
    segments: ArrayLike = (),
    circle_beams: ArrayLike | None = None,
    segment_beams: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """First hit of every beam from the origin of the scan frame.

    Only the (beam, primitive) pairs whose bearings can meet are intersected: a circle at distance ``d``
    spans the bearings ``theta_c +- asin(r / d)``, a segment the shorter arc between its end points' bearings.
    With evenly spaced ``angles`` (as a laser's) these windows become beam index ranges, intersected by a compiled
    loop (:mod:`evaluation.scenarios.scan.raycast_kernels`; the numpy code with ``PFPEOPLE_NUMBA=0``, the same
    result bit for bit); otherwise every pair is tested. The result is the same either way.

    Parameters
    ----------
    angles : array_like, shape (N,)
        Beam bearings (rad, scan frame, counter-clockwise from x).
    circles : array_like, shape (C, 3)
        ``(x, y, radius)`` (m, scan frame).
    segments : array_like, shape (S, 4)
        ``(x0, y0, x1, y1)`` (m, scan frame).
    circle_beams, segment_beams : array_like, shape (C, 2) / (S, 2), optional
        First and last beam index (inclusive) each primitive can be seen by (default all beams). A swept scan
        casts each angular block against the scene at its own time in one call this way.

    Returns
    -------
    ranges : ndarray, shape (N,)
        Distance (m) to the first hit; ``inf`` where the beam hits nothing.
    hit : ndarray, shape (N,), int64
        Index of the primitive hit: ``0 .. C-1`` the circles, ``C .. C+S-1`` the segments, ``-1`` none.
    """
    a = np.asarray(angles, dtype=float).reshape(-1)
    circ = np.asarray(circles, dtype=float).reshape(-1, 3)
    seg = np.asarray(segments, dtype=float).reshape(-1, 4)
    n = a.size
    best = np.full(n, np.inf)
    hit = np.full(n, -1, dtype=np.int64)
    if n == 0:
        return best, hit
    inc = (a[-1] - a[0]) / (n - 1) if n > 1 else 1.0
    even = n > 1 and inc > 0 and _evenly_spaced(a, inc)
    cos_a, sin_a = np.cos(a), np.sin(a)
    cb = _beam_bounds(circle_beams, len(circ), n, "circle_beams")
    sb = _beam_bounds(segment_beams, len(seg), n, "segment_beams")
    if even:
        c_lo, c_hi, s_lo, s_hi = _windows(circ, seg, a[0], inc, n, (cb, sb))
        if _jit.enabled("evaluation"):
            first_hits(cos_a, sin_a, circ, c_lo, c_hi, seg, s_lo, s_hi, best, hit)
            return best, hit
        c_pairs, s_pairs = _window_pairs(c_lo, c_hi), _window_pairs(s_lo, s_hi)
    else:
        c_pairs, s_pairs = _all_pairs(n, cb), _all_pairs(n, sb)
    found = []
    if len(circ):
        found.append(_circle_hits(cos_a, sin_a, circ, *c_pairs))
    if len(seg):
        bi, pi_, t = _segment_hits(cos_a, sin_a, seg, *s_pairs)
        found.append((bi, pi_ + len(circ), t))
    if found:
        bi = np.concatenate([f[0] for f in found])
        pi_ = np.concatenate([f[1] for f in found])
        t = np.concatenate([f[2] for f in found])
        np.minimum.at(best, bi, t)
        win = t == best[bi]
        hit[bi[win]] = pi_[win]
    return best, hit


def no_return_value(kind: str, range_max: float) -> float:
    """The range a beam without a return reads (see the module docstring)."""
    if kind == "inf":
        return math.inf
    if kind == "nan":
        return math.nan
    if kind == "above_max":
        return float(range_max) + 1.0
    if kind == "at_max":
        return float(range_max)
    raise ValueError(f"no_return must be one of {NO_RETURN_KINDS}, got {kind!r}")


def _mix_edges(r: NDArray[np.float64], p: float, rng: np.random.Generator) -> NDArray[np.float64]:
    """True ranges ``(N,)`` with mixed pixels: each beam whose finite neighbour (the farther-differing one) lies
    more than ``MIXED_PIXEL_EDGE_M`` away in range takes, with probability ``p``, a range uniformly between its own
    surface and the neighbour's. Beams without a hit stay so (a footprint half on nothing returns the near part)."""
    left = np.concatenate(([np.nan], r[:-1]))
    right = np.concatenate((r[1:], [np.nan]))
    with np.errstate(invalid="ignore"):
        dl = np.where(np.isfinite(left), left - r, 0.0)
        dr = np.where(np.isfinite(right), right - r, 0.0)
    other = np.where(np.abs(dl) >= np.abs(dr), dl, dr)
    edge = np.isfinite(r) & (np.abs(other) > MIXED_PIXEL_EDGE_M) & (rng.random(r.size) < p)
    out = r.copy()
    out[edge] += rng.random(int(edge.sum())) * other[edge]
    return out


def measure_ranges(
    true_ranges: ArrayLike,
    *,
    range_min: float,
    range_max: float,
    noise_sd: float,
    dropout: float,
    no_return: str = "inf",
    mixed_pixel: float = 0.0,
    rng: np.random.Generator,
) -> NDArray[np.float64]:
    """What the laser reports for the true ranges: Gaussian noise, dropouts and the out-of-range codes.

    Parameters
    ----------
    true_ranges : array_like, shape (N,)
        Exact first-hit distances (m); ``inf`` for no hit.
    range_min, range_max : float
        The laser's interval (m).
    noise_sd : float
        Standard deviation (m) of additive Gaussian range noise.
    dropout : float
        Probability that a beam returns nothing.
    no_return : {"inf", "nan", "above_max", "at_max"}
        Value of a beam without a return.
    mixed_pixel : float
        Probability that a beam at a depth edge reports a range between the two surfaces (module docstring).
    rng : numpy.random.Generator

    Returns
    -------
    ndarray, shape (N,)
        Reported ranges (m).
    """
    r = np.asarray(true_ranges, dtype=float).reshape(-1)
    if mixed_pixel > 0 and r.size > 1:
        r = _mix_edges(r, mixed_pixel, rng)
    miss = no_return_value(no_return, range_max)
    noisy = r + rng.normal(0.0, noise_sd, size=r.size) if noise_sd > 0 else r.copy()
    lost = ~np.isfinite(r) | (noisy > range_max)
    if dropout > 0:
        lost |= rng.random(r.size) < dropout
    out = np.where(lost, miss, noisy)
    return np.where(~lost & (noisy < range_min), -np.inf, out)
