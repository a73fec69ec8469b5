"""Arrivals: returns where the same laser saw through a moment ago are of something that came there.

The static-clutter map (:mod:`pfpeople.perception.clutter_map`) measures how long a place has been occupied, so a
person who has stood since they came into view and a chair are the same to it. The scans of the last second tell
them apart: a person who stands sways and shifts their weight, so some of a leg's returns of this scan lie where,
a fraction of a second earlier, the laser saw through to something farther away (or saw nothing); furniture's
returns lie where the laser has always stopped.

Over one second the scans are registered by the frame-to-frame ego-motion (wheel odometry or scan matching),
whose error over that span is a couple of centimetres at walking speed, the laser's own noise; over longer spans
the odometry's drift lets the beams beside a chair leg "see through" it (on the benchmark's wheelchair scene, at
1 m/s, the registered past scans of static objects sat 7-9 cm off after 3 s).

:class:`RecentScans` keeps one laser's scans of the last :data:`WINDOW_S` seconds with the pose of each in the
static-clutter map's frame, and says for each queried detection whether one of up to :data:`VIEWS` scans
:data:`MIN_AGE_S` to :data:`WINDOW_S` old saw through at least :data:`FRACTION` of its returns (the current
scan's end points within :data:`RADIUS_M` of it). A person who stands does not sway in every second, so the place
where a detection of a precise detector (the caller says which: ``[[detectors]] hold_arrivals``) arrived is *held*
for :data:`HOLD_S` seconds: that detector's static detections within :data:`HOLD_RADIUS_M` of it count as arrived
too. Only arrivals
renew a place, so a false arrival (a chair's edge uncovered by a registration error) lapses.

A scan sees through a point (m, that scan's frame) when the beam nearest the point's bearing and its
:data:`SIDE_BEAMS` neighbours on each side each returned at least :data:`MARGIN_M` farther, or returned nothing
(``+inf`` or ``range_max`` and beyond, REP-117); a point outside the scan's field of view or beyond its
``range_max``, or a beam without a reading (NaN, below ``range_min``), says nothing.

Frames: the map frame ``M`` of :class:`pfpeople.perception.clutter_map.StaticClutterMap` (``map.pose`` is the
current laser frame in ``M``); detections and points in the current laser frame (m, REP-103).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge import jit as _jit
from gridbridge.geometry import Pose2D, to_frame
from pfpeople.perception.clutter_kernels import arrived_flags, near_any, view_points
from pfpeople.sensors import LaserScan

__all__ = [
    "FRACTION",
    "MARGIN_M",
    "MIN_AGE_S",
    "RADIUS_M",
    "SIDE_BEAMS",
    "VIEWS",
    "WINDOW_S",
    "RecentScans",
    "seen_through_beams",
]

#: The oldest scan looked at (s): one second of odometry drift is within the laser's noise (module docstring).
WINDOW_S = 1.0
#: The newest scan looked at (s): younger scans show the same leg in the same place (a person's sway moves a leg
#: about 5 cm in 0.3-0.5 s).
MIN_AGE_S = 0.3
#: Scans looked at, evenly spaced over the ones between :data:`MIN_AGE_S` and :data:`WINDOW_S` old.
VIEWS = 3
#: How much farther (m) a beam must return to see through a point: ten times the range noise of common 2-D
#: lasers, more than the spread of the mixed pixels at a leg's edge.
MARGIN_M = 0.3
#: The fraction of a detection's returns one earlier scan must see through: most of a leg has moved, not the
#: edge that a centimetre of registration error uncovers.
FRACTION = 0.5
#: The beams on each side of a return's nearest beam that must see through it too: where a wall is seen at a
#: grazing angle, a beam's range changes by decimetres from one beam to the next, and the nearest beam alone let
#: the wall "arrive" (corridor scene, seed 1: a false person for 100 frames, precision 0.99 -> 0.92).
SIDE_BEAMS = 1
#: A detection's returns are the current scan's end points within this distance (m): the static-clutter map's
#: ``query_radius``.
RADIUS_M = 0.35
#: How long (s) a place where a detection arrived stays a person's: the time constant of a standing person's sway
#: (the simulator's, 2 s; the issue measured 0.1-0.4 m over 2-4 s), after which their legs have moved and arrive
#: again; a chair's false arrival (a registration error) lapses. Held 5 s, wheelchair's false arrivals (robot at
#: 1 m/s) became false tracks (MOTA -0.02 on two seeds, ``docs/ablations.md``).
HOLD_S = 2.0
#: A held place readmits the static detections within this distance (m): the benchmark's person radius, wider
#: than a standing person's detection jitter (0.05-0.1 m), as :data:`pfpeople.track.stopped_people.ANCHOR_RADIUS`.
HOLD_RADIUS_M = 0.3


class RecentScans:
    """One laser's scans of the last :data:`WINDOW_S` seconds, and which detections arrived (module docstring).

    Use per scan, after the static-clutter map's update::

        if not ego_ok:
            recent.clear()                              # the history no longer lines up
        arrived = recent.arrived(static_detections, points, clutter.map.pose, stamp_ns)
        recent.add(scan, clutter.map.pose, stamp_ns)
    """

    def __init__(self) -> None:
        self._scans: deque[tuple[int, _Beams, Pose2D]] = deque()
        #: The held places: (stamp ns, x m, y m in the map frame) of the holdable detections that arrived
        self._places: deque[tuple[int, float, float]] = deque()

    def __len__(self) -> int:
        """The number of scans held."""
        return len(self._scans)

    def clear(self) -> None:
        """Forget every scan (for an unknown ego-motion, or a restart)."""
        self._scans.clear()
        self._places.clear()

    def add(self, scan: LaserScan, pose: Pose2D, stamp_ns: int) -> None:
        """Hold ``scan`` (taken at ``stamp_ns``, ns) with ``pose``, its laser frame in the map frame; drop the scans
        older than :data:`WINDOW_S` by then."""
        self._scans.append((int(stamp_ns), _Beams.of(scan), pose))
        while (stamp_ns - self._scans[0][0]) * 1e-9 > WINDOW_S + 1e-9:
            self._scans.popleft()

    def arrived(
        self, detections: ArrayLike, points: ArrayLike, pose: Pose2D, stamp_ns: int, holdable: ArrayLike | None = None
    ) -> NDArray[np.bool_]:
        """Which detections sit where an earlier scan saw through most of their returns.

        Parameters
        ----------
        detections : array_like, shape (M, 2)
            Positions (m, current laser frame).
        points : array_like, shape (N, 2)
            The current scan's end points (m, current laser frame; NaN rows are ignored).
        pose : Pose2D
            The current laser frame in the map frame.
        stamp_ns : int
            The current scan's time (ns).
        holdable : array_like of bool, shape (M,), optional
            The detections whose arrivals are held (:data:`HOLD_S`) and which a held place readmits (default
            none).

        Returns
        -------
        ndarray of bool, shape (M,)
            The detections that arrived now, or that are holdable and lie within :data:`HOLD_RADIUS_M` of a place
            where a holdable one arrived in the last :data:`HOLD_S` seconds (the places are kept in the map frame;
            only arrivals, not held detections, renew them).
        """
        det = np.asarray(detections, dtype=float).reshape(-1, 2)
        came = self._came(det, points, pose, stamp_ns)
        ok = np.zeros(det.shape[0], dtype=bool) if holdable is None else np.asarray(holdable, dtype=bool)
        if ok.shape != came.shape:
            raise ValueError(f"holdable must have one flag per detection ({came.shape[0]}), got shape {ok.shape}")
        held = self._held(det, pose, stamp_ns) & ok
        if (came & ok).any():
            self._places.extend((int(stamp_ns), float(x), float(y)) for x, y in pose.apply(det[came & ok]))
        return came | held

    def _held(self, det: NDArray[np.float64], pose: Pose2D, stamp_ns: int) -> NDArray[np.bool_]:
        """Which detections (M, 2; current laser frame) lie within :data:`HOLD_RADIUS_M` of a held place (the
        places older than :data:`HOLD_S` dropped first)."""
        while self._places and (stamp_ns - self._places[0][0]) * 1e-9 > HOLD_S + 1e-9:
            self._places.popleft()
        if not self._places or not det.shape[0]:
            return np.zeros(det.shape[0], dtype=bool)
        here = to_frame(np.array([(x, y) for _, x, y in self._places]), pose)  # map frame -> current laser frame
        return near_any(det, here, HOLD_RADIUS_M)

    def _came(self, det: NDArray[np.float64], points: ArrayLike, pose: Pose2D, stamp_ns: int) -> NDArray[np.bool_]:
        """Which detections (M, 2) arrived by the recent scans alone (the first part of :meth:`arrived`)."""
        out = np.zeros(det.shape[0], dtype=bool)
        views = self._views(pose, stamp_ns)
        if not views or not det.shape[0]:
            return out
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        if _jit.enabled("pfpeople"):  # the same answers, fewer numpy calls (pfpeople.perception.clutter_kernels)
            return _arrived_compiled(det, pts, views)
        dx, dy = pts[None, :, 0] - det[:, None, 0], pts[None, :, 1] - det[:, None, 1]
        owner, which = np.nonzero(dx * dx + dy * dy <= RADIUS_M * RADIUS_M)  # NaN rows are near nothing
        if not owner.size:
            return out
        own, m = pts[which], det.shape[0]
        need = FRACTION * np.bincount(owner, minlength=m)
        for beams, here_in_past in views:
            out |= np.bincount(owner, weights=beams.seen_through(here_in_past.apply(own)), minlength=m) >= need
        return out & (need > 0)

    def _views(self, pose: Pose2D, stamp_ns: int) -> list[tuple[_Beams, Pose2D]]:
        """Up to :data:`VIEWS` held scans :data:`MIN_AGE_S` to :data:`WINDOW_S` old, evenly spaced, each with the
        current laser frame in its laser frame."""
        lo, hi = stamp_ns - WINDOW_S * 1e9 - 1.0, stamp_ns - MIN_AGE_S * 1e9 + 1.0
        old = [(beams, p) for t, beams, p in self._scans if lo <= t <= hi]
        if len(old) > VIEWS:
            last = len(old) - 1
            old = [old[round(i * last / (VIEWS - 1))] for i in range(VIEWS)]
        return [(beams, p.inverse().compose(pose)) for beams, p in old]


def _arrived_compiled(
    det: NDArray[np.float64], pts: NDArray[np.float64], views: list[tuple[_Beams, Pose2D]]
) -> NDArray[np.bool_]:
    """:meth:`RecentScans.arrived` of detections ``det`` (M, 2) and points ``pts`` (N, 2) against ``views``
    (non-empty), by :func:`~pfpeople.perception.clutter_kernels.view_points` and
    :func:`~pfpeople.perception.clutter_kernels.arrived_flags`, with numpy's ``hypot`` and ``arctan2`` of every
    view's points in one call each: the same operations as the numpy code, the same answers."""
    m = det.shape[0]
    poses = np.array([(p.x, p.y, math.cos(p.yaw), math.sin(p.yaw)) for _, p in views])
    owner, local = view_points(np.ascontiguousarray(det), np.ascontiguousarray(pts), RADIUS_M * RADIUS_M, poses)
    if not owner.size:
        return np.zeros(m, dtype=bool)
    r = np.hypot(local[:, 0], local[:, 1])
    bearing = np.arctan2(local[:, 1], local[:, 0])
    far = np.concatenate([b.far for b, _ in views])
    starts = np.cumsum([0] + [b.far.size for b, _ in views]).astype(np.intp)
    geo = np.array([(b.angle_min, b.increment, b.range_max) for b, _ in views])
    out: NDArray[np.bool_] = arrived_flags(r, bearing, owner, m, far, starts, geo, (SIDE_BEAMS, MARGIN_M, FRACTION))
    return out


@dataclass(frozen=True)
class _Beams:
    """A held scan's geometry and, per beam, the range beyond which it saw nothing (``+inf`` for a beam that
    returned nothing, ``-inf`` for one without a reading: it sees through no point)."""

    angle_min: float
    increment: float
    range_max: float
    far: NDArray[np.float64]

    @classmethod
    def of(cls, scan: LaserScan) -> _Beams:
        ranges = scan.ranges  # a beam with a reading: ``valid`` (finite, range_min to range_max)
        far = np.where(scan.no_return, np.inf, np.where(scan.valid, ranges, -np.inf))
        return cls(float(scan.angle_min), float(scan.angle_increment), float(scan.range_max), far)

    def seen_through(self, local: NDArray[np.float64]) -> NDArray[np.bool_]:
        """:func:`seen_through_beams` of points ``local`` (N, 2) (m, the scan's frame)."""
        n, inc = self.far.size, self.increment
        if n == 0 or inc == 0.0:
            return np.zeros(local.shape[0], dtype=bool)
        r = np.hypot(local[:, 0], local[:, 1])
        bearing = np.arctan2(local[:, 1], local[:, 0])
        # the bearing from the first beam, in the scan's direction (a 360 deg scan may start anywhere)
        rel = (bearing - self.angle_min) % (2.0 * np.pi) if inc > 0 else -((self.angle_min - bearing) % (2.0 * np.pi))
        k = np.rint(rel / inc).astype(np.intp)
        seen = (k >= SIDE_BEAMS) & (k < n - SIDE_BEAMS) & (r <= self.range_max)
        far_enough = r + MARGIN_M
        for d in range(-SIDE_BEAMS, SIDE_BEAMS + 1):
            seen &= self.far[np.clip(k + d, 0, n - 1)] >= far_enough
        return seen


def seen_through_beams(local: NDArray[np.float64], scan: LaserScan) -> NDArray[np.bool_]:
    """Whether ``scan`` saw through each point (module docstring).

    Parameters
    ----------
    local : ndarray, shape (N, 2)
        Points (m) in the scan's frame.
    scan : LaserScan

    Returns
    -------
    ndarray of bool, shape (N,)
        True where the beam nearest the point's bearing and :data:`SIDE_BEAMS` on each side returned at least
        :data:`MARGIN_M` beyond it, or nothing.
    """
    return _Beams.of(scan).seen_through(np.asarray(local, dtype=float).reshape(-1, 2))
