"""Laser detector: things that move, i.e. returns lying where earlier scans saw free space (a motion detector).

A person who walks puts returns where, a fraction of a second earlier, the laser saw through to something farther
away or saw nothing at all; walls, furniture and parked things put their returns where the laser has always
stopped. The detector keeps the last scans with the laser's pose in each (from the run's ego-motion: wheel odometry
or scan matching) and, for every return of the current scan within ``max_range``, asks each past scan between
``min_age`` and ``max_age`` seconds old whether it saw through the return's position:

* the return is moved into the past scan's frame (``q = T p``, ``T``: the current laser frame in that scan's);
* the past beam nearest ``q``'s bearing and its neighbours on each side must each have returned at least
  ``margin`` beyond ``q``'s range, or nothing (``+inf``, REP-117: free space to the laser's range, so only where
  ``q``'s range plus ``margin`` is within that scan's ``range_max``). The
  neighbours cover the registration error: ``side = max(1, ceil(atan(tolerance / r) / increment))`` beams on each
  side at range ``r``, so the odometry's latency and error (``tolerance``, metres at the return) cannot make a wall
  beside the return "seen through"; a beam without a reading (NaN, too close) sees through nothing.

Returns that a past scan saw through are *moved*. A return that differs in range by more than ``edge`` from both of
its neighbours is a lone point, the signature of a mixed pixel at a depth edge (a range between the two surfaces,
which is exactly where the earlier scan saw through): it is never moved. Moved returns are grouped in bearing order
(a gap of more than ``link`` metres starts a new group; groups whose centres are within ``merge`` metres join: two
legs), and every group of at least ``min_returns`` moved returns no wider than ``max_width`` is a person candidate,
at its centre pushed ``leg_radius`` farther along its bearing (the laser sees the front of the legs). Its score is
the fraction of the returns within ``link`` of it that moved.

Without a known ego-motion (the first scan, an odometry gap, a failed scan match, a jump) the memory is emptied
and the detector sees nothing until it holds scans old enough again. By design it finds walkers, with many false
candidates (a door that swings, a person's arm, the shadow edge of a passing person on a wall): its PPV and FNR are
measured like every detector's and the fusion weighs it by them. People who stand still are not its job.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gridbridge import jit as _jit
from gridbridge.geometry import Pose2D
from gridbridge.params import DetectorModel
from gridbridge.validation import check_int, check_positive
from pfpeople.detect.motion_kernels import moved_flags
from pfpeople.sensors import LaserScan

__all__ = ["CALIBRATED_MOTION", "MotionDetector", "MotionParams", "compose_pending", "moved_returns"]


@dataclass(frozen=True, kw_only=True)
class MotionParams:
    """Settings of :class:`MotionDetector` (module docstring).

    Parameters
    ----------
    min_age, max_age : float
        The past scans looked at are this old (s): younger ones show a leg where it stood, older ones drift with
        the odometry.
    views : int
        Past scans looked at, evenly spaced over those between ``min_age`` and ``max_age``.
    margin : float
        How much farther (m) a past beam must have returned to see through a return.
    tolerance : float
        Registration error (m, at the return) the side beams cover.
    turn_tolerance : float
        Registration error in bearing (rad) the side beams cover too.
    edge : float
        A return farther than this (m) in range from both its neighbours is a lone point (a mixed pixel): never
        moved.
    max_range : float
        Returns farther than this (m) are not looked at.
    link : float
        A gap (m) between bearing-ordered moved returns that starts a new group.
    merge : float
        Groups whose centres are this close (m) join (two legs).
    min_returns : int
        Moved returns a candidate needs.
    max_width : float
        Widest candidate (m): wider moved groups are walls uncovered by a passer-by, doors, not a person.
    leg_radius : float
        A candidate lies this far (m) behind its returns' centre along its bearing (the laser sees the legs' front).
    vacated_radius : float
        A return up to this far (m) behind a vacated return along its beam is moved too (a person walking away).
    """

    min_age: float = 0.2
    max_age: float = 0.6
    views: int = 3
    margin: float = 0.3
    tolerance: float = 0.05
    turn_tolerance: float = 0.01
    edge: float = 0.15
    max_range: float = 12.0
    link: float = 0.3
    merge: float = 0.5
    min_returns: int = 2
    max_width: float = 1.0
    leg_radius: float = 0.06
    vacated_radius: float = 0.6

    def __post_init__(self) -> None:
        for name in ("min_age", "margin", "tolerance", "edge", "link", "merge", "max_width", "vacated_radius"):
            check_positive(getattr(self, name), f"MotionParams.{name}")
        check_positive(self.leg_radius, "MotionParams.leg_radius", allow_zero=True)
        check_positive(self.turn_tolerance, "MotionParams.turn_tolerance", allow_zero=True)
        check_positive(self.max_range, "MotionParams.max_range")
        if self.max_age <= self.min_age:
            raise ValueError(f"MotionParams.max_age must exceed min_age, got {self.max_age} <= {self.min_age}")
        check_int(self.views, "MotionParams.views", minimum=1)
        check_int(self.min_returns, "MotionParams.min_returns", minimum=1)


@dataclass(frozen=True, kw_only=True, eq=False)
class _Past:
    """A held scan: its stamp, its beams (``far``: the range beyond which it saw nothing), its geometry."""

    stamp_ns: int
    far: NDArray[np.float64]
    angle_min: float
    increment: float
    range_max: float
    points: NDArray[np.float64]

    @classmethod
    def of(cls, scan: LaserScan, max_range: float) -> _Past:
        far = np.where(scan.no_return, np.inf, np.where(scan.valid, scan.ranges, -np.inf))
        pts = scan.points()
        with np.errstate(invalid="ignore"):
            keep = np.isfinite(pts[:, 0]) & (scan.ranges <= max_range)
        return cls(
            stamp_ns=scan.stamp_ns,
            far=far,
            angle_min=scan.angle_min,
            increment=scan.angle_increment,
            range_max=float(scan.range_max),
            points=pts[keep],
        )


def _lone(r: NDArray[np.float64], edge: float) -> NDArray[np.bool_]:
    """Returns whose range differs by more than ``edge`` from both neighbours' (NaN neighbours differ)."""
    left = np.r_[np.nan, r[:-1]]
    right = np.r_[r[1:], np.nan]
    with np.errstate(invalid="ignore"):
        return ~(np.abs(left - r) <= edge) & ~(np.abs(right - r) <= edge)


def moved_returns(
    scan: LaserScan, views: list[tuple[_Past, Pose2D]], params: MotionParams
) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
    """The looked-at returns of ``scan`` (beam indices) and whether each is moved (module docstring); ``views``
    pairs a past scan with the current laser frame's pose in its frame."""
    r = np.where(scan.valid, scan.ranges, np.nan)
    with np.errstate(invalid="ignore"):
        idx = np.flatnonzero(np.isfinite(r) & (r <= params.max_range) & ~_lone(r, params.edge))
    moved = np.zeros(idx.size, dtype=bool)
    if not idx.size or not views:
        return idx, moved
    b = scan.angles[idx]
    pts = np.column_stack((r[idx] * np.cos(b), r[idx] * np.sin(b)))
    now = _Past.of(scan, params.max_range)
    for past, pose in views:
        moved |= _seen_through(pose.apply(pts), past, params)
        gone = past.points[_seen_through(pose.inverse().apply(past.points), now, params)]
        if gone.shape[0]:
            moved |= _behind_vacated(pts, pose.inverse().apply(gone), params.vacated_radius)
    return idx, moved


def _seen_through(q: NDArray[np.float64], past: _Past, params: MotionParams) -> NDArray[np.bool_]:
    """Whether ``past`` saw through each point ``q`` ``(N, 2)`` (m, its frame)."""
    qr, qb = np.hypot(q[:, 0], q[:, 1]), np.arctan2(q[:, 1], q[:, 0])
    rule = (params.margin, params.tolerance, params.turn_tolerance, past.range_max)
    if _jit.enabled("pfpeople"):
        out: NDArray[np.bool_] = moved_flags(qr, qb, past.far, past.angle_min, past.increment, *rule)
        return out
    return _moved_numpy(qr, qb, past, *rule)


def _behind_vacated(pts: NDArray[np.float64], gone: NDArray[np.float64], radius: float) -> NDArray[np.bool_]:
    """Points ``(N, 2)`` behind a vacated point ``gone`` ``(V, 2)`` along its beam (m, current frame): farther from
    the laser by at most ``radius`` and within half of it across the beam, where a person who walked away from the
    laser stands now."""
    gr = np.maximum(np.hypot(gone[:, 0], gone[:, 1]), 1e-6)
    u = gone / gr[:, None]  # unit bearing of each vacated point
    rel = pts[:, None, :] - gone[None, :, :]
    along = rel[..., 0] * u[None, :, 0] + rel[..., 1] * u[None, :, 1]
    across = np.abs(rel[..., 1] * u[None, :, 0] - rel[..., 0] * u[None, :, 1])
    inside = (along > 0.0) & (along <= radius) & (across <= 0.5 * radius)
    return np.asarray(inside.any(axis=1), dtype=bool)


def _moved_numpy(
    qr: NDArray[np.float64],
    qb: NDArray[np.float64],
    past: _Past,
    margin: float,
    tolerance: float,
    turn: float,
    range_max: float,
) -> NDArray[np.bool_]:
    """The numpy twin of :func:`pfpeople.detect.motion_kernels.moved_flags`."""
    n, inc = past.far.size, past.increment
    rel = (qb - past.angle_min) % (2.0 * np.pi) if inc > 0 else -((past.angle_min - qb) % (2.0 * np.pi))
    k = np.rint(rel / inc).astype(np.intp)
    side = np.maximum(1, np.ceil((np.arctan(tolerance / np.maximum(qr, 1e-6)) + turn) / abs(inc))).astype(np.intp)
    need = qr + margin
    out = (k - side >= 0) & (k + side < n) & (need <= range_max)
    for d in range(int(side.max(initial=1)) + 1):
        for sgn in (-1, 1) if d else (1,):
            j = np.clip(k + sgn * d, 0, n - 1)
            out &= (d > side) | (past.far[j] >= need)
    return out


def _groups(pts: NDArray[np.float64], link: float, merge: float) -> list[NDArray[np.intp]]:
    """Groups of bearing-ordered points: a jump over ``link`` (m) splits, groups within ``merge`` (m) join."""
    if not pts.shape[0]:
        return []
    jump = np.linalg.norm(np.diff(pts, axis=0), axis=1) > link
    starts = np.r_[0, np.flatnonzero(jump) + 1]
    groups = [np.arange(a, b) for a, b in zip(starts, np.r_[starts[1:], pts.shape[0]], strict=True)]
    merged: list[NDArray[np.intp]] = []
    for g in groups:
        if merged and np.linalg.norm(pts[g].mean(axis=0) - pts[merged[-1]].mean(axis=0)) <= merge:
            merged[-1] = np.r_[merged[-1], g]
        else:
            merged.append(g)
    return merged


class MotionDetector:
    """People as things that moved through space seen free (module docstring).

    Parameters
    ----------
    params : MotionParams, optional
    model : DetectorModel, optional
        PPV / FNR for the filters; default the values measured on the labelled data (:data:`CALIBRATED_MOTION`).
    """

    #: The detector needs the laser frame's motion before every scan (:meth:`observe_motion`).
    uses_ego_motion = True

    def __init__(self, params: MotionParams | None = None, *, model: DetectorModel | None = None) -> None:
        self.params = params if params is not None else MotionParams()
        self.model = model if model is not None else _default_model()
        self._past: deque[tuple[_Past, Pose2D]] = deque()
        self._motion: Pose2D | None = None
        self._given = False
        self._seen_first = False

    def reset(self) -> None:
        """Forget every held scan."""
        self._past.clear()
        self._motion = None
        self._given = False
        self._seen_first = False

    def observe_motion(self, motion: Pose2D | None) -> None:
        """The laser frame's motion since the previous scan (the new frame in the previous one), or None when
        unknown; call before :meth:`detect` of the new scan. Motions given for frames whose scan never reached
        :meth:`detect` (unusable data) are composed with the next one."""
        self._motion = compose_pending(self._motion, motion, self._given)
        self._given = True

    def _advance(self, scan: LaserScan) -> list[tuple[_Past, Pose2D]]:
        """Bring the held scans' poses to the new frame and return the views old enough to look at."""
        motion, self._motion, self._given = self._motion, None, False
        if motion is None and self._seen_first:
            self._past.clear()
        elif motion is not None:
            held = [(p, pose.compose(motion)) for p, pose in self._past]
            self._past = deque(held)
        p = self.params
        while self._past and (scan.stamp_ns - self._past[0][0].stamp_ns) * 1e-9 > p.max_age + 1e-9:
            self._past.popleft()
        old = [v for v in self._past if (scan.stamp_ns - v[0].stamp_ns) * 1e-9 >= p.min_age - 1e-9]
        if len(old) > p.views:
            last = len(old) - 1
            old = [old[round(i * last / (p.views - 1))] for i in range(p.views)] if p.views > 1 else [old[0]]
        return old

    def _hold(self, scan: LaserScan) -> None:
        self._past.append((_Past.of(scan, self.params.max_range), Pose2D()))
        self._seen_first = True

    def moved_beams(self, scan: LaserScan) -> NDArray[np.bool_]:
        """Take ``scan`` as the new scan and say which of its beams returned from something that moved, shape
        (B,) (the learned detector's motion input, :mod:`pfpeople.detect.learned.memory`)."""
        views = self._advance(scan)
        idx, moved = moved_returns(scan, views, self.params)
        self._hold(scan)
        out = np.zeros(scan.ranges.size, dtype=bool)
        out[idx[moved]] = True
        return out

    def detect_scored(self, scan: LaserScan) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Person candidates ``(M, 2)`` (m, scan frame) and their scores ``(M,)`` in [0, 1]."""
        views = self._advance(scan)
        idx, moved = moved_returns(scan, views, self.params)
        self._hold(scan)
        if not moved.any():
            return np.zeros((0, 2)), np.zeros(0)
        b, r = scan.angles[idx], scan.ranges[idx]
        pts = np.column_stack((r * np.cos(b), r * np.sin(b)))
        return self._candidates(pts, moved)

    def _candidates(
        self, pts: NDArray[np.float64], moved: NDArray[np.bool_]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        p = self.params
        mpts = pts[moved]
        out, scores = [], []
        for g in _groups(mpts, p.link, p.merge):
            q = mpts[g]
            width = float(np.linalg.norm(q.max(axis=0) - q.min(axis=0)))
            if g.size < p.min_returns or width > p.max_width:
                continue
            c = q.mean(axis=0)
            c = c * (1.0 + p.leg_radius / max(float(np.hypot(*c)), 1e-6))
            near = np.linalg.norm(pts - c, axis=1) <= p.link + p.leg_radius
            out.append(c)
            scores.append(float(moved[near].mean()) if near.any() else 1.0)
        return np.asarray(out, dtype=float).reshape(-1, 2), np.asarray(scores, dtype=float)

    def detect(self, scan: LaserScan) -> NDArray[np.float64]:
        """Person candidates ``(M, 2)`` (m, scan frame)."""
        return self.detect_scored(scan)[0]


def compose_pending(pending: Pose2D | None, motion: Pose2D | None, given: bool) -> Pose2D | None:
    """The motion since the last scan a detector saw: ``motion``, composed after a ``pending`` one given for a frame
    whose scan it never saw (``given``); unknown (None) when either is."""
    if not given:
        return motion
    if pending is None or motion is None:
        return None
    return pending.compose(motion)


#: The motion detector's PPV and FNR, measured as the built-in detectors' (:data:`gridbridge.params.
#: CALIBRATED_LASER_DETECTORS`) on data the benchmark does not score, people with fewer than three returns ignored
#: (``python -m evaluation.harness.motion_calibration --seed 3``): PPV the pooled true over all detections of the
#: five scan-level scenes at simulation seed 3 and negative_2's three lasers, 0.57; FNR the mean miss rate of those
#: scenes and of person_following_outdoor_1's followed person, 0.49 (0.99 there: no odometry, and its scans seldom
#: scan-match outdoors, so the detector rarely knows the laser's motion).
CALIBRATED_MOTION = DetectorModel(name="laser_motion", ppv=0.57, fnr=0.49)


def _default_model() -> DetectorModel:
    return CALIBRATED_MOTION
