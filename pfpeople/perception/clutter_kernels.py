"""Compiled free-space tracing and evidence update of :class:`pfpeople.perception.clutter_map.StaticClutterMap`
(numba; see :mod:`gridbridge.jit`, scope ``"pfpeople"``).

:func:`update_evidence` does what the numpy code of ``StaticClutterMap.update`` does after the scan's cells are
known (the free cells along the traced rays, the people's cells, the protection of the cells beside a return,
the relaxation towards unknown, the hits and the free decrements), in one pass over the samples and one over the
map, with the same floating-point operations, so the two give the same evidence bit for bit.
"""

from __future__ import annotations

import math
from typing import TypeAlias

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge import geometry as _geometry
from gridbridge import jit as _jit
from gridbridge.jit import jit as njit
from gridbridge.kernels import pairwise_sum

_F: TypeAlias = NDArray[np.float64]

__all__ = [
    "arrived_flags",
    "ball_means",
    "moving_update",
    "near_any",
    "near_mask",
    "return_scores",
    "scan_rays",
    "self_update",
    "static_lookup",
    "update_evidence",
    "view_points",
    "warm_up",
]


@njit
def update_evidence(
    s: NDArray[np.float64],
    n: int,
    hit_cells: NDArray[np.intp],
    human_cells: NDArray[np.intp],
    ru: NDArray[np.float64],
    n_free: NDArray[np.intp],
    steps: NDArray[np.float64],
    origin: NDArray[np.float64],
    neighbours: NDArray[np.intp],
    params: NDArray[np.float64],
) -> None:  # pragma: no cover - compiled
    """Update the flat evidence ``s`` (n * n,) of one scan in place.

    Parameters
    ----------
    s : ndarray, shape (n * n,)
        Evidence (s) per cell, flat index ``i * n + j``.
    n : int
        Cells per side of the window.
    hit_cells, human_cells : ndarray of intp
        Flat cells of the returns inside the window away from people (hits) and near them (traced free).
    ru : ndarray, shape (R, 2)
        Unit direction of every traced ray in the map frame, divided by the resolution (cells per m).
    n_free : ndarray of intp, shape (R,)
        Samples traced along each ray (the first ``n_free[r]`` of ``steps``).
    steps : ndarray, shape (K,)
        Sample distances along a ray (m).
    origin : ndarray, shape (2,)
        The sensor's position in cells from the window's corner.
    neighbours : ndarray of intp
        Flat offsets of the cells protected beside a hit (the hit's own cell included).
    params : ndarray, shape (6,)
        ``(unknown_evidence, decay, dt, s_max, free decrement, s_min)``: ``s`` relaxes to
        ``(s - unknown) * decay + unknown``, hits gain ``dt`` up to ``s_max``, free cells lose the decrement down
        to ``s_min``.
    """
    free, hit = _marks(n, hit_cells, human_cells, ru, n_free, steps, origin, neighbours)
    s0, decay, dt, s_max, dec, s_min = params[0], params[1], params[2], params[3], params[4], params[5]
    for i in range(n * n):  # both branches computed and one selected (no jumps: the compiler vectorises it)
        v = (s[i] - s0) * decay + s0
        h = v + dt
        h = h if h <= s_max else s_max
        v = h if hit[i] else v
        f = v - dec
        f = f if f >= s_min else s_min
        s[i] = f if free[i] else v


@njit
def _marks(
    n: int,
    hit_cells: NDArray[np.intp],
    human_cells: NDArray[np.intp],
    ru: NDArray[np.float64],
    n_free: NDArray[np.intp],
    steps: NDArray[np.float64],
    origin: NDArray[np.float64],
    neighbours: NDArray[np.intp],
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:  # pragma: no cover - compiled
    """The free and the hit cells of one scan, flat (n * n,) each (the arguments are :func:`update_evidence`'s):
    free along the traced rays and at the people's returns, not beside a hit (``neighbours``)."""
    ncell = n * n
    free = np.zeros(ncell, dtype=np.bool_)
    for b in range(n_free.size):
        for k in range(n_free[b]):
            fi = math.floor(ru[b, 0] * steps[k] + origin[0])
            fj = math.floor(ru[b, 1] * steps[k] + origin[1])
            if fi >= 0 and fi < n and fj >= 0 and fj < n:
                free[fi * n + fj] = True
    for c in human_cells:
        free[c] = True
    hit = np.zeros(ncell, dtype=np.bool_)
    for c in hit_cells:
        hit[c] = True
        for off in neighbours:
            free[(c + off) % ncell] = False
    return free, hit


@njit
def ball_means(
    xy: NDArray[np.float64], score: NDArray[np.float64], pos: NDArray[np.float64], radius: float
) -> NDArray[np.float64]:  # pragma: no cover - compiled
    """Mean ``score`` of the points ``xy`` within ``radius`` of each position, as
    ``score[cKDTree(xy).query_ball_point(pos, radius)].mean()`` (0 where none).

    Parameters
    ----------
    xy : ndarray, shape (H, 2)
        Points (m).
    score : ndarray, shape (H,)
        Their scores.
    pos : ndarray, shape (M, 2)
        Query positions (m, the frame of ``xy``).
    radius : float
        Query radius (m): a point counts when ``dx * dx + dy * dy <= radius * radius`` (the k-d tree's test).

    Returns
    -------
    ndarray, shape (M,)
        The means: the points in index order (the tree's sorted answer) summed as numpy's mean does
        (:func:`gridbridge.kernels.pairwise_sum`), divided by their number.
    """
    r2 = radius * radius
    out = np.zeros(pos.shape[0])
    buf = np.empty(xy.shape[0])
    for m in range(pos.shape[0]):
        k = 0
        for i in range(xy.shape[0]):
            dx = xy[i, 0] - pos[m, 0]
            dy = xy[i, 1] - pos[m, 1]
            if dx * dx + dy * dy <= r2:
                buf[k] = score[i]
                k += 1
        if k:
            out[m] = pairwise_sum(buf, 0, k) / k
    return out


#: The tracks of :class:`pfpeople.perception.clutter_map.MovingPeople`: positions, anchors a and b (T, 2) (m),
#: anchor b's time (T,) (s), missed updates (T,), moving (T,), last time moved (T,) (s).
_Tracks: TypeAlias = tuple[_F, _F, _F, _F, NDArray[np.int64], NDArray[np.bool_], _F]


@njit
def moving_update(
    tracks: _Tracks, det: _F, now: float, gate: float, window: float, min_distance: float, hold: float, max_missed: int
) -> _Tracks:  # pragma: no cover - compiled
    """``MovingPeople.update``'s track update for the detections ``det`` (M, 2) (m, odometry frame) at time
    ``now`` (s), as its numpy code does it: the greedy association (closest pairs first, ``np.argsort`` stable
    order), the new tracks, the anchors every ``window / 2``, the moving flags, the dropped tracks. ``window``
    and ``hold`` are NaN for None. Returns the new tracks (the arrays given are not changed)."""
    pos, anc_a, anc_b, t_b, missed, moving, moved_t = tracks
    pos, missed = pos.copy(), missed + 1
    used = _associate(pos, missed, det, gate)
    n_old, m = pos.shape[0], det.shape[0] - int(used.sum())
    n = n_old + m
    p2, a2, b2 = np.empty((n, 2)), np.empty((n, 2)), np.empty((n, 2))
    tb2, mi2, mv2, mt2 = np.empty(n), np.empty(n, dtype=np.int64), np.empty(n, dtype=np.bool_), np.empty(n)
    p2[:n_old], a2[:n_old], b2[:n_old], tb2[:n_old] = pos, anc_a, anc_b, t_b
    mi2[:n_old], mv2[:n_old], mt2[:n_old] = missed, moving, moved_t
    q = n_old
    for k in range(det.shape[0]):
        if not used[k]:
            p2[q], a2[q], b2[q] = det[k], det[k], det[k]
            tb2[q], mi2[q], mv2[q], mt2[q] = now, 0, False, -np.inf
            q += 1
    half = 0.5 * window - 1e-9
    for t in range(n):
        if window == window and now - tb2[t] >= half:
            a2[t] = b2[t]
            b2[t], tb2[t] = p2[t], now
        if math.hypot(p2[t, 0] - a2[t, 0], p2[t, 1] - a2[t, 1]) >= min_distance:
            mt2[t] = now
            mv2[t] = True
        if hold == hold:
            mv2[t] = mv2[t] and now - mt2[t] <= hold + 1e-9
    alive = mi2 <= max_missed
    return p2[alive], a2[alive], b2[alive], tb2[alive], mi2[alive], mv2[alive], mt2[alive]


@njit
def _associate(pos: _F, missed: NDArray[np.int64], det: _F, gate: float) -> NDArray[np.bool_]:  # pragma: no cover
    """The association of :func:`moving_update`: tracks (T, 2) take the detections (M, 2) closest pair first
    within ``gate`` (m); changes ``pos`` and ``missed`` in place, returns which detections were used (M,)."""
    T, M = pos.shape[0], det.shape[0]
    used = np.zeros(M, dtype=np.bool_)
    if T == 0 or M == 0:
        return used
    d = np.empty(T * M)
    for t in range(T):
        for k in range(M):
            d[t * M + k] = math.hypot(pos[t, 0] - det[k, 0], pos[t, 1] - det[k, 1])
    for flat in np.argsort(d, kind="mergesort"):
        t, k = flat // M, flat % M
        if d[flat] > gate:
            break
        if used[k] or missed[t] == 0:
            continue
        used[k] = True
        pos[t, 0], pos[t, 1], missed[t] = det[k, 0], det[k, 1], 0
    return used


@njit
def self_update(
    p: _F,
    ref: _F,
    travel: _F,
    lim: tuple[float, float, float],
    has_ego: bool,
    ex: float,
    ey: float,
    c: float,
    s: float,
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:  # pragma: no cover - compiled
    """``SelfReturns.update``'s streaks, as its numpy code does them: ``p`` (N, 2) the scan's end points (m,
    laser frame; NaN rows), ``ref`` (N, 2) and ``travel`` (N,) each beam's streak (changed in place), ``lim`` =
    ``(max_range, tolerance, travel)`` (m); with ``has_ego`` the previous laser frame in the current one is
    ``(ex, ey)`` and rotation ``(c, s)`` (cos, sin of its yaw). Returns the self mask and the finite rows (N,)."""
    max_range, tol, need = lim
    n = p.shape[0]
    mask = np.zeros(n, dtype=np.bool_)
    finite = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        px, py = p[i, 0], p[i, 1]
        finite[i] = math.isfinite(px) and math.isfinite(py)
        valid = finite[i] and math.hypot(px, py) <= max_range
        same = valid and math.hypot(px - ref[i, 0], py - ref[i, 1]) <= tol
        if same:
            if has_ego:
                mx = ex + c * px - s * py
                my = ey + s * px + c * py
                travel[i] = travel[i] + math.hypot(mx - px, my - py)
        else:
            ref[i, 0], ref[i, 1] = (px, py) if valid else (math.nan, math.nan)
            travel[i] = 0.0
        mask[i] = same and travel[i] >= need
    return mask, finite


@njit
def static_lookup(
    pts: _F, ev: _F, n: int, pose: tuple[float, float, float, float], corner: tuple[float, float, float], lim: _F
) -> NDArray[np.bool_]:  # pragma: no cover - compiled
    """``StaticClutterMap.static_points`` of the points ``pts`` (N, 2) (m, sensor frame; rows with a NaN or an
    infinite coordinate are not static), as its numpy code does it: moved into the map frame by ``pose`` =
    ``(x, y, cos yaw, sin yaw)``, the cell of each from ``corner`` = ``(x0, y0, 1 / resolution)`` in the flat
    evidence ``ev`` (n * n,) (s), static when inside the window and ``ev / lim[0] >= lim[1]`` (``static_time``
    (s), ``static_threshold - 1e-9``). Returns (N,)."""
    x, y, c, s = pose
    x0, y0, inv = corner
    out = np.zeros(pts.shape[0], dtype=np.bool_)
    for k in range(pts.shape[0]):
        px, py = pts[k, 0], pts[k, 1]
        if not (math.isfinite(px) and math.isfinite(py)):
            continue
        i = math.floor(((x + c * px - s * py) - x0) * inv)
        j = math.floor(((y + s * px + c * py) - y0) * inv)
        if i >= 0 and i < n and j >= 0 and j < n:
            out[k] = ev[i * n + j] / lim[0] >= lim[1]
    return out


@njit
def _ray(
    vx: float,
    vy: float,
    length: float,
    k: int,
    rot: tuple[float, float, float],
    steps: _F,
    ru: _F,
    n_free: NDArray[np.intp],
) -> None:  # pragma: no cover - compiled
    """Ray ``k`` of :func:`scan_rays` through ``(vx, vy)`` traced ``length`` m: its direction rotated into the map
    frame in cells per m (``rot = (cos yaw, sin yaw, 1 / resolution)``) and its samples (``np.searchsorted``)."""
    c, sn, inv = rot
    r = math.hypot(vx, vy)
    r = r if r >= 1e-9 else 1e-9  # np.maximum(r, 1e-9)
    ux, uy = vx / r, vy / r
    ru[k, 0], ru[k, 1] = (c * ux - sn * uy) * inv, (sn * ux + c * uy) * inv
    n_free[k] = np.searchsorted(steps, length)


@njit
def _split_far(pts: _F, no_return: _F, max_range: float) -> tuple[_F, _F, _F]:  # pragma: no cover - compiled
    """:func:`scan_rays`' returns within ``max_range`` (M, 2) with their ranges (M,), and the rays traced free
    all along (the no-return beams, then the returns beyond ``max_range`` cut there)."""
    r = np.empty(pts.shape[0])
    far = np.empty(pts.shape[0], dtype=np.bool_)
    for k in range(pts.shape[0]):
        r[k] = math.hypot(pts[k, 0], pts[k, 1])
        far[k] = r[k] > max_range
    n_far = int(far.sum())
    m = pts.shape[0] - n_far
    keep, rk = np.empty((m, 2)), np.empty(m)
    free_rays = np.empty((no_return.shape[0] + n_far, 2))
    free_rays[: no_return.shape[0]] = no_return
    a, b = 0, no_return.shape[0]
    for k in range(pts.shape[0]):
        if far[k]:
            f = max_range / r[k]
            free_rays[b, 0], free_rays[b, 1] = pts[k, 0] * f, pts[k, 1] * f
            b += 1
        else:
            keep[a, 0], keep[a, 1], rk[a] = pts[k, 0], pts[k, 1], r[k]
            a += 1
    return keep, rk, free_rays


@njit
def scan_rays(
    pts: _F, people: _F, no_return: _F, pose: tuple[float, float, float, float], geo: _F, steps: _F, n: int
) -> tuple[_F, NDArray[np.bool_], NDArray[np.intp], NDArray[np.bool_], _F, NDArray[np.intp]]:  # pragma: no cover
    """``StaticClutterMap.update``'s geometry of one scan in one pass, as its numpy code computes it
    (``_rays``, ``cell_of`` of the returns moved into the map frame, ``_ray_dirs``).

    ``pts`` are the finite returns (N, 2), ``people`` the excluded positions (K, 2), ``no_return`` the no-return
    beams' end points (F, 2) (m, sensor frame); ``pose = (x, y, cos yaw, sin yaw)`` the sensor in the map frame;
    ``geo = (max_range, exclude_radius, free_stride, free_margin, x0, y0, 1 / resolution)`` with the window's
    corner ``(x0, y0)``; ``steps`` the sample distances; ``n`` the window's cells per side.

    Returns the returns within ``max_range`` (M, 2), which of them lie near a person, their flat cells (0
    outside) and whether inside the window, and the rays' directions (R, 2) and samples (R,): every
    ``free_stride``-th return up to ``free_margin`` before it, then every ``free_stride``-th of the no-return
    beams followed by the returns beyond ``max_range`` (cut there).
    """
    max_range, radius, stride_f, margin, x0, y0, inv = geo[0], geo[1], geo[2], geo[3], geo[4], geo[5], geo[6]
    stride = int(stride_f)
    x, y, c, sn = pose
    keep, rk, free_rays = _split_far(pts, no_return, max_range)
    m = keep.shape[0]
    human = np.zeros(m, dtype=np.bool_)
    cells = np.zeros(m, dtype=np.intp)
    inside = np.zeros(m, dtype=np.bool_)
    r2 = radius * radius
    for k in range(m):
        px, py = keep[k, 0], keep[k, 1]
        if people.shape[0]:
            best = np.inf
            for q in range(people.shape[0]):
                dx, dy = px - people[q, 0], py - people[q, 1]
                best = min(best, dx * dx + dy * dy)
            human[k] = best <= r2
        i = math.floor(((x + c * px - sn * py) - x0) * inv)
        j = math.floor(((y + sn * px + c * py) - y0) * inv)
        if i >= 0 and i < n and j >= 0 and j < n:
            cells[k], inside[k] = i * n + j, True
    n_ret, n_fr = (m + stride - 1) // stride, (free_rays.shape[0] + stride - 1) // stride
    ru, n_free = np.empty((n_ret + n_fr, 2)), np.empty(n_ret + n_fr, dtype=np.intp)
    rot = (c, sn, inv)
    for t in range(n_ret):
        _ray(keep[t * stride, 0], keep[t * stride, 1], rk[t * stride] - margin, t, rot, steps, ru, n_free)
    for t in range(n_fr):
        fx, fy = free_rays[t * stride, 0], free_rays[t * stride, 1]
        _ray(fx, fy, min(math.hypot(fx, fy), max_range), n_ret + t, rot, steps, ru, n_free)
    return keep, human, cells, inside, ru, n_free


@njit
def return_scores(
    ev: _F, hit_cells: NDArray[np.intp], offsets: NDArray[np.intp], static_time: float
) -> _F:  # pragma: no cover - compiled
    """``StaticClutterMap._return_scores``, exactly: per return, the largest evidence of its cell and of the cells
    ``offsets`` (flat, wrapped) from it (``np.maximum`` in the offsets' order: maxima do not round), over
    ``static_time``, clipped to [0, 1]."""
    ncell = ev.size
    out = np.empty(hit_cells.size)
    for k in range(hit_cells.size):
        c = hit_cells[k]
        best = ev[c]
        for off in offsets:
            v = ev[(c + off) % ncell]
            best = v if v > best or math.isnan(v) else best
        t = best / static_time
        if not math.isnan(t):  # np.clip: (t > 0 ? t : 0), then (t < 1 ? t : 1); NaN stays
            t = t if t > 0.0 else 0.0
            t = t if t < 1.0 else 1.0
        out[k] = t
    return out


@njit
def near_mask(
    points: NDArray[np.float64], others: NDArray[np.float64], r2: float
) -> NDArray[np.bool_]:  # pragma: no cover - compiled
    """:func:`gridbridge.geometry.near_any` of ``points`` ``(N, 2)`` and ``K >= 1`` ``others`` ``(K, 2)`` (m) with
    ``r2 = radius * radius`` (m^2): whether the smallest ``dx * dx + dy * dy`` of a point is ``<= r2``; a NaN
    among its squares makes numpy's minimum NaN, so False.

    Returns
    -------
    ndarray, shape (N,), bool
    """
    out = np.zeros(points.shape[0], dtype=np.bool_)
    for i in range(points.shape[0]):
        m = math.inf
        for j in range(others.shape[0]):
            dx = points[i, 0] - others[j, 0]
            dy = points[i, 1] - others[j, 1]
            v = dx * dx + dy * dy
            if v != v:
                m = v
                break
            if v < m:
                m = v
        out[i] = m <= r2
    return out


def near_any(points: ArrayLike, others: ArrayLike, radius: float) -> NDArray[np.bool_]:
    """:func:`gridbridge.geometry.near_any` (``(N,)``: whether each of ``points`` ``(N, 2)`` lies within ``radius``
    (m, inclusive) of a row of ``others`` ``(K, 2)``), by :func:`near_mask` when
    ``gridbridge.jit.enabled("pfpeople")``: the same answers."""
    if not _jit.enabled("pfpeople"):
        return _geometry.near_any(points, others, radius)
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    o = np.asarray(others, dtype=float).reshape(-1, 2)
    if not p.shape[0] or not o.shape[0]:
        return np.zeros(p.shape[0], dtype=bool)
    out: NDArray[np.bool_] = near_mask(np.ascontiguousarray(p), np.ascontiguousarray(o), float(radius * radius))
    return out


def warm_up() -> None:
    """Load (or compile) the kernels of this module now, so the first scan of a run does not wait for them
    (nothing happens when ``gridbridge.jit.enabled("pfpeople")`` is False)."""
    if not _jit.enabled("pfpeople"):
        return
    no = np.zeros(0, dtype=np.intp)
    params = np.array([1.0, 1.0, 0.1, 20.0, 0.05, -1.0])
    ev = np.zeros(4)
    pts, cells, frozen = np.zeros((1, 2)), np.zeros(1, dtype=np.intp), np.zeros(0, dtype=np.intp)
    for writeable in (True, False):  # the run passes some arrays read-only (cached): numba compiles each flag apart
        pts.flags.writeable = cells.flags.writeable = frozen.flags.writeable = writeable
        update_evidence(
            ev, 2, no, no, np.zeros((1, 2)), np.ones(1, dtype=np.intp), np.ones(1), np.zeros(2), frozen, params
        )
        near_mask(pts, pts, 0.01)
        return_scores(ev, np.zeros(1, dtype=np.intp), cells, 1.0)
    ball_means(np.zeros((1, 2)), np.ones(1), np.zeros((1, 2)), 0.1)
    one = np.ones((1, 2))
    geo = np.array([10.0, 0.3, 1.0, 0.1, -1.0, -1.0, 1.0])
    scan_rays(one, np.zeros((0, 2)), np.zeros((0, 2)), (0.0, 0.0, 1.0, 0.0), geo, np.ones(3), 2)
    scan_rays(one, one, one, (0.0, 0.0, 1.0, 0.0), geo, np.ones(3), 2)
    e = np.zeros((0, 2))
    static_lookup(np.zeros((1, 2)), np.zeros(4), 2, (0.0, 0.0, 1.0, 0.0), (-1.0, -1.0, 1.0), np.ones(2))
    pts, ref = np.zeros((2, 2)), np.full((2, 2), np.nan)
    self_update(pts, ref, np.zeros(2), (1.0, 0.05, 0.5), True, 0.0, 0.0, 1.0, 0.0)
    tracks = (e, e, e, np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.bool_), np.zeros(0))
    owner, _ = view_points(np.zeros((1, 2)), np.zeros((2, 2)), 0.1, np.array([[0.0, 0.0, 1.0, 0.0]]))
    far, geo = np.full(3, np.inf), np.array([[-1.0, 1.0, 9.0]])
    arrived_flags(np.ones(2), np.zeros(2), owner, 1, far, np.array([0, 3]), geo, (1, 0.3, 0.5))
    moving_update(
        moving_update(tracks, np.zeros((1, 2)), 0.1, 0.3, 2.0, 0.3, 5.0, 8), np.ones((1, 2)), 0.2, 0.3, 2.0, 0.3, 5.0, 8
    )


@njit
def view_points(
    det: NDArray[np.float64], pts: NDArray[np.float64], r2: float, poses: NDArray[np.float64]
) -> tuple[NDArray[np.intp], NDArray[np.float64]]:  # pragma: no cover - compiled
    """The (detection, point) pairs within ``sqrt(r2)`` m of detections ``det`` (M, 2) and points ``pts`` (N, 2)
    (m; ``dx * dx + dy * dy <= r2`` with ``dx = pts_x - det_x``, NaN rows near nothing; detection-major, as
    ``np.nonzero`` of the (M, N) test lists them), and their points moved by each of ``poses`` (V, 4), rows
    ``(x, y, cos yaw, sin yaw)``, as :func:`gridbridge.geometry.from_frame` does it.

    Returns
    -------
    owner : ndarray of intp, shape (P,)
        The detection of each pair.
    local : ndarray, shape (V * P, 2)
        The pairs' points in each pose's frame, pose-major.
    """
    near = np.zeros((det.shape[0], pts.shape[0]), dtype=np.bool_)
    total = 0
    for m in range(det.shape[0]):
        for n in range(pts.shape[0]):
            dx = pts[n, 0] - det[m, 0]
            dy = pts[n, 1] - det[m, 1]
            if dx * dx + dy * dy <= r2:
                near[m, n] = True
                total += 1
    owner = np.empty(total, dtype=np.intp)
    local = np.empty((poses.shape[0] * total, 2))
    k = 0
    for m in range(det.shape[0]):
        for n in range(pts.shape[0]):
            if near[m, n]:
                owner[k] = m
                px, py = pts[n, 0], pts[n, 1]
                for v in range(poses.shape[0]):
                    x, y, c, s = poses[v, 0], poses[v, 1], poses[v, 2], poses[v, 3]
                    local[v * total + k, 0] = x + c * px - s * py
                    local[v * total + k, 1] = y + s * px + c * py
                k += 1
    return owner, local


@njit
def _remainder(a: float, b: float) -> float:  # pragma: no cover - compiled
    """numpy's float ``a % b`` (``npy_divmod``: ``fmod`` with the divisor's sign)."""
    mod = np.fmod(a, b)
    if mod != 0.0:
        if (b < 0.0) != (mod < 0.0):
            mod += b
    else:
        mod = math.copysign(0.0, b)
    return mod


@njit
def _seen_point(
    r: float,
    bearing: float,
    far: NDArray[np.float64],
    lo: int,
    n: int,
    a0: float,
    inc: float,
    rmax: float,
    side: int,
    margin: float,
    two_pi: float,
) -> bool:  # pragma: no cover - compiled
    """Whether the view whose ``n`` beams are ``far[lo:lo + n]`` saw through the point at range ``r`` and
    ``bearing`` (``_Beams.seen_through`` for one point)."""
    rel = _remainder(bearing - a0, two_pi) if inc > 0 else -_remainder(a0 - bearing, two_pi)
    k = np.int64(np.rint(rel / inc))
    if k < side or k >= n - side or not r <= rmax:
        return False
    ok = True
    for d in range(-side, side + 1):
        if not far[lo + k + d] >= r + margin:
            ok = False
    return ok


@njit
def arrived_flags(
    r: NDArray[np.float64],
    bearing: NDArray[np.float64],
    owner: NDArray[np.intp],
    m: int,
    far: NDArray[np.float64],
    starts: NDArray[np.intp],
    geo: NDArray[np.float64],
    rule: tuple[int, float, float],
) -> NDArray[np.bool_]:  # pragma: no cover - compiled
    """Which of M detections one view saw through at least a fraction of the points of
    (``pfpeople.perception.arrivals.RecentScans.arrived``; per point ``_Beams.seen_through``, its operations in
    its order).

    Parameters
    ----------
    r, bearing : ndarray, shape (V * P,)
        Range (m) and bearing (rad) of the P points in each view's scan frame, view-major.
    owner : ndarray of intp, shape (P,)
        The detection each point belongs to (0 to M - 1).
    m : int
        The number of detections M.
    far : ndarray, shape (sum of the views' beams,)
        The views' beam ranges beyond which they saw nothing, concatenated; view v's are
        ``far[starts[v]:starts[v + 1]]``.
    starts : ndarray of intp, shape (V + 1,)
    geo : ndarray, shape (V, 3)
        Per view ``(angle_min, increment, range_max)``.
    rule : tuple
        ``(SIDE_BEAMS, MARGIN_M, FRACTION)`` of :mod:`pfpeople.perception.arrivals`.

    Returns
    -------
    ndarray of bool, shape (M,)
    """
    side, margin, fraction = rule
    views, p = geo.shape[0], owner.shape[0]
    count = np.zeros(m)
    for i in range(p):
        count[owner[i]] += 1.0
    out = np.zeros(m, dtype=np.bool_)
    seen = np.zeros(m)
    two_pi = 2.0 * np.pi
    for v in range(views):
        lo, n = starts[v], starts[v + 1] - starts[v]
        a0, inc, rmax = geo[v, 0], geo[v, 1], geo[v, 2]
        seen[:] = 0.0
        for i in range(p if n > 0 and inc != 0.0 else 0):
            q = v * p + i
            if _seen_point(r[q], bearing[q], far, lo, n, a0, inc, rmax, side, margin, two_pi):
                seen[owner[i]] += 1.0
        for j in range(m):
            need = fraction * count[j]
            out[j] = out[j] or (seen[j] >= need and need > 0)
    return out
