"""People the tracker saw walk and then stop: the static-clutter map's suppression lifted where they stopped.

The static-clutter map (:mod:`pfpeople.perception.clutter_map`) calls a place static once it has been occupied for
some time, so a person who walks up and stops becomes "furniture" a second or so later and their detections are
suppressed. What tells the two apart is history: a person who stops walked there, and the map let their detections
through while they walked (it had not seen the place occupied); a chair's detections are static from the first
sight (the map's unknown prior), and a chair's or a pillar's track does not walk.

:class:`StoppedPeople` gives each track an *anchor*, the place it stopped at, from two rules applied after each
tracker update:

1. a confirmed track that has moved (``Track.moved``) and walks (its speed estimate :data:`WALKING_MPS` or more)
   with a detection the map let through within :data:`ANCHOR_RADIUS` is anchored at its position, not stopped;
2. an anchored track that does not walk, is within :data:`ANCHOR_RADIUS` of its anchor and has such a detection
   within :data:`ANCHOR_RADIUS` has *stopped* there: its anchor moves to its position (a person slowing down, or
   shuffling while they stand).

Only the anchors of tracks that stopped readmit detections. A walker's track handed over to a chair or a pillar it
passed slows down where no detection is let through (the object's are static): it never stops. A track that leaves
its anchor without walking keeps it but cannot move it.
Anchors are moved into each new grid frame with the ego-motion, like the tracks, and are forgotten with their track.
A detection the map calls static within :data:`ANCHOR_RADIUS` of an anchor is *readmitted*: the filter sees it. The
loop this makes (readmitted detections keep the track alive, the track keeps its anchor) holds only while something
stands at the anchor: when the person leaves, the place is seen free and the detections there stop.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from gridbridge.geometry import to_frame
from pfpeople.sensors import Pose2D
from pfpeople.track.multi_person import Track

__all__ = ["ANCHOR_RADIUS", "WALKING_MPS", "StoppedPeople"]

#: Radius (m) around a track within which a let-through detection anchors it, around an anchor within which the
#: track may move it and a static detection is readmitted: the benchmark's person radius (a detection within 0.3 m
#: of a person is that person's), wider than a standing person's detection jitter (0.05-0.1 m), narrower than the
#: distance at which walkers pass furniture.
ANCHOR_RADIUS = 0.3
#: Speed (m/s) of a track's Kalman estimate at which it walks: people walk at 1.46 +- 0.63 m/s (the paper's people
#: motion model); the tracks of chairs and pillars jitter at 0.3 m/s and less.
WALKING_MPS = 0.5


class StoppedPeople:
    """The anchors of the tracks that walked and stopped (module docstring); grid frame of the latest frame."""

    def __init__(self) -> None:
        #: track id -> (x, y, stopped): the anchor (m, grid frame) and whether the track stopped there (rule 2)
        self._anchor: dict[int, tuple[float, float, bool]] = {}

    def __len__(self) -> int:
        """The number of anchored tracks, stopped or not (:attr:`anchors` holds the stopped ones only)."""
        return len(self._anchor)

    @property
    def anchors(self) -> NDArray[np.float64]:
        """``(A, 2)`` anchor positions (m, current grid frame) of the tracks that stopped (rule 2), in the order the
        tracks were anchored."""
        return np.array([(x, y) for x, y, stopped in self._anchor.values() if stopped], dtype=float).reshape(-1, 2)

    def reset(self) -> None:
        """Forget every anchor (the tracker restarts)."""
        self._anchor = {}

    def move(self, ego: Pose2D | None) -> None:
        """Move the anchors into the new grid frame.

        Parameters
        ----------
        ego : Pose2D or None
            Pose of the new grid frame in the previous one (m, m, rad); None: the robot stood still. The convention
            of :meth:`pfpeople.track.multi_person.MultiPersonTracker.update`'s ``ego``.
        """
        if ego is None or not self._anchor or (ego.x == 0.0 and ego.y == 0.0 and ego.yaw == 0.0):
            return
        xy = to_frame([(x, y) for x, y, _ in self._anchor.values()], ego).tolist()
        self._anchor = {tid: (x, y, a[2]) for (tid, a), (x, y) in zip(self._anchor.items(), xy, strict=True)}

    def readmit(self, static_positions: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Which of the detections the map calls static lie within :data:`ANCHOR_RADIUS` of an anchor.

        Parameters
        ----------
        static_positions : ndarray, shape (M, 2)
            Detections the map called static (m, current grid frame).

        Returns
        -------
        ndarray, shape (M,), bool
            True where the detection is readmitted.
        """
        pts = np.asarray(static_positions, dtype=float).reshape(-1, 2)
        anchors = self.anchors
        if not len(anchors) or not len(pts):
            return np.zeros(len(pts), dtype=bool)
        d2 = ((pts[:, None, :] - anchors[None, :, :]) ** 2).sum(axis=2)
        return np.asarray((d2 <= ANCHOR_RADIUS**2).any(axis=1), dtype=bool)

    def update(self, tracks: Sequence[Track], let_through: NDArray[np.float64]) -> None:
        """Anchor the tracks after the frame's tracker update (rules 1 and 2 of the module docstring).

        Parameters
        ----------
        tracks : sequence of Track
            The tracker's live tracks after the update (current grid frame); the anchors of tracks no longer among
            them are forgotten.
        let_through : ndarray, shape (D, 2)
            The frame's detections the map let through (not static, not readmitted; m, current grid frame).
        """
        pts = np.asarray(let_through, dtype=float).reshape(-1, 2)
        r2 = ANCHOR_RADIUS**2
        out: dict[int, tuple[float, float, bool]] = {}
        for t in tracks:
            old = self._anchor.get(t.id)
            if old is not None:
                out[t.id] = old
            if not len(pts) or not (((pts[:, 0] - t.x) ** 2 + (pts[:, 1] - t.y) ** 2) <= r2).any():
                continue
            if t.confirmed and t.moved and math.hypot(t.vx, t.vy) >= WALKING_MPS:
                out[t.id] = (t.x, t.y, False)  # rule 1: walks, not (yet) stopped
            elif old is not None and (old[0] - t.x) ** 2 + (old[1] - t.y) ** 2 <= r2:
                out[t.id] = (t.x, t.y, True)  # rule 2: stopped there
        self._anchor = out
