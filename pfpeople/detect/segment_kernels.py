"""Compiled kernels of :mod:`pfpeople.detect.segments` (numba; the switch is :mod:`gridbridge.jit`'s, scope
``"pfpeople"``, read at every call).

Each kernel computes what the numpy code of its caller computes, in the same order of floating-point
operations, so the two agree bit for bit: sums of ``np.add.reduceat`` are :func:`gridbridge.kernels.pairwise_sum`
after the first element, sums of ``np.bincount`` are sequential from 0, ``np.maximum`` / ``np.minimum`` keep
NaN. The angles (``arctan2``) are left to numpy between two kernels.
"""

from __future__ import annotations

import math
from typing import TypeAlias

import numpy as np
from numpy.typing import NDArray

from gridbridge import jit as _jit
from gridbridge.jit import jit as njit
from gridbridge.kernels import pairwise_sum

__all__ = [
    "context_terms",
    "far_blobs",
    "features_angles",
    "features_rest",
    "jump_segments",
    "pair_greedy",
    "people_pairs",
    "warm_up",
]

#: What :func:`jump_segments` returns: points (P, 2), beams (P,), starts (S,), counts (S,), ranges before and after
#: (S,), runs dropped.
_Runs: TypeAlias = tuple[
    NDArray[np.float64],
    NDArray[np.intp],
    NDArray[np.intp],
    NDArray[np.intp],
    NDArray[np.float64],
    NDArray[np.float64],
    int,
]


#: Relative margin (far above the rounding of ``dx * dx + dy * dy`` and of ``hypot``: a few 1e-16) within which
#: :func:`context_terms` and :func:`_runs` compare distances by their ``hypot`` instead of their squares.
_MARGIN = 1e-9
#: Squared distances (m^2) below which :func:`context_terms` always computes the ``hypot`` (underflow).
_TINY = 1e-300


@njit
def _max(a: float, b: float) -> float:  # pragma: no cover - compiled
    """``np.maximum`` of two floats (NaN wins)."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a >= b else b


@njit
def _min(a: float, b: float) -> float:  # pragma: no cover - compiled
    """``np.minimum`` of two floats (NaN wins)."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a <= b else b


@njit
def _reduceat(a: NDArray[np.float64], starts: NDArray[np.intp], counts: NDArray[np.intp]) -> NDArray[np.float64]:
    """``np.add.reduceat(a, starts)`` for segments ``starts[s] .. starts[s] + counts[s]`` (counts >= 1)."""
    out = np.empty(starts.size)
    for s in range(starts.size):
        lo = starts[s]
        out[s] = a[lo] + pairwise_sum(a, lo + 1, counts[s] - 1)
    return out


@njit
def jump_segments(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    r: NDArray[np.float64],
    beams: NDArray[np.intp],
    jump: float,
    min_points: int,
) -> _Runs:  # pragma: no cover - compiled
    """The kept runs of consecutive points closer than ``jump`` (m), as in
    :func:`pfpeople.detect.segments.segment_scan`.

    Parameters
    ----------
    x, y, r : ndarray, shape (V,)
        End points (m, scan frame) and ranges (m) of the valid beams in walk order (V >= 1).
    beams : ndarray of intp, shape (V,)
        Their beam indices.
    jump : float
        Jump distance (m).
    min_points : int
        Runs with fewer points are dropped.

    Returns
    -------
    points, beams, starts, counts, range_before, range_after, n_small
        The fields of :class:`~pfpeople.detect.segments.Segments` (``n_small``: runs dropped).
    """
    n = x.size
    rs, m, kept, total = _runs(x, y, jump, min_points)
    pts = np.empty((total, 2))
    out_beams = np.empty(total, dtype=np.intp)
    starts = np.empty(kept, dtype=np.intp)
    counts = np.empty(kept, dtype=np.intp)
    before = np.empty(kept)
    after = np.empty(kept)
    k = 0
    q = 0
    for s in range(m):
        lo, hi = rs[s], rs[s + 1]
        if hi - lo < min_points:
            continue
        starts[k] = q
        counts[k] = hi - lo
        before[k] = r[lo - 1] if lo > 0 else math.inf
        after[k] = r[hi] if hi < n else math.inf
        for i in range(lo, hi):
            pts[q, 0] = x[i]
            pts[q, 1] = y[i]
            out_beams[q] = beams[i]
            q += 1
        k += 1
    return pts, out_beams, starts, counts, before, after, m - kept


@njit
def _runs(
    x: NDArray[np.float64], y: NDArray[np.float64], jump: float, min_points: int
) -> tuple[NDArray[np.intp], int, int, int]:  # pragma: no cover - compiled
    """The runs of :func:`jump_segments`: their starts ``rs[:m]`` then ``rs[m] = V`` (points closer than ``jump``
    (m) to the previous one continue a run), their number ``m``, and the number and points of those kept
    (at least ``min_points`` points). The gaps are ``np.hypot``'s; only those whose square lies within
    ``_MARGIN`` (relative) of ``jump ** 2`` are computed (the others lie on the same side of ``jump`` by far more
    than rounding), unless ``jump ** 2`` is outside ``[_TINY, 1 / _TINY]``."""
    n = x.size
    rs = np.empty(n + 1, dtype=np.intp)  # run starts, then n
    m = 1
    rs[0] = 0
    j2 = jump * jump
    lo, hi = j2 * (1.0 - _MARGIN), j2 * (1.0 + _MARGIN)
    if not (j2 >= _TINY and j2 <= 1.0 / _TINY):
        lo, hi = -1.0, math.inf  # every gap by its hypot
    for i in range(n - 1):
        dx, dy = x[i + 1] - x[i], y[i + 1] - y[i]
        v = dx * dx + dy * dy
        if v > hi or (v >= lo and math.hypot(dx, dy) > jump):
            rs[m] = i + 1
            m += 1
    rs[m] = n
    kept = 0
    total = 0
    for s in range(m):
        if rs[s + 1] - rs[s] >= min_points:
            kept += 1
            total += rs[s + 1] - rs[s]
    return rs, m, kept, total


@njit
def features_angles(
    pts: NDArray[np.float64], starts: NDArray[np.intp], counts: NDArray[np.intp]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:  # pragma: no cover
    """The arguments of the two ``arctan2`` of :func:`pfpeople.detect.segments.segment_features`.

    Returns
    -------
    cross_t, dot_t : ndarray, shape (N - 2,)
        Of every consecutive triple of points (right, mid, left): ``(left - mid) x (right - mid)`` and
        ``(left - mid) . (right - mid)``.
    cross_i, dot_i : ndarray, shape (N - 2 S,)
        Of every interior point p of a segment with first / last points f / l: ``(f - p) x (l - p)`` and
        ``(f - p) . (l - p)``, in point order.
    """
    N = pts.shape[0]
    nt = max(N - 2, 0)
    cross_t = np.empty(nt)
    dot_t = np.empty(nt)
    for i in range(nt):
        ml0 = pts[i + 2, 0] - pts[i + 1, 0]
        ml1 = pts[i + 2, 1] - pts[i + 1, 1]
        mr0 = pts[i, 0] - pts[i + 1, 0]
        mr1 = pts[i, 1] - pts[i + 1, 1]
        cross_t[i] = ml0 * mr1 - ml1 * mr0
        dot_t[i] = ml0 * mr0 + ml1 * mr1
    ni = N - 2 * starts.size
    cross_i = np.empty(ni)
    dot_i = np.empty(ni)
    k = 0
    for s in range(starts.size):
        lo = starts[s]
        hi = lo + counts[s] - 1
        for p in range(lo + 1, hi):
            u0 = pts[lo, 0] - pts[p, 0]
            u1 = pts[lo, 1] - pts[p, 1]
            v0 = pts[hi, 0] - pts[p, 0]
            v1 = pts[hi, 1] - pts[p, 1]
            cross_i[k] = u0 * v1 - u1 * v0
            dot_i[k] = u0 * v0 + u1 * v1
            k += 1
    return cross_t, dot_t, cross_i, dot_i


@njit
def _centred_sums(
    x: NDArray[np.float64], y: NDArray[np.float64], starts: NDArray[np.intp], counts: NDArray[np.intp]
) -> tuple[NDArray[np.float64], ...]:  # pragma: no cover - compiled
    """Per segment (S,): the centroid ``cx, cy`` and the sums of ``dx^2, dy^2, dx dy, dx z, dy z`` over its points
    (``d`` = point - centroid, ``z = dx^2 + dy^2``), each summed as ``np.add.reduceat`` sums."""
    N = x.size
    cx = _reduceat(x, starts, counts)
    cy = _reduceat(y, starts, counts)
    dxx = np.empty(N)
    dyy = np.empty(N)
    dxy = np.empty(N)
    dxz = np.empty(N)
    dyz = np.empty(N)
    for s in range(starts.size):
        n = float(counts[s])
        cx[s] = cx[s] / n
        cy[s] = cy[s] / n
        for p in range(starts[s], starts[s] + counts[s]):
            d0 = x[p] - cx[s]
            d1 = y[p] - cy[s]
            dxx[p] = d0 * d0
            dyy[p] = d1 * d1
            dxy[p] = d0 * d1
            z = d0 * d0 + d1 * d1
            dxz[p] = d0 * z
            dyz[p] = d1 * z
    sxx = _reduceat(dxx, starts, counts)
    syy = _reduceat(dyy, starts, counts)
    sxy = _reduceat(dxy, starts, counts)
    return cx, cy, sxx, syy, sxy, _reduceat(dxz, starts, counts), _reduceat(dyz, starts, counts)


@njit
def _moments(
    pts: NDArray[np.float64],
    starts: NDArray[np.intp],
    counts: NDArray[np.intp],
    out: NDArray[np.float64],
    steps: NDArray[np.float64],
) -> None:  # pragma: no cover - compiled
    """Columns 0-8 and 13 of the features (counts, spread, median, width, line and circle fits, steps); ``steps``
    (N,) gets the length of every step ``p -> p + 1`` inside a segment (m)."""
    S = starts.size
    N = pts.shape[0]
    x = np.ascontiguousarray(pts[:, 0])
    y = np.ascontiguousarray(pts[:, 1])
    cx, cy, sxx, syy, sxy, suz, svz = _centred_sums(x, y, starts, counts)
    buf = np.empty(N)
    for s in range(S):
        lo, c = starts[s], counts[s]
        n = float(c)
        out[s, 0] = n
        out[s, 1] = math.sqrt((sxx[s] + syy[s]) / (n - 1.0))
        half_tr = 0.5 * (sxx[s] + syy[s])
        dd = sxx[s] - syy[s]
        disc = math.sqrt(_max(0.25 * (dd * dd) + sxy[s] * sxy[s], 0.0))
        lin = _max(half_tr - disc, 0.0)
        out[s, 4] = lin
        # coordinate-wise median
        a, b = (c - 1) // 2, c // 2
        _sorted(x, lo, c, buf)
        mx = 0.5 * (buf[a] + buf[b])
        _sorted(y, lo, c, buf)
        my = 0.5 * (buf[a] + buf[b])
        for p in range(lo, lo + c):
            buf[p] = math.hypot(x[p] - mx, y[p] - my)
        out[s, 2] = (buf[lo] + pairwise_sum(buf, lo + 1, c - 1)) / n
        out[s, 13] = math.hypot(mx, my)
        hi = lo + c - 1
        out[s, 3] = math.hypot(x[hi] - x[lo], y[hi] - y[lo])
        _circle(x, y, lo, c, sxx[s], syy[s], sxy[s], suz[s], svz[s], cx[s], cy[s], lin, buf, out, s)
        _steps(x, y, lo, c, out, s, steps)


@njit
def _sorted(v: NDArray[np.float64], lo: int, c: int, buf: NDArray[np.float64]) -> None:  # pragma: no cover
    """``buf[:c] = np.sort(v[lo:lo + c])`` (insertion sort below 32 values: no allocation)."""
    if c > 32:
        buf[:c] = np.sort(v[lo : lo + c])
        return
    for i in range(c):
        val = v[lo + i]
        j = i - 1
        while j >= 0 and buf[j] > val:
            buf[j + 1] = buf[j]
            j -= 1
        buf[j + 1] = val


@njit
def _circle(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    lo: int,
    c: int,
    suu: float,
    svv: float,
    suv: float,
    suz: float,
    svz: float,
    cx: float,
    cy: float,
    lin: float,
    buf: NDArray[np.float64],
    out: NDArray[np.float64],
    s: int,
) -> None:  # pragma: no cover - compiled
    """Columns 5 (circularity) and 6 (radius) of segment ``s``: the Kasa circle fit."""
    n = float(c)
    det = suu * svv - suv * suv
    scale = _max(suu + svv, 1e-300)
    ok = det > 1e-12 * (scale * scale)
    if not ok:
        out[s, 5] = lin
        out[s, 6] = _min(math.inf, 10.0)
        return
    a_c = 0.5 * (svv * suz - suv * svz) / det
    b_c = 0.5 * (suu * svz - suv * suz) / det
    r2 = a_c * a_c + b_c * b_c + (suu + svv) / n
    radius = math.sqrt(r2)
    x0 = cx + a_c
    y0 = cy + b_c
    for p in range(lo, lo + c):
        res = radius - math.hypot(x[p] - x0, y[p] - y0)
        buf[p] = res * res
    out[s, 5] = buf[lo] + pairwise_sum(buf, lo + 1, c - 1)
    out[s, 6] = _min(radius, 10.0)


@njit
def _steps(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    lo: int,
    c: int,
    out: NDArray[np.float64],
    s: int,
    steps: NDArray[np.float64],
) -> None:  # pragma: no cover - compiled
    """Columns 7 (boundary length) and 8 (boundary regularity) of segment ``s`` (sequential sums); the step
    lengths (m) into ``steps[lo:lo + c - 1]``."""
    step_sum = 0.0
    step_sq = 0.0
    for p in range(lo, lo + c - 1):
        st = math.hypot(x[p + 1] - x[p], y[p + 1] - y[p])
        steps[p] = st
        step_sum += st
        step_sq += st * st
    n_steps = float(c) - 1.0
    out[s, 7] = step_sum
    out[s, 8] = math.sqrt(_max(step_sq - step_sum * step_sum / n_steps, 0.0) / _max(n_steps - 1.0, 1.0))


@njit
def features_rest(
    pts: NDArray[np.float64],
    starts: NDArray[np.intp],
    counts: NDArray[np.intp],
    th: NDArray[np.float64],
    ang: NDArray[np.float64],
) -> NDArray[np.float64]:  # pragma: no cover - compiled
    """The feature matrix ``(S, 14)`` from the points and the turning / inscribed angles of
    :func:`features_angles` (``th`` over the triples, ``ang`` over the interior points, rad in [0, 2 pi)).

    A triple's side lengths ``|left - mid|`` and ``|right - mid|`` are the segment's step lengths of
    :func:`_steps` (``np.hypot`` of the same differences, up to the sign: the same floats)."""
    S = starts.size
    out = np.empty((S, 14))
    steps = np.empty(pts.shape[0])
    _moments(pts, starts, counts, out, steps)
    k = 0
    for s in range(S):
        lo, c = starts[s], counts[s]
        n = float(c)
        curv_sum = 0.0
        th_sum = 0.0
        for i in range(lo, lo + c - 2):  # triples (i, i + 1, i + 2) inside the segment
            ml0 = pts[i + 2, 0] - pts[i + 1, 0]
            ml1 = pts[i + 2, 1] - pts[i + 1, 1]
            mr0 = pts[i, 0] - pts[i + 1, 0]
            mr1 = pts[i, 1] - pts[i + 1, 1]
            cross = ml0 * mr1 - ml1 * mr0
            denom = steps[i + 1] * steps[i] * math.hypot(pts[i + 2, 0] - pts[i, 0], pts[i + 2, 1] - pts[i, 1])
            curv_sum += 2.0 * cross / denom if denom > 0 else 0.0
            th_sum += th[i]
        out[s, 9] = curv_sum / n
        out[s, 10] = th_sum / n
        s1 = 0.0
        for j in range(k, k + c - 2):
            s1 += ang[j]
        n_int = n - 2.0
        iav = s1 / n_int
        s2 = 0.0
        for j in range(k, k + c - 2):
            dv = ang[j] - iav
            s2 += dv * dv
        k += c - 2
        out[s, 11] = iav
        out[s, 12] = math.sqrt(s2 / _max(n_int - 1.0, 1.0))
    return out


@njit
def far_blobs(
    pts: NDArray[np.float64],
    beams: NDArray[np.intp],
    starts: NDArray[np.intp],
    counts: NDArray[np.intp],
    range_before: NDArray[np.float64],
    range_after: NDArray[np.float64],
    params: NDArray[np.float64],
) -> tuple[NDArray[np.bool_], NDArray[np.bool_], NDArray[np.float64]]:  # pragma: no cover - compiled
    """The far leg blobs and small runs of :func:`pfpeople.detect.legs.far_leg_blobs` among every run.

    Parameters
    ----------
    pts, beams, starts, counts, range_before, range_after
        The runs of ``segment_scan(scan, min_points=1)`` (m, scan frame).
    params : ndarray, shape (7,)
        ``(far_max_points, far_from, far_min_jump, far_leg_width, |angle_increment|, far_max_width, unused)``.

    Returns
    -------
    keep, small : ndarray of bool, shape (R,)
        The far leg blobs, and every small foreground run beyond ``far_from``.
    centres : ndarray, shape (R, 2)
        The runs' centroids (m).
    """
    R = starts.size
    N = pts.shape[0]
    max_points, far_from, min_jump, leg_width, inc, max_width = (
        params[0],
        params[1],
        params[2],
        params[3],
        params[4],
        params[5],
    )
    r, x, y, sr, centres = _blob_sums(pts, starts, counts, max_points)
    keep = np.zeros(R, dtype=np.bool_)
    small = np.zeros(R, dtype=np.bool_)
    for s in range(R):
        lo, c = starts[s], counts[s]
        hi = lo + c - 1
        cf = float(c)
        before = range_before[s] if lo > 0 and abs(beams[lo] - beams[lo - 1]) == 1 else math.inf
        after = range_after[s] if hi < N - 1 and abs(beams[hi + 1] - beams[hi]) == 1 else math.inf
        rmin = r[lo]
        for p in range(lo + 1, lo + c):
            rmin = _min(rmin, r[p])
        rmean = sr[s] / cf
        sm = (cf <= max_points) and (rmin >= far_from) and (before - rmean >= min_jump) and (after - rmean >= min_jump)
        small[s] = sm
        need = _max(np.floor(leg_width / (_max(rmean, 1e-3) * _max(inc, 1e-9))), 1.0)
        width = math.hypot(x[hi] - x[lo], y[hi] - y[lo])
        keep[s] = sm and (cf >= need) and (width <= max_width)
    return keep, small, centres


@njit
def _blob_sums(
    pts: NDArray[np.float64], starts: NDArray[np.intp], counts: NDArray[np.intp], max_points: float
) -> tuple[
    NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]
]:  # pragma: no cover - compiled
    """The ranges ``r`` (N,), coordinates ``x``, ``y`` (N,) (m) of the points of :func:`far_blobs`, the runs'
    range sums ``sr`` (R,) (``np.add.reduceat``'s) and centroids (R, 2) (m). The ranges of a run of more than
    ``max_points`` points are 0 (such a run is neither small nor a blob: :func:`far_blobs` does not read them)."""
    N = pts.shape[0]
    r = np.zeros(N)
    for s in range(starts.size):
        if float(counts[s]) <= max_points:
            for p in range(starts[s], starts[s] + counts[s]):
                r[p] = math.hypot(pts[p, 0], pts[p, 1])
    x = np.ascontiguousarray(pts[:, 0])
    y = np.ascontiguousarray(pts[:, 1])
    sr = _reduceat(r, starts, counts)
    sx = _reduceat(x, starts, counts)
    sy = _reduceat(y, starts, counts)
    centres = np.empty((starts.size, 2))
    for s in range(starts.size):
        cf = float(counts[s])
        centres[s, 0] = sx[s] / cf
        centres[s, 1] = sy[s] / cf
    return r, x, y, sr, centres


@njit
def pair_greedy(pts: NDArray[np.float64], lo: float, hi: float) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
    """:func:`pfpeople.detect.legs.pair_legs` in one pass, the same pairs: the admissible pairs ``i < j`` (distance
    ``np.hypot`` in ``[lo, hi]``) taken closest first, ties in ``(i, j)`` order (a stable sort of the pairs in
    that order by distance: ``np.lexsort((j, i, d))``'s order), each leg in at most one pair.

    Returns the pairs ``(P, 2)`` and which of the ``K`` legs are paired.
    """
    k = pts.shape[0]
    m = k * (k - 1) // 2
    ii, jj = np.empty(m, dtype=np.intp), np.empty(m, dtype=np.intp)
    d = np.empty(m)
    n = 0
    for i in range(k):
        for j in range(i + 1, k):
            dist = math.hypot(pts[i, 0] - pts[j, 0], pts[i, 1] - pts[j, 1])
            if dist >= lo and dist <= hi:
                ii[n], jj[n], d[n] = i, j, dist
                n += 1
    order = np.argsort(d[:n], kind="mergesort")
    paired = np.zeros(k, dtype=np.bool_)
    out = np.empty((min(n, k // 2), 2), dtype=np.intp)
    p = 0
    for t in order:
        a, b = ii[t], jj[t]
        if not paired[a] and not paired[b]:
            paired[a] = paired[b] = True
            out[p, 0], out[p, 1] = a, b
            p += 1
    return out[:p].copy(), paired


@njit
def context_terms(
    centroids: NDArray[np.float64], widths: NDArray[np.float64], cap: float, radius: float
) -> NDArray[np.float64]:  # pragma: no cover - compiled
    """:func:`pfpeople.detect.segments.context_features` of ``n >= 2`` centroids ``(n, 2)`` (m) and widths ``(n,)``
    (m), ``cap`` and ``radius`` (m) its constants; ``(0, 4)`` when a centroid is not finite (the caller's numpy
    code then decides).

    Every row's distances are ``np.hypot`` of the centroids' differences, the own one ``inf``: the nearest is the
    first minimum (``np.argmin``), the second nearest the second smallest value (``np.partition``'s ``[1]``).
    The squared distances pick the candidates: a ``hypot`` is computed only where the square lies within
    ``_MARGIN`` (relative) of the second smallest square or of ``radius ** 2``, or below ``_TINY``; every other
    distance exceeds two candidates' (or is on the same side of ``radius``) by far more than rounding.

    Returns
    -------
    ndarray, shape (n, 4)
        The nearest and the second nearest distance (capped at ``cap``; the second ``cap`` when ``n == 2``),
        the number of distances ``<= radius`` and the nearest segment's width.
    """
    n = centroids.shape[0]
    for i in range(n):
        if not (math.isfinite(centroids[i, 0]) and math.isfinite(centroids[i, 1])):
            return np.empty((0, 4))
    out = np.empty((n, 4))
    d2 = np.empty(n)
    for i in range(n):
        m1, m2 = math.inf, math.inf
        for j in range(n):
            dx, dy = centroids[i, 0] - centroids[j, 0], centroids[i, 1] - centroids[j, 1]
            v = math.inf if j == i else dx * dx + dy * dy
            d2[j] = v
            if v < m1:
                m1, m2 = v, m1
            elif v < m2:
                m2 = v
        _context_row(centroids, widths, i, d2, m2 * (1.0 + _MARGIN) + _TINY, cap, radius, out)
        if n == 2:
            out[i, 1] = cap
    return out


@njit
def _context_row(
    centroids: NDArray[np.float64],
    widths: NDArray[np.float64],
    i: int,
    d2: NDArray[np.float64],
    bound: float,
    cap: float,
    radius: float,
    out: NDArray[np.float64],
) -> None:  # pragma: no cover - compiled
    """Row ``i`` of :func:`context_terms` from its squared distances ``d2`` (n,) (m^2, ``inf`` at ``i``): the
    ``hypot`` of the candidates ``d2 <= bound`` and of the squares near ``radius ** 2``."""
    r2 = radius * radius
    lo, hi = r2 * (1.0 - _MARGIN), r2 * (1.0 + _MARGIN) + _TINY
    best, second, near, count = math.inf, math.inf, 0, 0
    for j in range(d2.size):
        v = d2[j]
        d = -1.0
        if v <= bound or (v >= lo and v <= hi):
            dx, dy = centroids[i, 0] - centroids[j, 0], centroids[i, 1] - centroids[j, 1]
            d = math.inf if j == i else math.hypot(dx, dy)
        if v <= bound:
            if d < best:
                second, best, near = best, d, j
            elif d < second:
                second = d
        if v < lo or (v <= hi and d <= radius):
            count += 1
    out[i, 0] = min(best, cap)
    out[i, 1] = min(second, cap)
    out[i, 2] = float(count)
    out[i, 3] = widths[near]


@njit
def people_pairs(
    legs: NDArray[np.float64], widths: NDArray[np.float64], max_single: float, lo: float, hi: float, singles: bool
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:  # pragma: no cover - compiled
    """:func:`pfpeople.detect.legs.people_and_single_legs` of legs ``(K, 2)`` (m) and widths ``(K,)`` (m):
    ``max_single``, ``lo``, ``hi`` and ``singles`` are its ``max_single_leg_width``, ``min_separation``,
    ``max_separation`` and ``count_single_legs``.

    Returns
    -------
    people : ndarray, shape (M, 2)
        The legs-together segments (``width > max_single``) in order, the pairs' midpoints ``0.5 * (a + b)`` of
        :func:`pair_greedy` on the narrow legs, then (``singles``) the narrow legs in no pair (m).
    alone : ndarray, shape (S, 2)
        The narrow legs in no pair, in order (m).
    """
    k = legs.shape[0]
    together = np.empty(k, dtype=np.bool_)
    n_tog = 0
    for i in range(k):
        together[i] = widths[i] > max_single
        n_tog += together[i]
    narrow = np.empty((k - n_tog, 2))
    q = 0
    for i in range(k):
        if not together[i]:
            narrow[q, 0], narrow[q, 1] = legs[i, 0], legs[i, 1]
            q += 1
    pairs, paired = pair_greedy(narrow, lo, hi)
    n_alone = narrow.shape[0] - 2 * pairs.shape[0]
    alone = np.empty((n_alone, 2))
    people = np.empty((n_tog + pairs.shape[0] + (n_alone if singles else 0), 2))
    q, a = 0, 0
    for i in range(k):
        if together[i]:
            people[q, 0], people[q, 1] = legs[i, 0], legs[i, 1]
            q += 1
    for p in range(pairs.shape[0]):
        for c in range(2):
            people[q, c] = 0.5 * (narrow[pairs[p, 0], c] + narrow[pairs[p, 1], c])
        q += 1
    for i in range(narrow.shape[0]):
        if not paired[i]:
            alone[a, 0], alone[a, 1] = narrow[i, 0], narrow[i, 1]
            a += 1
            if singles:
                people[q, 0], people[q, 1] = narrow[i, 0], narrow[i, 1]
                q += 1
    return people, alone


def warm_up() -> None:
    """Load (or compile) the kernels of this module now, so the first scan of a run does not wait for them.

    The first compiled call of a process starts numba's code generator (about half a second; loading each cached
    kernel then takes milliseconds, compiling one the first time about a second). Nothing happens when
    ``gridbridge.jit.enabled("pfpeople")`` is False.
    """
    if not _jit.enabled("pfpeople"):
        return
    x = np.array([0.0, 0.01, 0.02, 1.0])
    beams = np.arange(4, dtype=np.intp)
    pts, b, starts, counts, r0, r1, _n = jump_segments(x, x, x + 1.0, beams, 0.13, 3)
    ct, _dt, ci, _di = features_angles(pts, starts, counts)
    features_rest(pts, starts, counts, np.zeros(ct.size), np.zeros(ci.size))
    far_blobs(pts, b, starts, counts, r0, r1, np.zeros(7))
    pair_greedy(np.zeros((3, 2)), 0.1, 0.5)
    centroids = np.zeros((2, 2))
    context_terms(centroids, np.zeros(2), 3.0, 0.6)
    centroids.flags.writeable = False  # a scan's segment centroids are read-only (cached on the scan)
    context_terms(centroids, np.zeros(2), 3.0, 0.6)
    people_pairs(np.zeros((3, 2)), np.zeros(3), 0.25, 0.1, 0.6, False)
