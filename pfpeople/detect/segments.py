"""Scan segmentation and per-segment geometric features, shared by both laser detectors.

Segmentation
------------
Invalid beams (NaN, inf, or a range outside ``[range_min, range_max]`` of the scan, or outside the optional
``max_range`` of the segmentation) are dropped first: they neither form points nor split segments, so a single
drop-out inside a leg does not cut it in two. The remaining end points, in beam order, are cut wherever the
Euclidean distance between two consecutive valid points exceeds ``jump_distance`` (the jump-distance
segmentation of Arras et al. 2007); segments with fewer than ``min_points`` points are discarded (and counted in
:attr:`Segments.n_dropped_small`). An empty scan, or one without valid beams, gives zero segments.

Beam order: the points are always taken in increasing bearing (counter-clockwise). A scan with a negative
``angle_increment`` (a laser mounted upside down or turning clockwise) is walked from its last beam to its
first, so the signed features (``mean_curvature``, ``mean_angle_diff``, ``iav``) mean the same for every laser
and such a scan gives the same segments and features as the same points scanned counter-clockwise; the point
positions are unchanged and ``Segments.beams`` still index the scan as given.

Features (Arras, Mozos & Burgard 2007; Spinello & Siegwart 2008)
-----------------------------------------------------------------
For a segment with points ``p_1 .. p_n`` (scan frame, m), centroid ``c`` and coordinate-wise median ``m``:

=======================  ================================================================================
``n_points``             n
``std``                  sqrt(sum |p_k - c|^2 / (n - 1))
``avg_median_dev``       mean |p_k - m|
``width``                |p_n - p_1|
``linearity``            sum of squared residuals of the total-least-squares line (smallest eigenvalue of
                         the scatter matrix)
``circularity``          sum (r_c - |p_k - x_c|)^2 for the algebraic (Kasa) circle fit (x_c, r_c)
``radius``               r_c of that fit (capped at ``RADIUS_CAP`` m for almost straight segments)
``boundary_length``      sum |p_{k+1} - p_k|
``boundary_regularity``  standard deviation of |p_{k+1} - p_k|
``mean_curvature``       signed Menger curvature 4 A / (a b c), summed over consecutive triples, divided by n
``mean_angle_diff``      turning angle at interior points (rad, in [0, 2 pi)), summed, divided by n
``iav``                  mean inscribed angle at interior points between p_1 and p_n (rad)
``iav_std``              standard deviation of that inscribed angle (rad)
``distance``             |m|, range of the segment (m)
=======================  ================================================================================

Context features: the other segments of the same scan, from their centroids (m). A leg's context is what tells
it from furniture that looks like a leg: a person's other leg lies 0.1-0.4 m away and is as wide; a chair's or a
table's legs come in threes and fours 0.4-0.6 m apart; a bump on a wall has neighbours centimetres away.

==============================  =========================================================================
``neighbour_distance``          distance to the nearest other segment's centroid (capped at ``CONTEXT_CAP``)
``second_neighbour_distance``   distance to the second nearest (capped at ``CONTEXT_CAP``)
``neighbours_within_0_6m``      number of other segments whose centroids lie within 0.6 m
``neighbour_width``             ``width`` of the nearest other segment (0 without one)
==============================  =========================================================================

The two "means" divide by the number of points n, not by the n - 2 triples, as leg_tracker's
``calcClusterFeatures`` does (the shipped boosted model was trained on these values).

All features are computed for all segments of a scan at once: by compiled loops
(:mod:`pfpeople.detect.segment_kernels`) when numba is enabled (:mod:`gridbridge.jit`, scope ``"pfpeople"``), else with
``numpy.add.reduceat`` (no Python loop over segments or points); both give the same floats.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from gridbridge import jit as _jit
from gridbridge.validation import check_int, check_positive
from pfpeople.detect import segment_kernels as _kernels
from pfpeople.sensors import LaserScan
from pfpeople.units import Beams, Metres

__all__ = [
    "CONTEXT_CAP",
    "FEATURE_NAMES",
    "RADIUS_CAP",
    "SegmentationParams",
    "Segments",
    "context_features",
    "scan_segments",
    "segment_features",
    "segment_scan",
]

#: Names of the columns of :func:`segment_features`, in order.
FEATURE_NAMES: tuple[str, ...] = (
    "n_points",
    "std",
    "avg_median_dev",
    "width",
    "linearity",
    "circularity",
    "radius",
    "boundary_length",
    "boundary_regularity",
    "mean_curvature",
    "mean_angle_diff",
    "iav",
    "iav_std",
    "distance",
    "neighbour_distance",
    "second_neighbour_distance",
    "neighbours_within_0_6m",
    "neighbour_width",
)

#: Distance (m) at which the context features' neighbour distances are capped (and given without neighbours).
CONTEXT_CAP = 3.0

#: Radius (m) of ``neighbours_within_0_6m``.
_NEIGHBOUR_RADIUS = 0.6

#: The columns :func:`context_features` computes: the last of :data:`FEATURE_NAMES`.
_N_CONTEXT = 4

#: Largest circle radius reported (m): a straight segment's fitted circle is arbitrarily large.
RADIUS_CAP = 10.0


@dataclass(frozen=True, kw_only=True)
class SegmentationParams:
    """Parameters of the jump-distance segmentation.

    Parameters
    ----------
    jump_distance : float
        Two consecutive valid end points further apart than this (m) start a new segment. The default 0.13 m
        is the clustering distance used to label the leg_tracker training bags (Leigh et al. 2015).
    min_points : int
        Segments with fewer points are discarded (>= 3, the features need three points).
    max_range : float
        Beams with a larger range (m) are treated as invalid; ``inf`` keeps all valid beams.
    """

    jump_distance: Metres = 0.13
    min_points: Beams = 3
    max_range: Metres = math.inf

    def __post_init__(self) -> None:
        check_positive(self.jump_distance, "SegmentationParams.jump_distance")
        check_int(self.min_points, "SegmentationParams.min_points", minimum=3)
        if math.isnan(self.max_range) or self.max_range <= 0:
            raise ValueError(f"SegmentationParams.max_range must be positive, got {self.max_range!r}")


@dataclass(frozen=True, kw_only=True, eq=False)
class Segments:
    """The segments of one scan, stored flat.

    Attributes
    ----------
    points : ndarray, shape (N, 2)
        End points of all kept segments, concatenated in beam order (m, scan frame).
    beams : ndarray, shape (N,)
        Beam index of each point in the scan.
    starts : ndarray, shape (S,)
        Index into ``points`` of the first point of each segment; segment ``s`` is
        ``points[starts[s]:starts[s] + counts[s]]``.
    counts : ndarray, shape (S,)
        Number of points of each segment.
    range_before, range_after : ndarray, shape (S,)
        Range (m) of the valid beam just before the segment's first point and just after its last point
        (``inf`` when there is none: scan border or only invalid beams). A segment standing in front of its
        background (a leg) has both larger than its end ranges.
    n_invalid : int
        Number of beams dropped as invalid (NaN, inf or out of range).
    n_dropped_small : int
        Number of segments discarded for having fewer than ``min_points`` points.
    """

    points: NDArray[np.float64]
    beams: NDArray[np.intp]
    starts: NDArray[np.intp]
    counts: NDArray[np.intp]
    range_before: NDArray[np.float64]
    range_after: NDArray[np.float64]
    n_invalid: int = 0
    n_dropped_small: int = 0

    def __len__(self) -> int:
        return int(self.starts.size)

    @property
    def segment_ids(self) -> NDArray[np.intp]:
        """Segment index of every point, shape (N,)."""
        return np.repeat(np.arange(self.starts.size), self.counts)

    @property
    def centroids(self) -> NDArray[np.float64]:
        """Mean point of every segment, shape (S, 2) (m, scan frame); computed once (read only)."""
        c = self.__dict__.get("_centroids")
        if c is None:
            if len(self) == 0:
                c = np.zeros((0, 2))
            else:
                c = np.add.reduceat(self.points, self.starts, axis=0) / self.counts[:, None]
            c.flags.writeable = False
            object.__setattr__(self, "_centroids", c)
        return c

    def segment(self, s: int) -> NDArray[np.float64]:
        """Points of segment ``s``, shape (n_s, 2)."""
        return self.points[self.starts[s] : self.starts[s] + self.counts[s]]


def segment_scan(
    scan: LaserScan, *, params: SegmentationParams | None = None, min_points: int | None = None
) -> Segments:
    """Cut a scan into segments at range jumps.

    Parameters
    ----------
    scan : LaserScan
        The scan; invalid beams are dropped (see the module docstring).
    params : SegmentationParams, optional
        Jump distance, minimum points and maximum range; defaults to ``SegmentationParams()``.
    min_points : int, optional
        Overrides ``params.min_points`` (>= 1): runs too short for the features, such as the far leg blobs of
        :func:`pfpeople.detect.legs.far_leg_blobs` (1 keeps every run, so the segments cover every valid
        beam).

    Returns
    -------
    Segments
        The kept segments (possibly none).
    """
    if not isinstance(scan, LaserScan):
        raise TypeError(f"scan must be a LaserScan, got {type(scan).__name__}")
    p = params if params is not None else SegmentationParams()
    if min_points is None:
        min_points = p.min_points
    else:
        min_points = check_int(min_points, "min_points", minimum=1)
    beams, r, x, y = _valid_points(scan, p.max_range)
    n_invalid = int(scan.ranges.size - beams.size)
    if beams.size == 0:
        return Segments(
            points=np.zeros((0, 2)),
            beams=np.zeros(0, dtype=np.intp),
            starts=np.zeros(0, dtype=np.intp),
            counts=np.zeros(0, dtype=np.intp),
            range_before=np.zeros(0),
            range_after=np.zeros(0),
            n_invalid=n_invalid,
        )
    if _jit.enabled("pfpeople"):
        pts, kb, starts, counts, before, after, n_small = _kernels.jump_segments(
            x, y, r, beams, float(p.jump_distance), int(min_points)
        )
        return Segments(
            points=pts,
            beams=kb,
            starts=starts,
            counts=counts,
            range_before=before,
            range_after=after,
            n_invalid=n_invalid,
            n_dropped_small=int(n_small),
        )
    return _runs_numpy(np.column_stack((x, y)), r, beams, p.jump_distance, min_points, n_invalid)


#: The latest (scan, max_range, valid points) of :func:`_valid_points`: a scan is segmented twice (the shape
#: features' segments and the far leg blobs' runs).
_LATEST_POINTS: tuple[LaserScan, float, tuple[Any, ...]] | None = None


def _valid_points(
    scan: LaserScan, max_range: float
) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The valid beams of ``scan`` within ``max_range`` in walk order (see the module docstring): beam indices,
    ranges (m) and end points ``x``, ``y`` (m, scan frame), each shape (V,); the latest result is kept by the
    scan's identity (do not change the arrays)."""
    global _LATEST_POINTS
    latest = _LATEST_POINTS
    if latest is not None and latest[0] is scan and latest[1] == max_range:
        return latest[2]
    with np.errstate(invalid="ignore"):
        valid = scan.valid & (scan.ranges <= max_range)
    beams = np.flatnonzero(valid)
    if scan.angle_increment < 0:  # walk the beams counter-clockwise (see the module docstring)
        beams = beams[::-1]
    r = scan.ranges[beams]
    a = scan.angle_min + scan.angle_increment * beams
    out = (beams.astype(np.intp), r, r * np.cos(a), r * np.sin(a))
    _LATEST_POINTS = (scan, max_range, out)
    return out


def _runs_numpy(
    pts: NDArray[np.float64],
    r: NDArray[np.float64],
    beams: NDArray[np.intp],
    jump_distance: float,
    min_points: int,
    n_invalid: int,
) -> Segments:
    """The numpy fallback of :func:`pfpeople.detect.segment_kernels.jump_segments`: the kept runs of the valid end
    points ``pts`` (V, 2) (m, walk order) with ranges ``r`` (V,) and beam indices ``beams`` (V,)."""
    gaps = np.hypot(*np.diff(pts, axis=0).T)
    breaks = np.flatnonzero(gaps > jump_distance) + 1
    starts = np.concatenate(([0], breaks))
    counts = np.diff(np.concatenate((starts, [beams.size])))
    keep = counts >= min_points
    n_small = int(np.count_nonzero(~keep))
    keep_pt = np.repeat(keep, counts)
    ends = starts + counts - 1
    r_pad = np.concatenate(([np.inf], r, [np.inf]))
    range_before = r_pad[starts][keep]
    range_after = r_pad[ends + 2][keep]
    counts = counts[keep]
    return Segments(
        points=pts[keep_pt],
        beams=beams[keep_pt].astype(np.intp),
        starts=(np.cumsum(counts) - counts).astype(np.intp),
        counts=counts.astype(np.intp),
        range_before=range_before,
        range_after=range_after,
        n_invalid=n_invalid,
        n_dropped_small=n_small,
    )


def _segment_sum(values: NDArray[np.float64], starts: NDArray[np.intp]) -> NDArray[np.float64]:
    return np.add.reduceat(values, starts, axis=0)


def segment_features(segments: Segments) -> NDArray[np.float64]:
    """Geometric features of every segment (see the module docstring for the definitions).

    Parameters
    ----------
    segments : Segments
        Output of :func:`segment_scan` (every segment has at least 3 points).

    Returns
    -------
    ndarray, shape (S, F)
        One row per segment, columns in the order of :data:`FEATURE_NAMES` (float64, SI units): the segment's
        own shape, then its context in the scan (:func:`context_features`).
    """
    if len(segments) == 0:
        return np.zeros((0, len(FEATURE_NAMES)))
    if np.any(segments.counts < 3):
        raise ValueError("segments must have at least 3 points each for segment_features")
    shape = _features_compiled(segments) if _jit.enabled("pfpeople") else _features_numpy(segments)
    width = shape[:, FEATURE_NAMES.index("width")]
    return np.hstack((shape, context_features(segments.centroids, width)))


def context_features(centroids: NDArray[np.float64], widths: NDArray[np.float64]) -> NDArray[np.float64]:
    """The context features of every segment of a scan (module docstring).

    Parameters
    ----------
    centroids : ndarray, shape (S, 2)
        The segments' centroids (m, scan frame).
    widths : ndarray, shape (S,)
        Their ``width`` (m).

    Returns
    -------
    ndarray, shape (S, 4)
        ``neighbour_distance``, ``second_neighbour_distance`` (m, at most ``CONTEXT_CAP``),
        ``neighbours_within_0_6m`` (a count) and ``neighbour_width`` (m) per segment.
    """
    n = centroids.shape[0]
    if n >= 2 and _jit.enabled("pfpeople"):
        c = np.ascontiguousarray(centroids, dtype=np.float64)
        w = np.ascontiguousarray(widths, dtype=np.float64)
        terms: NDArray[np.float64] = _kernels.context_terms(c, w, CONTEXT_CAP, _NEIGHBOUR_RADIUS)
        if terms.shape[0] == n:
            return terms
    out = np.zeros((n, _N_CONTEXT))
    out[:, :2] = CONTEXT_CAP
    if n < 2:
        return out
    d = np.hypot(centroids[:, None, 0] - centroids[None, :, 0], centroids[:, None, 1] - centroids[None, :, 1])
    np.fill_diagonal(d, np.inf)
    nearest = np.argmin(d, axis=1)
    rows = np.arange(n)
    out[:, 0] = np.minimum(d[rows, nearest], CONTEXT_CAP)
    if n > 2:
        out[:, 1] = np.minimum(np.partition(d, 1, axis=1)[:, 1], CONTEXT_CAP)
    out[:, 2] = np.count_nonzero(d <= _NEIGHBOUR_RADIUS, axis=1)
    out[:, 3] = widths[nearest]
    return out


def _features_compiled(segments: Segments) -> NDArray[np.float64]:
    """The per-segment columns of :func:`segment_features` (all but the context, ``(S, 14)``) by the compiled
    kernels (the angles by numpy between them)."""
    pts = np.ascontiguousarray(segments.points, dtype=np.float64)
    starts = segments.starts.astype(np.intp)
    counts = segments.counts.astype(np.intp)
    cross_t, dot_t, cross_i, dot_i = _kernels.features_angles(pts, starts, counts)
    th = np.mod(np.arctan2(cross_t, dot_t), 2 * np.pi)
    ang = np.mod(np.arctan2(cross_i, dot_i), 2 * np.pi)
    out: NDArray[np.float64] = _kernels.features_rest(pts, starts, counts, th, ang)
    return out


def _features_numpy(segments: Segments) -> NDArray[np.float64]:
    """The per-segment columns of :func:`segment_features` in numpy (the fallback without numba; the compiled
    kernels' reference)."""
    pts, starts, counts, sid = segments.points, segments.starts, segments.counts, segments.segment_ids
    n = counts.astype(float)
    first, last = pts[starts], pts[starts + counts - 1]
    c, d, sxx, syy, sxy, std, linearity = _spread(pts, starts, n, sid)
    avg_median_dev, distance = _median_features(pts, starts, counts, n, sid)
    width = np.hypot(*(last - first).T)
    radius, circularity = _circle_fit(pts, starts, n, sid, c, d, (sxx, syy, sxy), linearity)
    boundary_length, boundary_regularity = _boundary(pts, n, sid)
    mean_curvature, mean_angle_diff = _triples(pts, n, sid)
    iav, iav_std = _inscribed_angle(pts, starts, counts, n, sid, first, last)
    columns = (n, std, avg_median_dev, width, linearity, circularity, radius, boundary_length, boundary_regularity)
    return np.column_stack((*columns, mean_curvature, mean_angle_diff, iav, iav_std, distance))


_F = NDArray[np.float64]


def _spread(pts: _F, starts: NDArray[np.intp], n: _F, sid: NDArray[np.intp]) -> tuple[_F, _F, _F, _F, _F, _F, _F]:
    """Centroid ``c`` (S, 2), centred points ``d`` (N, 2), the scatter sums ``sxx, syy, sxy``, ``std`` and
    ``linearity`` (the smallest eigenvalue of the scatter matrix: squared residuals of the total-least-squares
    line)."""
    c = _segment_sum(pts, starts) / n[:, None]
    d = pts - c[sid]
    sxx = _segment_sum(d[:, 0] ** 2, starts)
    syy = _segment_sum(d[:, 1] ** 2, starts)
    sxy = _segment_sum(d[:, 0] * d[:, 1], starts)
    std = np.sqrt((sxx + syy) / (n - 1.0))
    half_tr = 0.5 * (sxx + syy)
    disc = np.sqrt(np.maximum(0.25 * (sxx - syy) ** 2 + sxy**2, 0.0))
    linearity = np.maximum(half_tr - disc, 0.0)
    return c, d, sxx, syy, sxy, std, linearity


def _median_features(
    pts: _F, starts: NDArray[np.intp], counts: NDArray[np.intp], n: _F, sid: NDArray[np.intp]
) -> tuple[_F, _F]:
    """``avg_median_dev`` and ``distance`` from the coordinate-wise median (points sorted by (segment,
    coordinate))."""
    med = np.empty((len(starts), 2))
    lo = starts + (counts - 1) // 2
    hi = starts + counts // 2
    for k in range(2):
        order = np.lexsort((pts[:, k], sid))
        srt = pts[order, k]
        med[:, k] = 0.5 * (srt[lo] + srt[hi])
    avg_median_dev = _segment_sum(np.hypot(*(pts - med[sid]).T), starts) / n
    return avg_median_dev, np.hypot(med[:, 0], med[:, 1])


def _circle_fit(
    pts: _F,
    starts: NDArray[np.intp],
    n: _F,
    sid: NDArray[np.intp],
    c: _F,
    d: _F,
    scatter: tuple[_F, _F, _F],
    linearity: _F,
) -> tuple[_F, _F]:
    """``radius`` (capped at :data:`RADIUS_CAP`) and ``circularity`` of the algebraic (Kasa) circle fit, which
    minimises ``sum (x^2 + y^2 + D x + E y + G)^2`` in centred coordinates; a degenerate fit gives the line's
    residuals."""
    suu, svv, suv = scatter
    z = d[:, 0] ** 2 + d[:, 1] ** 2
    suz = _segment_sum(d[:, 0] * z, starts)
    svz = _segment_sum(d[:, 1] * z, starts)
    det = suu * svv - suv**2
    scale = np.maximum(suu + svv, 1e-300)
    ok = det > 1e-12 * scale**2
    safe_det = np.where(ok, det, 1.0)
    # centre (a, b) in centred coordinates solves [[suu, suv], [suv, svv]] [a, b] = 0.5 [suz, svz]
    a_c = np.where(ok, 0.5 * (svv * suz - suv * svz) / safe_det, 0.0)
    b_c = np.where(ok, 0.5 * (suu * svz - suv * suz) / safe_det, 0.0)
    r2 = a_c**2 + b_c**2 + (suu + svv) / n
    radius = np.where(ok, np.sqrt(r2), np.inf)
    centre = c + np.column_stack((a_c, b_c))
    resid = np.where(ok[sid], radius[sid] - np.hypot(*(pts - centre[sid]).T), 0.0)
    circularity = np.where(ok, _segment_sum(resid**2, starts), linearity)
    return np.minimum(radius, RADIUS_CAP), circularity


def _boundary(pts: _F, n: _F, sid: NDArray[np.intp]) -> tuple[_F, _F]:
    """``boundary_length`` and ``boundary_regularity`` from the consecutive steps inside each segment."""
    S = len(n)
    step = np.hypot(*np.diff(pts, axis=0).T)  # (N-1,)
    same = sid[1:] == sid[:-1]
    step_in = np.where(same, step, 0.0)
    # np.bincount sums in input order as np.add.at does (same values), several times faster
    step_sum = np.bincount(sid[:-1][same], weights=step_in[same], minlength=S)
    step_sq = np.bincount(sid[:-1][same], weights=step_in[same] ** 2, minlength=S)
    n_steps = n - 1.0
    regularity = np.sqrt(np.maximum(step_sq - step_sum**2 / n_steps, 0.0) / np.maximum(n_steps - 1, 1))
    return step_sum.astype(np.float64, copy=False), regularity


def _triples(pts: _F, n: _F, sid: NDArray[np.intp]) -> tuple[_F, _F]:
    """``mean_curvature`` (signed Menger curvature) and ``mean_angle_diff`` (turning angle) over the
    consecutive triples (right, mid, left) inside each segment, divided by ``n``."""
    S = len(n)
    right, mid, left = pts[:-2], pts[1:-1], pts[2:]
    tri_ok = sid[:-2] == sid[2:]
    ml = left - mid
    mr = right - mid
    l_ml = np.hypot(*ml.T)
    l_mr = np.hypot(*mr.T)
    l_lr = np.hypot(*(left - right).T)
    cross = ml[:, 0] * mr[:, 1] - ml[:, 1] * mr[:, 0]
    dot = ml[:, 0] * mr[:, 0] + ml[:, 1] * mr[:, 1]
    th = np.mod(np.arctan2(cross, dot), 2 * np.pi)
    denom = l_ml * l_mr * l_lr
    curv = np.where(denom > 0, 2.0 * cross / np.where(denom > 0, denom, 1.0), 0.0)  # 4 A / (abc), signed
    tri_seg = sid[1:-1][tri_ok]
    mean_curvature = np.bincount(tri_seg, weights=curv[tri_ok], minlength=S) / n
    mean_angle_diff = np.bincount(tri_seg, weights=th[tri_ok], minlength=S) / n
    return mean_curvature, mean_angle_diff


def _inscribed_angle(
    pts: _F, starts: NDArray[np.intp], counts: NDArray[np.intp], n: _F, sid: NDArray[np.intp], first: _F, last: _F
) -> tuple[_F, _F]:
    """``iav`` and ``iav_std``: the inscribed angle at the interior points between each segment's first and
    last point (rad)."""
    S = len(n)
    interior = np.ones(pts.shape[0], dtype=bool)
    interior[starts] = False
    interior[starts + counts - 1] = False
    iseg = sid[interior]
    u = first[iseg] - pts[interior]
    v = last[iseg] - pts[interior]
    ang = np.mod(np.arctan2(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0], (u * v).sum(axis=1)), 2 * np.pi)
    s1 = np.bincount(iseg, weights=ang, minlength=S)
    n_int = n - 2.0
    iav = s1 / n_int
    s2 = np.bincount(iseg, weights=(ang - iav[iseg]) ** 2, minlength=S)
    return iav, np.sqrt(s2 / np.maximum(n_int - 1.0, 1.0))


#: The latest (scan, params, segments, features): two detectors on one scan (legs, boosted) share them.
_LATEST: tuple[LaserScan, SegmentationParams, Segments, NDArray[np.float64]] | None = None


def scan_segments(scan: LaserScan, *, params: SegmentationParams | None = None) -> tuple[Segments, NDArray[np.float64]]:
    """``segment_scan(scan, params)`` and its ``segment_features``, computed once per scan object and params.

    The latest result is kept (by the scan's identity, so a scan must not be changed after it was passed):
    the leg detector and the boosted detector of one laser segment the same scan with the same parameters.
    """
    global _LATEST
    p = params if params is not None else SegmentationParams()
    latest = _LATEST
    if latest is not None and latest[0] is scan and latest[1] == p:
        return latest[2], latest[3]
    segs = segment_scan(scan, params=p)
    feats = segment_features(segs)
    _LATEST = (scan, p, segs, feats)
    return segs, feats
