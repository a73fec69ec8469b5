"""Static-clutter suppression: a local occupancy map of non-person laser returns (after leg_tracker).

Furniture legs look like human legs to a laser, and the paper's filter accumulates what is seen every frame,
so chair and table legs become confident "people". leg_tracker (Leigh et al., ICRA 2015) keeps a local
occupancy grid of the laser returns that are *not* associated with tracked people and does not confirm a
person on cells that were already occupied. :class:`StaticClutterMap` is that map, with the occupancy
measured as **time**: how long (seconds of evidence) a place has been seen occupied.

Frames
------
The map lives in an odometry-like frame ``M`` (x, y in m, REP-103): the first sensor frame, moved by the
ego-motion passed to :meth:`StaticClutterMap.update` (``T_MS <- T_MS * ego``, ``ego`` = the current sensor
frame in the previous one, e.g. :class:`pfpeople.perception.scan_matching.ScanOdometry`). Its cells are axis-aligned in
``M`` (resolution ``r``); the window of ``(2 h / r)^2`` cells (``h`` = ``half_extent``) is re-centred on the sensor
by a whole number of cells when the sensor is more than ``recentre_distance`` from its centre, so the stored
values are never interpolated (no blur, no sub-cell drift). Points and queries are in the **current sensor
frame** (the frame of the points of the latest update).

Update (per scan, ``dt`` seconds since the previous one, clipped to ``max_dt``)
-----------------------------------------------------------------------------
Every cell holds ``s`` (s), a bounded log-odds of occupancy in units of "seconds of evidence". First every
cell relaxes towards the unknown value ``s0`` (``unknown_evidence``):
``s <- s0 + (s - s0) exp(-dt / forget_time)`` (what is no longer observed fades). Then:

* **hit** (a scan end point falls in the cell and is not near an excluded person): ``s <- min(s + dt, s_max)``;
* **free** (every ``free_stride``-th beam is traced, in steps of one cell, up to ``free_margin`` before its end
  point, or up to ``max_range`` when it returned nothing within range or beyond ``max_range``; or an end point
  near an excluded person falls in the cell, as leg_tracker marks human returns as free):
  ``s <- max(s - free_rate dt, s_min)``, except in cells within ``protect_cells`` of a hit cell of the same scan
  (beams passing beside a thin post, or a post misregistered by a cell, do not erase it).

With a per-scan log-odds increment proportional to ``dt``, the evidence is a rate, so the same time constants
hold at 7.5 Hz and 40 Hz. Cells start (and cells entering the window are set) at ``s0``. ``s0 > 0`` is a
prior for places never seen: something first seen where nothing was ever seen free (a chair coming into view
as the robot turns) needs only ``static_threshold * static_time - s0`` seconds to count as static, while a
person walking into space that was seen free has to make up the free evidence too (down to ``s_min``).
Free evidence weighs less than hits (``free_rate < 1``): with a few centimetres of odometry error a static
post is often carved free by beams passing its cell, and a walking person's cells are hit only briefly. A
person standing still is kept out of the map by passing them in ``exclude``.

When the ego-motion of a scan is unknown (the scan matcher failed and there is no wheel odometry), call
:meth:`StaticClutterMap.forget` before the update: a map that moved with the robot would call anything
that keeps its place relative to the robot static (a followed person).

Query
-----
``static_score(p)`` for positions ``p`` (M, 2) in the current sensor frame: the cells within ``query_radius``
of ``p`` that were hit by the latest scan (the returns a detection there is made of) are looked up, and the
score is ``mean(clip(s_max3 / static_time, 0, 1))`` over them, with ``s_max3`` the largest ``s`` within
``query_cells`` cells of the return's cell (tolerance to a cell of odometry error); 0 when there are no such
returns and within ``exclude_radius`` of the latest ``exclude`` positions (a confirmed person is never
static, whatever the place held before). ``is_static`` is ``score >= static_threshold``. Taking the
returns of the current scan (not every cell near ``p``) keeps a person next to a wall from inheriting the
wall's score through empty cells; the mean (not the maximum) keeps one static return (a wall point at the
edge of the radius) from vetoing a person.

Use
---
:class:`ClutterSuppressor` runs the whole recipe per scan (scan odometry or a given ego, forgetting on an
unknown ego, exclusion of :class:`MovingPeople` tracks, the static test of every detection).

How the defaults were chosen: ``docs/ablations.md``, "The static-clutter map's defaults".
"""

from __future__ import annotations

import copy
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from gridbridge import jit as _jit
from gridbridge.geometry import Pose2D, rotate
from gridbridge.validation import check_int, check_real, finite_rows
from pfpeople.perception.clutter_kernels import (
    ball_means,
    moving_update,
    near_any,
    return_scores,
    scan_rays,
    static_lookup,
    update_evidence,
)
from pfpeople.perception.scan_matching import LaserEgoMotion, ScanOdometry
from pfpeople.perception.self_returns import SelfReturns
from pfpeople.units import Beams, Cells, Metres, Ratio, Seconds

__all__ = [
    "FIRST_DT_S",
    "ClutterConfig",
    "ClutterSuppressor",
    "MovingPeople",
    "StaticClutterMap",
    "SuppressionStep",
]


def _check_number(value: object, name: str, *, allow_zero: bool = False) -> float:
    """A finite number > 0 (>= 0 with ``allow_zero``): :func:`gridbridge.validation.check_real`."""
    return check_real(value, name, low=0.0, low_open=not allow_zero)


def _positions(values: ArrayLike, name: str, *, drop_nonfinite: bool = False) -> NDArray[np.float64]:
    arr = np.asarray(values, dtype=float)
    if arr.size == 0:
        return np.zeros((0, 2))
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"{name} must have shape (N, 2) of (x, y) positions in metres, got {arr.shape}")
    if drop_nonfinite:
        return arr[finite_rows(arr)]
    if not np.isfinite(arr).all():  # one reduction: every row finite is every value finite
        raise ValueError(f"{name} contains NaN or infinite positions")
    return arr


#: The time step (s) the first scan of a map counts (no earlier stamp): its evidence. Not a setting: at 0.05 or
#: 0.1 s every output of ``pfpeople run`` was byte for byte the same on the four simulated scenes and on
#: person_following_outdoor_1 and negative_2 (issue 44).
FIRST_DT_S = 0.1


@dataclass(frozen=True, kw_only=True)
class ClutterConfig:
    """Parameters of :class:`StaticClutterMap` (lengths in m, times in s).

    Parameters
    ----------
    resolution : float
        Cell size (m).
    half_extent : float
        Half the side of the square map window (m); cells farther than this from the window centre are
        forgotten.
    max_range : float
        End points farther than this from the sensor are ignored, and free space is traced up to it.
    recentre_distance : float
        The window is re-centred on the sensor (by whole cells) when the sensor is farther than this from
        the window centre.
    static_time : float
        Seconds of (net) occupancy after which a cell counts as static (score 1).
    free_rate : float
        A second of free observations removes ``free_rate`` seconds of occupancy evidence.
    s_min, s_max : float
        Bounds of the evidence (s): ``s_min <= 0`` (how much free evidence a cell can store, negative),
        ``s_max >= static_time`` (how long a static cell stays static once unobserved or seen free).
    forget_time : float
        Time constant (s) with which cells return to unknown (``unknown_evidence``).
    free_margin : float
        Free space is traced up to this distance before each end point (m).
    free_stride : int
        Free space is traced along every ``free_stride``-th beam (the cells are larger than the beam gap
        within a few metres).
    protect_cells : int
        Cells within this many cells (Chebyshev) of a hit cell of the same scan are not marked free.
    unknown_evidence : float
        ``s0``: the evidence (s) of a never-observed cell, and the value cells relax to.
    query_cells : int
        A return's evidence is the largest within this many cells of its cell.
    exclude_radius : float
        Scan points within this distance of an excluded (person) position are not added (marked free).
    query_radius : float
        Radius (m) around a queried position within which the current returns are looked up.
    static_threshold : float
        ``is_static`` is ``static_score >= static_threshold`` (in (0, 1]).
    max_dt : float
        The largest time step applied at once (a gap in the data is not evidence). The first scan, or one given
        neither ``dt`` nor ``stamp_ns``, counts :data:`FIRST_DT_S`.
    self_range : float
        :class:`ClutterSuppressor`: returns within this distance of the laser (m) that keep their place in the
        laser frame while the robot moves are the robot's own body
        (:class:`pfpeople.perception.self_returns.SelfReturns`),
        and detections on them are suppressed like static ones; 0 turns this off.
    self_travel : float
        The distance (m) a world-fixed point would have moved in the laser frame while such a return kept its
        place, after which it is the robot's.
    """

    resolution: Metres = 0.1
    half_extent: Metres = 12.0
    max_range: Metres = 10.0
    recentre_distance: Metres = 1.0
    static_time: Seconds = 2.0
    free_rate: Ratio = 0.5
    s_min: Seconds = -1.0
    s_max: Seconds = 20.0
    forget_time: Seconds = 60.0
    free_margin: Metres = 0.25
    exclude_radius: Metres = 0.4
    query_radius: Metres = 0.35
    static_threshold: Ratio = 0.8
    max_dt: Seconds = 0.5
    protect_cells: Cells = 1
    free_stride: Beams = 4
    unknown_evidence: Seconds = 1.0
    query_cells: Cells = 1
    self_range: Metres = 1.0
    self_travel: Metres = 0.5

    def __post_init__(self) -> None:
        for name in (
            "resolution",
            "half_extent",
            "max_range",
            "static_time",
            "s_max",
            "forget_time",
            "query_radius",
            "static_threshold",
            "max_dt",
            "self_travel",
        ):
            # stored as floats: an integer from a TOML file (``unknown_evidence = 0``) would make an integer map
            object.__setattr__(self, name, _check_number(getattr(self, name), f"ClutterConfig.{name}"))
        for name in (
            "recentre_distance",
            "free_margin",
            "exclude_radius",
            "free_rate",
            "unknown_evidence",
            "self_range",
        ):
            object.__setattr__(self, name, _check_number(getattr(self, name), f"ClutterConfig.{name}", allow_zero=True))
        for name, low in (("free_stride", 1), ("protect_cells", 0), ("query_cells", 0)):
            check_int(getattr(self, name), f"ClutterConfig.{name}", minimum=low, maximum=5)
        if self.unknown_evidence > self.s_max:
            raise ValueError("ClutterConfig.unknown_evidence must be <= s_max")
        object.__setattr__(self, "s_min", check_real(self.s_min, "ClutterConfig.s_min", high=0.0))
        if self.s_max < self.static_time:
            raise ValueError("ClutterConfig.s_max must be >= static_time")
        if self.static_threshold > 1.0:
            raise ValueError(f"ClutterConfig.static_threshold must be in (0, 1], got {self.static_threshold!r}")
        if self.half_extent < self.max_range + self.recentre_distance:
            raise ValueError("ClutterConfig.half_extent must be >= max_range + recentre_distance")
        if self.half_extent / self.resolution > 2000:
            raise ValueError("ClutterConfig.half_extent / resolution must be <= 2000 (map too large)")


class StaticClutterMap:
    """Local map of how long each place has been occupied by non-person laser returns.

    See the module docstring for the maths and frames. Typical use, once per scan ``k`` (all in the laser's
    frame)::

        points = scan.points()                     # all beams; NaN rows (invalid) are ignored
        step = odometry.update(points)             # ScanOdometry, or the ego from wheel odometry / TF
        if k > 0 and not step.ok:
            clutter.forget()                       # ego unknown
        ex = step.ego.inverse().apply(moving_prev)  # last scan's moving people, moved into this frame
        clutter.update(points, ego=step.ego, exclude=ex, stamp_ns=scan.stamp_ns)
        keep = ~clutter.is_static(detections)      # detections in the same sensor frame
        moving_prev = moving.update(all_detections, ego=step.ego)  # MovingPeople

    Parameters
    ----------
    config : ClutterConfig, optional
    """

    def __init__(self, config: ClutterConfig | None = None) -> None:
        if config is not None and not isinstance(config, ClutterConfig):
            raise TypeError(f"config must be a ClutterConfig, got {type(config).__name__}")
        self.config = config or ClutterConfig()
        c = self.config
        self.n = math.ceil(2.0 * c.half_extent / c.resolution)
        self.reset()
        # free-space sample offsets along a beam (m), spaced below one cell
        step = c.resolution
        self._steps = np.arange(0.5 * step, c.max_range, step)
        p = c.protect_cells
        self._neighbours = [di * self.n + dj for di in range(-p, p + 1) for dj in range(-p, p + 1)]
        q = c.query_cells
        self._query_neighbours = [di * self.n + dj for di in range(-q, q + 1) for dj in range(-q, q + 1)]
        # the same offsets as arrays for the compiled kernels (made once, read only)
        self._neighbour_array = np.asarray(self._neighbours, dtype=np.intp)
        self._query_array = np.asarray(self._query_neighbours, dtype=np.intp)
        self._neighbour_array.flags.writeable = self._query_array.flags.writeable = False

    def reset(self) -> None:
        """Forget everything (the next update starts a new map at the sensor)."""
        self.evidence = np.full((self.n, self.n), self.config.unknown_evidence)
        """Occupancy evidence ``s`` (s) per cell, shape (n, n), index [i, j] along the map frame's x, y."""
        self.pose = Pose2D()
        """The current sensor frame in the map frame."""
        self.centre = np.zeros(2)
        """The map frame position (m) of the window centre."""
        self._last_stamp: int | None = None
        self.last_dt = FIRST_DT_S
        """Seconds of the latest update (after clipping to ``max_dt``)."""
        self._hit_cells = np.zeros(0, dtype=np.intp)
        self._hit_xy = np.zeros((0, 2))
        self._hit_tree: cKDTree | None = None
        self._scores: NDArray[np.float64] | None = None
        self._people = np.zeros((0, 2))
        self.updates = 0

    def forget(self) -> None:
        """Set every cell back to unknown, keeping the pose and the window.

        For a scan whose ego-motion is unknown (the scan matcher failed and no odometry is available): the
        stored evidence no longer lines up with the world, and a static map that drifted with the robot would
        call a person walking beside it static.
        """
        self.evidence.fill(self.config.unknown_evidence)
        self._scores = None

    # --- geometry ---------------------------------------------------------------------------------------------
    @property
    def origin(self) -> NDArray[np.float64]:
        """Map frame position (m) of the corner of cell [0, 0]."""
        return self.centre - 0.5 * self.n * self.config.resolution

    def cell_of(self, xy_map: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
        """Flat cell index of map-frame points ``(N, 2)`` and whether they are inside the window."""
        o = self.origin
        inv = 1.0 / self.config.resolution
        i = np.floor((xy_map[:, 0] - o[0]) * inv).astype(np.intp)
        j = np.floor((xy_map[:, 1] - o[1]) * inv).astype(np.intp)
        inside = (i >= 0) & (i < self.n) & (j >= 0) & (j < self.n)
        flat = i * self.n + j
        flat[~inside] = 0
        return flat, inside

    def _recentre(self) -> None:
        c = self.config
        d = np.array([self.pose.x, self.pose.y]) - self.centre
        if math.hypot(*d) <= c.recentre_distance:
            return
        shift = np.round(d / c.resolution).astype(int)
        new = np.full_like(self.evidence, c.unknown_evidence)
        sx, sy = int(shift[0]), int(shift[1])
        n = self.n
        if abs(sx) < n and abs(sy) < n:
            src_x = slice(max(sx, 0), n + min(sx, 0))
            dst_x = slice(max(-sx, 0), n + min(-sx, 0))
            src_y = slice(max(sy, 0), n + min(sy, 0))
            dst_y = slice(max(-sy, 0), n + min(-sy, 0))
            new[dst_x, dst_y] = self.evidence[src_x, src_y]
        self.evidence = new
        self.centre = self.centre + shift * c.resolution

    # --- update -----------------------------------------------------------------------------------------------
    def _dt(self, dt: float | None, stamp_ns: int | None) -> float:
        c = self.config
        if dt is not None:
            value = _check_number(dt, "dt", allow_zero=True)
        elif stamp_ns is not None and self._last_stamp is not None:
            value = max(0.0, (int(stamp_ns) - self._last_stamp) * 1e-9)
        else:
            value = FIRST_DT_S
        if stamp_ns is not None:
            self._last_stamp = int(stamp_ns)
        return min(value, c.max_dt)

    def update(
        self,
        points: ArrayLike,
        *,
        ego: Pose2D | None = None,
        exclude: ArrayLike | None = None,
        dt: float | None = None,
        stamp_ns: int | None = None,
        free: ArrayLike | None = None,
    ) -> None:
        """Add one scan.

        Parameters
        ----------
        points : array_like, shape (N, 2)
            All scan end points in the current sensor frame (m); non-finite rows (invalid beams, as
            ``LaserScan.points()`` gives them) are ignored. The sensor is at the origin of this frame (free
            space is traced from it).
        ego : Pose2D, optional
            The current sensor frame in the previous update's sensor frame (moves the map); identity if
            omitted (the sensor is standing).
        exclude : array_like, shape (K, 2), optional
            Positions (m, current sensor frame) of people (confirmed tracks); the points within
            ``exclude_radius`` of them are not added to the map but counted as free space.
        dt : float, optional
            Seconds since the previous update; else from ``stamp_ns``; else :data:`FIRST_DT_S`.
        stamp_ns : int, optional
            The scan's stamp (ns), used for ``dt`` when ``dt`` is not given.
        free : array_like, shape (F, 2), optional
            End points (m, current sensor frame) of the beams that returned nothing within range
            (:meth:`pfpeople.sensors.LaserScan.free_rays`): free space is traced along them up to the end point
            (or ``max_range``), with no hit. Open floor that no beam returns from is then seen free, as
            everywhere else, instead of keeping the unknown prior.

        Raises
        ------
        ValueError
            For arrays of the wrong shape, NaN in ``exclude``, or a negative ``dt``.
        TypeError
            For an ``ego`` that is not a :class:`Pose2D`.
        """
        pts, people, step = self._begin_update(points, ego, exclude, dt, stamp_ns)
        s = self.evidence.reshape(-1)
        if _jit.enabled("pfpeople") and s.base is self.evidence:  # the same as below, compiled (clutter_kernels)
            pts, cells, inside = self._update_compiled(s, pts, people, free, step)
        else:
            pts, human, rays, lengths = self._rays(pts, people, free)
            cells, inside = self.cell_of(self.pose.apply(pts))
            self._evidence_numpy(s, cells, inside, human, rays, lengths, step)
        # the latest returns, for the queries (all returns, people's too: a query looks at what is there now)
        self._hit_cells = cells[inside]
        self._hit_xy = pts[inside]
        self._hit_tree = None  # built by the first query
        self._people = people
        self._scores = None
        self.updates += 1

    def _begin_update(
        self,
        points: ArrayLike,
        ego: Pose2D | None,
        exclude: ArrayLike | None,
        dt: float | None,
        stamp_ns: int | None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
        """The checks and the map's motion of :meth:`update`: the finite returns (N, 2) and the people (K, 2)
        (m, current sensor frame) and the time step (s); the map is moved by ``ego`` and recentred."""
        pts = _positions(points, "points", drop_nonfinite=True)
        if ego is not None and not isinstance(ego, Pose2D):
            raise TypeError(f"ego must be a Pose2D, got {type(ego).__name__}")
        people = _positions(exclude if exclude is not None else np.zeros((0, 2)), "exclude")
        step = self._dt(dt, stamp_ns)
        self.last_dt = step
        if ego is not None and self.updates:
            self.pose = self.pose.compose(ego)
        self._recentre()
        return pts, people, step

    def _rays(
        self, pts: NDArray[np.float64], people: NDArray[np.float64], free: ArrayLike | None
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64], NDArray[np.float64]]:
        """The returns within ``max_range`` (M, 2), which of them lie near a person, and the traced rays (every
        ``free_stride``-th return up to ``free_margin`` before it, the no-return beams and the returns beyond the
        map up to ``max_range``) with their lengths (m, sensor frame)."""
        c = self.config
        r = np.hypot(pts[:, 0], pts[:, 1])
        far = r > c.max_range  # returns beyond the map: the beam crossed free space up to max_range
        far_pts = pts[far] * (c.max_range / r[far])[:, None]
        pts, r = pts[~far], r[~far]
        no_return = np.zeros((0, 2)) if free is None else _positions(free, "free", drop_nonfinite=True)
        free_rays = np.concatenate((no_return, far_pts))  # traced free all along: no end point, no margin
        human = np.zeros(pts.shape[0], dtype=bool)
        if people.shape[0] and pts.shape[0]:
            human = near_any(pts, people, c.exclude_radius)
        beams = np.arange(0, pts.shape[0], c.free_stride)
        fr_pts = free_rays[:: c.free_stride]
        rays = np.concatenate((pts[beams], fr_pts))
        lengths = np.concatenate(
            (r[beams] - c.free_margin, np.minimum(np.hypot(fr_pts[:, 0], fr_pts[:, 1]), c.max_range))
        )
        return pts, human, rays, lengths

    def _update_compiled(
        self,
        s: NDArray[np.float64],
        pts: NDArray[np.float64],
        people: NDArray[np.float64],
        free: ArrayLike | None,
        step: float,
    ) -> tuple[NDArray[np.float64], NDArray[np.intp], NDArray[np.bool_]]:
        """The rest of :meth:`update` compiled, the same values as its numpy steps (:meth:`_rays`, :meth:`cell_of`,
        :meth:`_evidence_numpy`): the scan's geometry by :func:`~pfpeople.perception.clutter_kernels.scan_rays`,
        the evidence by :func:`~pfpeople.perception.clutter_kernels.update_evidence`. Returns the returns within
        ``max_range`` (M, 2), their flat cells and whether they are inside the window."""
        c = self.config
        no_return = np.zeros((0, 2)) if free is None else _positions(free, "free", drop_nonfinite=True)
        inv = 1.0 / c.resolution
        o = self.origin
        pose = (float(self.pose.x), float(self.pose.y), math.cos(self.pose.yaw), math.sin(self.pose.yaw))
        geo = np.array([c.max_range, c.exclude_radius, c.free_stride, c.free_margin, o[0], o[1], inv])
        pts, people, no_return = (np.ascontiguousarray(a) for a in (pts, people, no_return))
        pts, human, cells, inside, ru, n_free = scan_rays(pts, people, no_return, pose, geo, self._steps, self.n)
        origin = (np.array([self.pose.x, self.pose.y]) - o) * inv
        params = np.array(
            [c.unknown_evidence, math.exp(-step / c.forget_time), step, c.s_max, c.free_rate * step, c.s_min]
        )
        nb = self._neighbour_array
        update_evidence(
            s, self.n, cells[inside & ~human], cells[inside & human], ru, n_free, self._steps, origin, nb, params
        )
        return pts, cells, inside

    def _evidence_numpy(
        self,
        s: NDArray[np.float64],
        cells: NDArray[np.intp],
        inside: NDArray[np.bool_],
        human: NDArray[np.bool_],
        rays: NDArray[np.float64],
        lengths: NDArray[np.float64],
        step: float,
    ) -> None:
        """The evidence update of one scan (module docstring): relax towards unknown, hits, free cells."""
        c = self.config
        hc = cells[inside & ~human]
        ncell = self.n * self.n
        free_mask = np.zeros(ncell, dtype=bool)
        free_mask[self._ray_cells(rays, lengths)] = True
        free_mask[cells[inside & human]] = True
        # cells next to a return are not carved free by the beams that pass beside it (thin objects)
        for off in self._neighbours:
            free_mask[(hc + off) % ncell] = False
        s0 = c.unknown_evidence
        s -= s0
        s *= math.exp(-step / c.forget_time)  # every cell relaxes towards unknown; observed ones change below
        s += s0
        hit = np.unique(hc)
        s[hit] = np.minimum(s[hit] + step, c.s_max)
        fr = np.flatnonzero(free_mask)
        s[fr] = np.maximum(s[fr] - c.free_rate * step, c.s_min)

    def _ray_cells(self, rays: NDArray[np.float64], lengths: NDArray[np.float64]) -> NDArray[np.intp]:
        """Flat indices of the map cells sampled along rays from the sensor (one sample per cell length).

        Parameters
        ----------
        rays : ndarray, shape (R, 2)
            A point on each ray (m, current sensor frame; its direction is what counts).
        lengths : ndarray, shape (R,)
            How far (m) each ray is traced; samples at ``resolution * (k + 1/2)`` below it.

        Returns
        -------
        ndarray of intp
            Cells inside the window (with repeats); sample k of a ray with unit direction u is
            ``pose(u * steps[k]) = R u steps[k] + t``.
        """
        ru, origin, n_free = self._ray_dirs(rays, lengths)
        total = int(n_free.sum())
        beam = np.repeat(np.arange(rays.shape[0]), n_free)
        k = np.arange(total) - np.repeat(np.cumsum(n_free) - n_free, n_free)
        fi = np.floor(ru[beam, 0] * self._steps[k] + origin[0]).astype(np.intp)
        fj = np.floor(ru[beam, 1] * self._steps[k] + origin[1]).astype(np.intp)
        ok = (fi >= 0) & (fi < self.n) & (fj >= 0) & (fj < self.n)
        return np.asarray(fi[ok] * self.n + fj[ok], dtype=np.intp)

    def _ray_dirs(
        self, rays: NDArray[np.float64], lengths: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.intp]]:
        """Of rays (R, 2) traced ``lengths`` (R,) m (see :meth:`_ray_cells`): their unit directions in the map
        frame in cells per m (R, 2), the sensor's position in cells from the window's corner (2,), and the samples
        of each ray (R,)."""
        r = np.hypot(rays[:, 0], rays[:, 1])
        n_free = np.searchsorted(self._steps, lengths)
        inv = 1.0 / self.config.resolution
        ru = rotate(rays / np.maximum(r, 1e-9)[:, None], self.pose.yaw) * inv
        origin = (np.array([self.pose.x, self.pose.y]) - self.origin) * inv
        return np.ascontiguousarray(ru), origin, n_free.astype(np.intp)

    # --- queries ----------------------------------------------------------------------------------------------
    def cell_score(self) -> NDArray[np.float64]:
        """``clip(s / static_time, 0, 1)`` of every cell, shape (n, n)."""
        return np.asarray(np.clip(self.evidence / self.config.static_time, 0.0, 1.0), dtype=np.float64)

    def static_points(self, points: ArrayLike) -> NDArray[np.bool_]:
        """Which points lie in a cell the map calls static (``cell_score >= static_threshold``), shape (N,).

        Parameters
        ----------
        points : array_like, shape (N, 2)
            Points (m) in the current sensor frame, e.g. the latest scan's end points; non-finite rows and points
            outside the window are not static. One look-up per point (no neighbourhood, unlike
            :meth:`static_score`): cheap enough for every return of every scan.
        """
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        c = self.config
        ev = self.evidence.reshape(-1)
        if _jit.enabled("pfpeople"):  # the same as below, compiled (pfpeople.perception.clutter_kernels)
            o, yaw = self.origin, self.pose.yaw
            pose = (self.pose.x, self.pose.y, math.cos(yaw), math.sin(yaw))
            lim = np.array([c.static_time, c.static_threshold - 1e-9])
            corner = (float(o[0]), float(o[1]), 1.0 / c.resolution)
            found: NDArray[np.bool_] = static_lookup(np.ascontiguousarray(pts), ev, self.n, pose, corner, lim)
            return found
        out = np.zeros(pts.shape[0], dtype=bool)
        ok = finite_rows(pts)
        if not ok.any():
            return out
        cells, inside = self.cell_of(self.pose.apply(pts[ok]))
        score = ev[cells] / c.static_time
        out[ok] = inside & (score >= c.static_threshold - 1e-9)
        return out

    def static_score(self, positions: ArrayLike) -> NDArray[np.float64]:
        """How long the returns at each position have been there, as a fraction of ``static_time``.

        Parameters
        ----------
        positions : array_like, shape (M, 2)
            Positions (m) in the current sensor frame (the frame of the latest update's points).

        Returns
        -------
        ndarray, shape (M,)
            Mean of ``clip(s / static_time, 0, 1)`` over the cells of the latest returns within
            ``query_radius`` of each position, in [0, 1]; 0 where there are no such returns and within
            ``exclude_radius`` of a position passed in the latest update's ``exclude`` (a confirmed person is
            never static, whatever the place held before).
        """
        pos = _positions(positions, "positions")
        out = np.zeros(pos.shape[0])
        if not pos.shape[0] or not self._hit_xy.shape[0]:
            return out
        score = self._return_scores()
        if _jit.enabled("pfpeople"):  # the same means, by a dense distance test (pfpeople.perception.clutter_kernels)
            out = ball_means(np.ascontiguousarray(self._hit_xy), score, pos, float(self.config.query_radius))
        else:
            if self._hit_tree is None:
                self._hit_tree = cKDTree(self._hit_xy)
            for m, idx in enumerate(self._hit_tree.query_ball_point(pos, r=self.config.query_radius)):
                if idx:
                    out[m] = float(score[idx].mean())
        if self._people.shape[0]:
            out[near_any(pos, self._people, self.config.exclude_radius)] = 0.0
        return out

    def _return_scores(self) -> NDArray[np.float64]:
        """Score of each latest return: the largest cell score within ``query_cells`` cells of its cell."""
        if self._scores is None and _jit.enabled("pfpeople"):  # the same scores, compiled (clutter_kernels)
            offsets = self._query_array
            ev = np.ascontiguousarray(self.evidence).reshape(-1)
            self._scores = return_scores(ev, self._hit_cells, offsets, float(self.config.static_time))
        if self._scores is None:
            ev = self.evidence.reshape(-1)
            ncell = self.n * self.n
            best = ev[self._hit_cells]
            for off in self._query_neighbours:
                best = np.maximum(best, ev[(self._hit_cells + off) % ncell])
            self._scores = np.clip(best / self.config.static_time, 0.0, 1.0)
        return self._scores

    def is_static(self, positions: ArrayLike) -> NDArray[np.bool_]:
        """``static_score(positions) >= static_threshold``, shape (M,)."""
        return np.asarray(self.static_score(positions) >= self.config.static_threshold - 1e-9, dtype=bool)


class MovingPeople:
    """A "people seen moving" set for ``StaticClutterMap.update(exclude=...)`` (after leg_tracker's rule that a
    track becomes a person once it has travelled some distance).

    Detections (sensor frame) are mapped into an odometry frame by the accumulated ego poses. Each one
    continues the nearest live track within ``gate`` (one-to-one, closest pairs first) or starts a new track at
    its position. A track is *moving* once it has moved ``min_distance`` or more within ``window`` seconds (its
    position against an anchor taken between ``window / 2`` and ``window`` seconds earlier; with
    ``window=None`` against where it started), and stays so for ``hold`` seconds after it last did, or until it
    has been unmatched for more than ``max_missed`` consecutive updates (then it is dropped). A chair leg stays
    where it is and never becomes moving. A walker who stops stays moving (kept out of the map) for ``hold``
    seconds: long enough for a pause, while a moving track that has passed onto a chair (a walker's detections
    end beside it and the chair's continue the track) lets the map take the chair after ``hold`` seconds instead
    of never. Measuring the motion over a window rather than from the start matters with wheel odometry: over
    tens of seconds its drift moves a chair by more than ``min_distance``. On the wheelchair scene, with the
    earlier rule (0.3 m from the start) and every confirmed track kept out too, 94 % of the leg detector's
    false people lay within ``exclude_radius`` of a kept-out position, so the map never took their chairs.

    Parameters
    ----------
    gate : float
        Largest distance (m) between a track and the detection that continues it (one scan apart): 0.35 m is
        2.6 m/s at 7.5 Hz. Larger gates let a chair's detection that jumps between two leg pairs continue (and
        "move") its track: on the benchmark 0.5 m gave 0.199 false people per negative scan instead of 0.177,
        for the same recall; 0.25 m gave 0.152 but lost walkers (positive_4 leg recall 0.315 -> 0.292).
    min_distance : float
        Distance (m) a track must move within ``window`` to be moving. 0.6 m in 2 s (0.3-0.6 m/s and more):
        a chair whose detection jumps between its leg pairs by up to ``gate`` is not moving.
    max_missed : int
        Updates a track survives without a detection.
    window : float or None
        Seconds over which the motion is measured (None: since the track started).
    default_dt : float
        Seconds per update when :meth:`update` gets no ``dt``.
    hold : float or None
        Seconds a track stays moving after it last moved ``min_distance`` within ``window``; None: as long as
        it is matched (leg_tracker's rule). 5 s was chosen on ``pfpeople run`` over the scan-level scenes (three
        seeds of wheelchair and crowd), person_following_outdoor_1 and negative_2: on the wheelchair scene of
        seed 1 a passer-by's track went on onto a chair and kept it out of the map for 36 s (precision 0.83; 0.95
        with ``hold = 5``, 0.92 with 10, 0.96 with 3); every other run gave the same people with and without it,
        except wheelchair seed 2 with 3 s (0.912 -> 0.919). 3 s would absorb a person who stops 2 s sooner, a cost
        none of these recordings measures: 5 s is the conservative choice.
    """

    def __init__(
        self,
        *,
        gate: float = 0.35,
        min_distance: float = 0.6,
        max_missed: int = 8,
        window: float | None = 2.0,
        default_dt: float = 0.1,
        hold: float | None = 5.0,
    ) -> None:
        self.gate = _check_number(gate, "gate")
        self.hold = None if hold is None else _check_number(hold, "hold")
        self.min_distance = _check_number(min_distance, "min_distance", allow_zero=True)
        self.window = None if window is None else _check_number(window, "window")
        self.default_dt = _check_number(default_dt, "default_dt")
        self.max_missed = check_int(max_missed, "max_missed", minimum=0)
        self.pose = Pose2D()
        self.time = 0.0
        self._pos = np.zeros((0, 2))
        self._anchor_a = np.zeros((0, 2))  # position at t_a (the anchor the motion is measured against)
        self._anchor_b = np.zeros((0, 2))  # the next anchor, taken at t_b
        self._t_b = np.zeros(0)
        self._missed = np.zeros(0, dtype=int)
        self._moving = np.zeros(0, dtype=bool)
        self._moved_t = np.zeros(0)

    def update(
        self, detections: ArrayLike, *, ego: Pose2D | None = None, dt: float | None = None
    ) -> NDArray[np.float64]:
        """Add one scan's detections; return the moving tracks' positions.

        Parameters
        ----------
        detections : array_like, shape (M, 2)
            Person detections (m) in the current sensor frame (all detectors together; duplicates are fine).
        ego : Pose2D, optional
            The current sensor frame in the previous update's (identity if omitted).
        dt : float, optional
            Seconds since the previous update (``default_dt`` if omitted).

        Returns
        -------
        ndarray, shape (K, 2)
            Latest positions (m) of the moving tracks, in the current sensor frame. For the next scan's
            ``StaticClutterMap.update(exclude=...)`` move them into that scan's frame with
            ``next_ego.inverse().apply(...)``.
        """
        if ego is not None and not isinstance(ego, Pose2D):
            raise TypeError(f"ego must be a Pose2D, got {type(ego).__name__}")
        det = _positions(detections, "detections")
        self.time += self.default_dt if dt is None else _check_number(dt, "dt", allow_zero=True)
        if ego is not None:
            self.pose = self.pose.compose(ego)
        det = self.pose.apply(det) if det.shape[0] else det
        names = ("_pos", "_anchor_a", "_anchor_b", "_t_b", "_missed", "_moving", "_moved_t")
        if _jit.enabled("pfpeople"):  # the same as below, compiled (pfpeople.perception.clutter_kernels)
            nan = math.nan
            window, hold = nan if self.window is None else self.window, nan if self.hold is None else self.hold
            tracks = tuple(getattr(self, name) for name in names)
            new = moving_update(tracks, det, self.time, self.gate, window, self.min_distance, hold, self.max_missed)
            for name, value in zip(names, new, strict=True):
                setattr(self, name, value)
        else:
            self._missed += 1
            self._start_tracks(det[~self._associate(det)])
            self._update_motion()
            alive = self._missed <= self.max_missed
            for name in names:
                setattr(self, name, getattr(self, name)[alive])
        sel = self._pos[self._moving]
        return self.pose.inverse().apply(sel) if sel.shape[0] else np.zeros((0, 2))

    def _associate(self, det: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Greedy nearest-first association of the detections (M, 2) (m, the first update's frame) with the
        tracks not yet updated in this scan, within ``gate``: the tracks take the positions; True for the
        detections used (M,)."""
        used = np.zeros(det.shape[0], dtype=bool)
        if self._pos.shape[0] and det.shape[0]:
            d = np.hypot(self._pos[:, None, 0] - det[None, :, 0], self._pos[:, None, 1] - det[None, :, 1])
            for flat in np.argsort(d, axis=None, kind="stable"):
                t, k = divmod(int(flat), det.shape[0])
                if d[t, k] > self.gate:
                    break
                if used[k] or self._missed[t] == 0:
                    continue
                used[k] = True
                self._pos[t], self._missed[t] = det[k], 0
        return used

    def _start_tracks(self, new: NDArray[np.float64]) -> None:
        """New tracks at ``new`` (M, 2) (m, the first update's frame), anchored there, not moving."""
        m = new.shape[0]
        self._pos = np.concatenate((self._pos, new))
        self._anchor_a = np.concatenate((self._anchor_a, new))
        self._anchor_b = np.concatenate((self._anchor_b, new))
        self._t_b = np.concatenate((self._t_b, np.full(m, self.time)))
        self._missed = np.concatenate((self._missed, np.zeros(m, dtype=int)))
        self._moving = np.concatenate((self._moving, np.zeros(m, dtype=bool)))
        self._moved_t = np.concatenate((self._moved_t, np.full(m, -np.inf)))

    def _update_motion(self) -> None:
        """Move the anchors every ``window / 2`` and mark the tracks that moved ``min_distance`` from theirs
        (moving for ``hold`` seconds since they last did)."""
        if self.window is not None:  # every window / 2 the newer anchor becomes the one measured against
            due = self.time - self._t_b >= 0.5 * self.window - 1e-9
            self._anchor_a[due] = self._anchor_b[due]
            self._anchor_b[due], self._t_b[due] = self._pos[due], self.time
        now_moving = np.hypot(*(self._pos - self._anchor_a).T) >= self.min_distance
        self._moved_t[now_moving] = self.time
        self._moving |= now_moving
        if self.hold is not None:
            self._moving &= self.time - self._moved_t <= self.hold + 1e-9


@dataclass(frozen=True, kw_only=True, eq=False)
class SuppressionStep:
    """What :meth:`ClutterSuppressor.step` did for one scan.

    Attributes
    ----------
    keep : list of ndarray of bool
        For each detection array passed, True for the detections that are not static clutter.
    ego : Pose2D
        The ego-motion used (given, or from the scan matcher; identity when the matcher failed).
    ego_ok : bool
        False when the ego-motion was unknown (the map was forgotten before the update).
    excluded : ndarray, shape (K, 2)
        The moving people excluded from this update (current sensor frame).
    """

    keep: list[NDArray[np.bool_]]
    ego: Pose2D
    ego_ok: bool
    excluded: NDArray[np.float64]


class ClutterSuppressor:
    """The recipe of ``evaluation.bench.clutter`` in one object: one per laser, one :meth:`step` per scan.

    Per scan (all in the laser's frame)::

        ego  = the given ego, else ScanOdometry.update(points).ego   (identity + forget() when the match fails)
        map.update(points, ego=ego, exclude=<moving people of the previous scan moved by ego>)
        own.update(points, ego)                                       (the robot's own returns, SelfReturns)
        keep = ~(map.is_static(detections) | own.is_self(detections)) (for each detection array)
        moving people <- union over arrays i of MovingPeople_i.update(detections[i], raw, ego=ego)

    Each detection array (detector) has its own :class:`MovingPeople`: two detectors that place one chair
    0.2-0.4 m apart (they pair its legs differently) would make one shared track jump between their
    detections and "move" (on the wheelchair scene with the retrained boosted detector, one shared set gave
    precision 0.83, one set per detector 0.91, each detector's set alone 0.91-0.92).

    Parameters
    ----------
    config : ClutterConfig, optional
        The map's parameters.
    odometry : ScanOdometry, optional
        The scan matcher used when :meth:`step` gets no ``ego`` (a default one when omitted).
    moving : MovingPeople, optional
        The "people seen moving" set of the first detection array (a default one when omitted); the other
        arrays get fresh copies of it.
    """

    def __init__(
        self,
        config: ClutterConfig | None = None,
        *,
        odometry: ScanOdometry | None = None,
        moving: MovingPeople | None = None,
    ) -> None:
        if moving is not None and not isinstance(moving, MovingPeople):
            raise TypeError(f"moving must be a MovingPeople, got {type(moving).__name__}")
        self.map = StaticClutterMap(config)
        cfg = self.map.config
        #: The robot's own returns (None with ``self_range = 0``).
        self.own = SelfReturns(max_range=cfg.self_range, travel=cfg.self_travel) if cfg.self_range > 0 else None
        #: The scan matcher with its back-off (:class:`pfpeople.perception.scan_matching.LaserEgoMotion`), used when
        #: :meth:`step` gets no ``ego``.
        self.laser_ego = LaserEgoMotion(odometry)
        self.moving = moving or MovingPeople()
        self._moving_sets: list[MovingPeople] = [self.moving]
        self._prev_moving = np.zeros((0, 2))
        self.scans = 0
        self.odometry_s = 0.0
        """Wall-clock seconds spent in the scan matcher (all scans)."""
        self.map_s = 0.0
        """Wall-clock seconds spent in the map and the moving-people tracks (all scans)."""

    def step(
        self,
        points: ArrayLike,
        detections: Sequence[ArrayLike],
        *,
        ego: Pose2D | None = None,
        ego_ok: bool = True,
        exclude: ArrayLike | None = None,
        stamp_ns: int | None = None,
        dt: float | None = None,
        free: ArrayLike | None = None,
    ) -> SuppressionStep:
        """Add one scan and say which detections are not static clutter.

        Parameters
        ----------
        points : array_like, shape (N, 2)
            All scan end points in the laser frame (m), e.g. ``LaserScan.points()`` (NaN rows are ignored).
        detections : sequence of array_like, shape (M_i, 2)
            The person detections of this scan in the same laser frame (m), one array per detector, always in the
            same order (array i feeds the i-th "people seen moving" set).
        ego : Pose2D, optional
            The laser frame now in the laser frame of the previous scan (odometry, TF, or a match made elsewhere);
            when omitted it comes from this map's scan matcher (:attr:`laser_ego`).
        ego_ok : bool
            False: ``ego`` is a failed match made elsewhere (the map forgets, as after a failure of its own).
        exclude : array_like, shape (K, 2), optional
            More people to keep out of the map, in this scan's laser frame (e.g. the confirmed people of a
            tracker or of the filter's output, moved into this frame), besides the moving tracks.
        stamp_ns, dt : optional
            The scan's time, see :meth:`StaticClutterMap.update`.
        free : array_like, shape (F, 2), optional
            Ends of the beams without a return (:meth:`pfpeople.sensors.LaserScan.free_rays`): free space.

        Returns
        -------
        SuppressionStep
        """
        dets = [_positions(d, f"detections[{i}]") for i, d in enumerate(detections)]
        extra = _positions(exclude if exclude is not None else np.zeros((0, 2)), "exclude")
        t0 = time.perf_counter()
        ego, ok = self._ego(points, ego, ego_ok)
        t1 = time.perf_counter()
        if not ok:
            self.map.forget()
        prev = self._prev_moving
        excluded = np.concatenate((ego.inverse().apply(prev) if prev.shape[0] else prev, extra))
        self.map.update(points, ego=ego, exclude=excluded, stamp_ns=stamp_ns, dt=dt, free=free)
        if self.own is not None:
            self.own.update(points, ego if ok else None)
        keep = [~flags for flags in self.clutter_flags(dets)]
        while len(self._moving_sets) < len(dets):
            self._moving_sets.append(copy.deepcopy(self._moving_sets[0]))
        moving = [mp.update(d, ego=ego, dt=self.map.last_dt) for mp, d in zip(self._moving_sets, dets, strict=False)]
        self._prev_moving = np.concatenate(moving) if moving else np.zeros((0, 2))
        t2 = time.perf_counter()
        self.scans += 1
        self.odometry_s += t1 - t0
        self.map_s += t2 - t1
        return SuppressionStep(keep=keep, ego=ego, ego_ok=ok, excluded=excluded)

    def _ego(self, points: ArrayLike, ego: Pose2D | None, ego_ok: bool) -> tuple[Pose2D, bool]:
        """The scan's ego-motion and whether it is known: the given one, else this map's scan match."""
        if ego is None:
            return self.laser_ego.match(points, first=self.scans == 0)
        if not isinstance(ego, Pose2D):
            raise TypeError(f"ego must be a Pose2D, got {type(ego).__name__}")
        return ego, bool(ego_ok)

    @property
    def odometry(self) -> ScanOdometry:
        """The scan matcher used when :meth:`step` gets no ``ego``."""
        return self.laser_ego.odometry

    def clutter_flags(self, groups: Sequence[NDArray[np.float64]]) -> list[NDArray[np.bool_]]:
        """:meth:`is_clutter` of each array of positions ``(M_i, 2)`` in ``groups``, in one query of them all
        (each position's answer is its own: the same flags as a query per array)."""
        arrays = [np.asarray(g, dtype=float).reshape(-1, 2) for g in groups]
        sizes = [a.shape[0] for a in arrays]
        if not any(sizes):
            return [np.zeros(0, dtype=bool) for _ in groups]
        flags = self.is_clutter(arrays[0] if len(arrays) == 1 else np.concatenate(arrays))
        out, start = [], 0
        for n in sizes:  # slices of the one answer (what np.split gives, without its overhead)
            out.append(flags[start : start + n])
            start += n
        return out

    def is_clutter(self, positions: ArrayLike) -> NDArray[np.bool_]:
        """``(M,)`` which positions (m, laser frame of the latest :meth:`step`) are static clutter: static in
        the map, or on the robot's own returns."""
        out = self.map.is_static(positions)
        if self.own is not None and out.shape[0]:
            out |= self.own.is_self(positions)
        return out
