"""The people a run reports: the classified people that the multi-person tracker confirms, and its coasting tracks.

One :meth:`PeopleTracker.step` per frame, after the classifier:

1. **Tracker inputs.** The tracker (:class:`~pfpeople.track.multi_person.MultiPersonTracker`) gets the classified
   people and, with ``peak_threshold``, the weaker belief peaks above it (they update tracks through a dip of
   the belief; tracks start only from people: ``TrackerConfig.birth_min_score`` = the classifier's threshold).
   With a hysteresis classifier (:class:`gridbridge.classifiers.HysteresisPeaks`) the weaker peaks are its own
   rejected candidates; otherwise :func:`pfpeople.track.belief_inputs.tracker_inputs` finds them. With ``snap_radius``
   and the frame's precise detections given (the laser detectors' people, static clutter removed), each of these
   positions with detections within ``snap_radius`` is moved to their mean: the grid places a person on its
   0.1-0.3 m cells, a laser detection to a few centimetres, and in a crowd the sharper positions keep tracks
   on their people.
2. **Reported people** (``people = "confirmed"``, the recommended mode's default):

   - a classified person is reported when the position assigned to a *confirmed* track in this frame is that
     person (:attr:`Track.measurement <pfpeople.track.multi_person.Track.measurement>`): a person appears once the
     tracker has confirmed it (a run's default: by the evidence of its hits, ``[tracking] confirm_evidence``; else 3
     hits within 5 frames), so clutter that peaks for one or two frames
     is never reported;
   - a confirmed track that missed the last ``1 .. coast_frames`` frames is reported at its predicted position
     (constant velocity) when that lies in an observed cell of the grid and farther than ``min_separation``
     from every reported person; its score is the belief at that cell, its size 0 cells;
   - with ``support`` positions (the laser detectors' unpaired single legs, :mod:`pfpeople.detect.legs`), a
     confirmed track that no classified person continued but a support position did (the tracker's step 4c,
     :class:`~pfpeople.track.multi_person.MultiPersonTracker`) is reported at its updated position on the same terms.
     Single legs never start a person: clutter that looks like one leg stays out, a tracked walker whose far leg
     is hidden stays in;
   - with ``static_confirm_s``, a track that has not moved (``Track.moved``: 0.3 m from its birth position, in
     the odometry frame) is reported only once it is ``static_confirm_s`` old: a walker is reported as soon as
     its track is confirmed, a person who stands still one second later, and a table leg that the robot drives
     past (seen for about a second, too briefly for the static-clutter map) not at all.

   ``people = "classified"`` reports the classifier's people unchanged (the paper modes' behaviour).
3. **Reported tracks** (``tracks.csv``, the result bag's tracks): the tracker's confirmed tracks. With
   ``observed_tracks_only`` (the recommended mode's default, ``[tracking] observed_tracks_only``) a track without
   a hit in this frame is left out while its predicted position lies in no cell a detector observes (behind a
   270 deg laser, beyond its range): the rule the coasting people above follow. It lives on in the tracker and
   keeps its id. Without evidence there, its constant-velocity prediction was mostly wrong. With ``see_through``
   and the frame's laser scans (``views``), a track or a coasting person without a hit in this frame is also
   left out where a laser sees through its predicted position (:mod:`pfpeople.track.free_space`).

Why, with the figures: ``docs/ablations.md``, "The reported people".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge.classifiers import PeakClassifier, People, people_cells
from gridbridge.grid import GridSpec
from gridbridge.validation import check_int, check_real
from pfpeople.sensors import Pose2D
from pfpeople.track.belief_inputs import tracker_inputs
from pfpeople.track.free_space import LaserView, seen_through
from pfpeople.track.multi_person import MultiPersonTracker, Track, TrackerConfig

__all__ = ["PEOPLE_MODES", "PeopleTracker", "TrackedFrame", "point_like", "snap_to_detections", "support_positions"]

#: What :class:`PeopleTracker` reports: the tracker-confirmed people, or every classified person.
PEOPLE_MODES = ("confirmed", "classified")


def snap_to_detections(positions: ArrayLike, detections: ArrayLike, radius: float) -> NDArray[np.float64]:
    """``positions`` ``(P, 2)`` with each one that has detections within ``radius`` (m) moved to their mean.

    Parameters
    ----------
    positions : array_like, shape (P, 2)
        People (m).
    detections : array_like, shape (D, 2)
        Detections (m, same frame).
    radius : float
        Distance (m).
    """
    pos = np.asarray(positions, dtype=float).reshape(-1, 2)
    det = np.asarray(detections, dtype=float).reshape(-1, 2)
    if not len(pos) or not len(det):
        return pos
    d = np.hypot(pos[:, None, 0] - det[None, :, 0], pos[:, None, 1] - det[None, :, 1])
    w = (d <= radius).astype(float)
    n = w.sum(axis=1)
    out = pos.copy()
    has = n > 0
    out[has] = (w[has] @ det) / n[has, None]
    return out


def _in_observed(xy: NDArray[np.float64], spec: GridSpec, observed: ArrayLike | None) -> NDArray[np.bool_]:
    """For positions ``(K, 2)`` (m, grid frame): inside the grid and, given ``observed``, in an observed cell.

    Up to 8 positions (a frame's tracks) are looked up in Python floats: :meth:`GridSpec.contains` and
    :meth:`GridSpec.flat_index`'s arithmetic (a cell index off the grid is -1 there, which reads the last cell)."""
    if len(xy) <= _FEW:
        flat = None if observed is None else np.asarray(observed, dtype=bool).ravel()  # once for every position
        return np.array([_observed_at(x, y, spec, flat) for x, y in xy.tolist()], dtype=bool)
    seen = spec.contains(xy[:, 0], xy[:, 1])
    if observed is not None and seen.any():
        seen[seen] = np.asarray(observed, dtype=bool).ravel()[spec.flat_index(xy[seen, 0], xy[seen, 1])]
    return np.asarray(seen, dtype=bool)


#: Up to this many positions :func:`_in_observed` looks up one by one.
_FEW = 8


def _observed_at(x: float, y: float, spec: GridSpec, flat: NDArray[np.bool_] | None) -> bool:
    """:func:`_in_observed` of one position (m, grid frame); ``flat``: the observed cells ``(nx ny,)``
    (row-major), None: every cell."""
    if not (spec.x0 <= x < spec.x1 and spec.y0 <= y < spec.y1):
        return False
    if flat is None:
        return True
    i, j = math.floor((x - spec.x0) / spec.resolution), math.floor((y - spec.y0) / spec.resolution)
    k = i * spec.ny + j if 0 <= i < spec.nx and 0 <= j < spec.ny else -1
    return bool(flat[k])


def _observed_or_hit(tracks: Sequence[Track], spec: GridSpec, observed: ArrayLike) -> list[Track]:
    """``tracks`` without the coasting ones (no hit in this frame) whose position is in no observed cell."""
    seen = _in_observed(np.array([[t.x, t.y] for t in tracks], dtype=float).reshape(-1, 2), spec, observed)
    return [t for t, s in zip(tracks, seen, strict=True) if t.misses == 0 or s]


def _seen_through_ids(tracks: Sequence[Track], views: Sequence[LaserView]) -> set[int]:
    """Ids of ``tracks`` whose position ``views`` see through (:func:`pfpeople.track.free_space.seen_through`)."""
    if not tracks:
        return set()
    free = seen_through(np.array([[t.x, t.y] for t in tracks]), views)
    return {t.id for t, f in zip(tracks, free, strict=True) if f}


def point_like(model: Any) -> bool:
    """Whether a detector's positions are precise enough to snap people to (its model's ``uncertainty`` is
    ``"point"``: the laser detectors; a camera's ``"gaussian"`` bearing-range error is not)."""
    return getattr(model, "uncertainty", "point") == "point"


def support_positions(
    support: Sequence[NDArray[np.float64] | None], static: Sequence[NDArray[np.bool_] | None] | None = None
) -> NDArray[np.float64]:
    """The support positions ``(K, 2)`` a tracker gets: every detector's (None: no data), less the static ones.

    Parameters
    ----------
    support : sequence of ndarray (S_k, 2) or None
        Per detector, its support positions (m, grid frame).
    static : sequence of ndarray (S_k,) of bool or None, optional
        Per detector, which of them the static-clutter map called static (None: none).
    """
    parts = []
    for k, pts in enumerate(support):
        if pts is None or not len(pts):
            continue
        flags = None if static is None else static[k]
        parts.append(np.asarray(pts, dtype=float).reshape(-1, 2)[~flags] if flags is not None else pts)
    return np.concatenate(parts).reshape(-1, 2) if parts else np.zeros((0, 2))


@dataclass(frozen=True)
class TrackedFrame:
    """One frame of :meth:`PeopleTracker.step`.

    Attributes
    ----------
    people : People
        The reported people (grid frame, m); ``mask`` holds the cells of the reported classified people only.
    tracks : list of Track
        The tracker's output (:meth:`MultiPersonTracker.confirmed`): what ``tracks.csv`` gets.
    coasted : int
        How many of ``people`` are coasting or support-continued tracks (the last ones).
    live : list of Track
        Every live track after the update (:attr:`MultiPersonTracker.tracks`), confirmed or not.
    """

    people: People
    tracks: list[Track]
    coasted: int
    live: list[Track] = field(default_factory=list)


class PeopleTracker:
    """The multi-person tracker run on a classifier's people, and the people it confirms (module docstring).

    Parameters
    ----------
    classifier : object
        The frame's classifier (its ``threshold``, and for :class:`HysteresisPeaks` its ``keep`` and
        ``rejected`` candidates, are read).
    config : TrackerConfig, optional
        Tracker parameters, used as given (a caller that wants tracks to start only from people sets
        ``birth_min_score`` to the classifier's threshold: :func:`pfpeople.pipeline.assembly.build_people_tracker`
        does).
    peak_threshold : float or None
        The belief peaks above this update tracks too (below the classifier's threshold; a peaks classifier only).
        None: the tracker gets the classified people only.
    people : {"confirmed", "classified"}
        What :meth:`step` reports (module docstring).
    coast_frames : int
        With ``"confirmed"``: a confirmed track is reported through up to this many consecutive missed frames
        (0: never).
    min_separation : float
        Smallest distance (m) between a coasting track reported and a reported person.
    use_support : bool
        With ``"confirmed"``: the ``support`` positions given to :meth:`step` continue confirmed tracks (module
        docstring); otherwise they are ignored.
    snap_radius : float
        Distance (m) within which the ``detections`` given to :meth:`step` move a person to their mean (module
        docstring); 0: never.
    static_confirm_s : float
        With ``"confirmed"``: age (s) from which a track that has not moved is reported (module docstring); 0:
        any confirmed track.
    observed_tracks_only : bool
        Leave out of the tracks a coasting track whose predicted position lies in no observed cell (module
        docstring).
    see_through : bool
        Leave out of the tracks and the people a track without a hit in this frame whose predicted position the
        ``views`` given to :meth:`step` see through (:mod:`pfpeople.track.free_space`).

    Raises
    ------
    ValueError
        An unknown ``people``, a negative ``coast_frames``, a ``peak_threshold`` outside [0, 1).
    TypeError
        A setting that is not a number (``coast_frames``: not an integer), naming it.
    """

    def __init__(
        self,
        classifier: Any,
        *,
        config: TrackerConfig | None = None,
        peak_threshold: float | None = None,
        people: str = "confirmed",
        coast_frames: int = 1,
        min_separation: float = 0.6,
        use_support: bool = True,
        snap_radius: float = 0.0,
        static_confirm_s: float = 0.0,
        observed_tracks_only: bool = False,
        see_through: bool = False,
    ) -> None:
        if people not in PEOPLE_MODES:
            raise ValueError(f"people must be one of {PEOPLE_MODES}, got {people!r}")
        self.coast_frames = check_int(coast_frames, "coast_frames", minimum=0)
        self.min_separation = check_real(min_separation, "min_separation", low=0.0)
        self.snap_radius = check_real(snap_radius, "snap_radius", low=0.0)
        self.static_confirm_s = check_real(static_confirm_s, "static_confirm_s", low=0.0)
        #: Whether :meth:`step` leaves coasting tracks outside the observed cells out of its tracks.
        self.observed_tracks_only = bool(observed_tracks_only)
        #: Whether :meth:`step` leaves out coasting tracks and people whose place its laser ``views`` see through.
        self.see_through = bool(see_through)
        self.classifier = classifier
        self.tracker = MultiPersonTracker(config)
        self.people = people
        #: Whether :meth:`step` uses its ``support`` positions.
        self.use_support = bool(use_support) and people == "confirmed"
        self._weak: PeakClassifier | None = None
        high = getattr(classifier, "threshold", None)
        if peak_threshold is not None:
            pt = check_real(peak_threshold, "peak_threshold", low=0.0, high=1.0, high_open=True)
            base = getattr(classifier, "peaks", classifier)  # HysteresisPeaks holds a PeakClassifier
            if isinstance(base, PeakClassifier) and high is not None and pt < high:
                self._weak = replace(base, threshold=pt)

    def reset(self) -> None:
        """Forget every track (a restart of the filter)."""
        self.tracker.reset()

    def _inputs(
        self, found: People, belief: NDArray[np.float64], spec: GridSpec, observed: ArrayLike | None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        pos, sc = np.asarray(found.positions, dtype=float).reshape(-1, 2), np.asarray(found.scores, dtype=float)
        weak = self._weak
        if weak is None:
            return pos, sc
        rejected = getattr(self.classifier, "rejected", None)
        keep = getattr(self.classifier, "keep", None)
        if rejected is not None and keep is not None and weak.threshold >= keep:
            # the hysteresis classifier already found the weaker peaks (its candidates it did not accept)
            sel = rejected.scores > weak.threshold
            return np.concatenate((pos, rejected.positions[sel])), np.concatenate((sc, rejected.scores[sel]))
        return tracker_inputs(found, belief, spec, low=weak, high=self.classifier.threshold, observed=observed)

    def step(
        self,
        found: People,
        belief: ArrayLike,
        spec: GridSpec,
        dt: float,
        *,
        observed: ArrayLike | None = None,
        ego: Pose2D | None = None,
        support: ArrayLike | None = None,
        detections: ArrayLike | None = None,
        views: Sequence[LaserView] | None = None,
    ) -> TrackedFrame:
        """Track this frame's people and report the confirmed ones (module docstring).

        Parameters
        ----------
        found : People
            The classifier's people of this frame (grid frame, m), classified from ``belief``.
        belief : array_like, shape (nx, ny)
            The frame's belief grid.
        spec : GridSpec
        dt : float
            Time since the previous frame (s, > 0; see :meth:`MultiPersonTracker.update`).
        observed : array_like of bool, shape (nx, ny), optional
            Cells some detector observes (as given to the classifier); None: every cell. With
            ``observed_tracks_only`` the returned tracks leave out the coasting ones outside these cells.
        ego : Pose2D, optional
            The current grid frame in the previous one.
        support : array_like, shape (K, 2), optional
            Support positions (m, grid frame) that may continue confirmed tracks (module docstring; only with
            ``use_support``).
        detections : array_like, shape (D, 2), optional
            The frame's precise detections (m, grid frame) for ``snap_radius``.
        views : sequence of (LaserScan, Pose2D), optional
            The frame's laser scans with their poses in the grid frame: with ``see_through``, a track or person
            without a hit in this frame is not reported where a laser sees through its predicted position
            (:func:`pfpeople.track.free_space.seen_through`).
        """
        grid = np.asarray(belief, dtype=float)
        pos, sc = self._inputs(found, grid, spec, observed)
        if self.snap_radius > 0 and detections is not None and len(pos):
            pos = snap_to_detections(pos, detections, self.snap_radius)
            n_found = len(found.positions)
            found = replace(found, positions=pos[:n_found])
        support = support if self.use_support else None
        self.tracker.advance(pos, dt, scores=sc, ego=ego, support=support)
        tracks, live = self.tracker.confirmed_and_live()  # one snapshot of the tracks a frame
        if self.observed_tracks_only and observed is not None and tracks:
            tracks = _observed_or_hit(tracks, spec, observed)
        gone: set[int] = set()
        if views and self.see_through:
            gone = self._seen_through(live, tracks, views)
            tracks = [t for t in tracks if t.id not in gone]
        if self.people == "classified":
            return TrackedFrame(people=found, tracks=tracks, coasted=0, live=live)
        people, coasted = self._reported(live, found, grid, spec, observed, gone)
        return TrackedFrame(people=people, tracks=tracks, coasted=coasted, live=live)

    def _seen_through(self, live: Sequence[Track], tracks: Sequence[Track], views: Sequence[LaserView]) -> set[int]:
        """The ids of the coasting tracks of ``live`` (every live track) that may be reported (as ``tracks``, or
        as people through a miss) and whose predicted place a laser of ``views`` sees through; each is tested
        once (``see_through``)."""
        may_show = [t for t in live if t.confirmed and 0 < t.misses]
        shown = {t.id for t in tracks}
        return _seen_through_ids([t for t in may_show if t.id in shown or t.misses <= self.coast_frames], views)

    def _reported(
        self,
        live: Sequence[Track],
        found: People,
        grid: NDArray[np.float64],
        spec: GridSpec,
        observed: ArrayLike | None,
        gone: set[int],
    ) -> tuple[People, int]:
        """The reported people of ``people = "confirmed"`` (step 2 of the module docstring).

        Parameters
        ----------
        live : sequence of Track
            Every live track of the tracker after this frame's update (:attr:`MultiPersonTracker.tracks`).
        found : People
            The classifier's people of this frame (after ``snap_radius``; m, grid frame).
        grid : ndarray, shape (nx, ny)
            The frame's belief grid (the coasting people's scores).
        spec : GridSpec
        observed : array_like of bool, shape (nx, ny), optional
            Cells some detector observes; None: every cell.
        gone : set of int
            Ids of tracks whose place a laser sees through (not reported through a miss).

        Returns
        -------
        people : People
            The confirmed classified people, then the coasting ones (size 0 cells).
        coasted : int
            How many of them are coasting.
        """
        n = len(found.positions)
        wait = self.static_confirm_s - 1e-9
        alive = [t for t in live if t.confirmed and (t.moved or t.age_s >= wait)]
        ok = np.zeros(n, dtype=bool)
        ok[[t.measurement for t in alive if t.misses == 0 and 0 <= t.measurement < n]] = True
        kept = np.asarray(found.positions, dtype=float).reshape(-1, 2)[ok]
        coast = self._coasting([t for t in alive if t.id not in gone], kept, spec, observed)
        coast_scores = grid.ravel()[spec.flat_index(coast[:, 0], coast[:, 1])] if len(coast) else np.zeros(0)
        mask = found.mask if ok.all() else people_cells(found.mask, spec, found.positions, ok)
        people = People(
            positions=np.concatenate((kept, coast)),
            scores=np.concatenate((np.asarray(found.scores, dtype=float)[ok], coast_scores)),
            sizes=np.concatenate((np.asarray(found.sizes, dtype=np.int64)[ok], np.zeros(len(coast), np.int64))),
            mask=mask,
        )
        return people, len(coast)

    def _coasting(
        self, alive: Sequence[Track], kept: NDArray[np.float64], spec: GridSpec, observed: ArrayLike | None
    ) -> NDArray[np.float64]:
        """Positions (K, 2) of the confirmed tracks to report through a miss (predicted) or continued by a
        support position (updated)."""
        pts = np.array(
            [[t.x, t.y] for t in alive if 1 <= t.misses <= self.coast_frames or (t.misses == 0 and t.supported)]
        ).reshape(-1, 2)
        if not len(pts):
            return pts
        pts = pts[_in_observed(pts, spec, observed)]
        if len(pts) and len(kept):
            d = np.hypot(pts[:, None, 0] - kept[None, :, 0], pts[:, None, 1] - kept[None, :, 1]).min(axis=1)
            pts = pts[d > self.min_separation]
        return pts
