"""The past scans a temporal model sees, kept aligned with the current laser frame by the ego-motion.

The memory holds the last ``past_scans * past_step`` scans, each with the pose of the *current* laser frame in that
scan's frame (m, rad). When a scan arrives with the laser frame's motion since the previous scan (``motion``: the
new frame in the previous one), every pose is composed with it, ``pose_k <- pose_k * motion``, and the previous scan
joins with pose ``motion``. Without a motion (unknown: an odometry gap, a failed scan match) the memory is emptied.

A model with ``past_scans = T`` and ``past_step = s`` sees the scans ``s, 2 s, ..., T s`` frames back; where the
memory has none yet (the first scans) the current scan stands in (as in training, where the first scans of every
recording have the same gap). The network's input is the current scan's cut-outs
(:func:`pfpeople.detect.learned.cutouts.cutouts`), per past scan the cut-outs of that scan around the same points
moved into its frame, and, with ``motion``, the cut-outs of the returns the motion detector calls moved
(:mod:`pfpeople.detect.motion`: 1 where a return lies in space the scans of 0.2-0.6 s before saw free, 0 elsewhere).
"""

from __future__ import annotations

from collections import deque

import numpy as np
from numpy.typing import NDArray

from gridbridge.geometry import Pose2D
from pfpeople.detect.learned.cutouts import CutoutParams, beam_cutouts, centre_beams, cutouts
from pfpeople.detect.motion import MotionDetector
from pfpeople.sensors import LaserScan

__all__ = ["ScanMemory"]


class ScanMemory:
    """Past scans aligned with the current frame (module docstring).

    Parameters
    ----------
    past_scans : int
        Past scans the model sees (0: none).
    past_step : int
        Frames between them.
    """

    def __init__(self, past_scans: int = 0, past_step: int = 1, *, motion: bool = False) -> None:
        if past_scans < 0 or past_step < 1:
            raise ValueError(f"past_scans must be >= 0 and past_step >= 1, got {past_scans}, {past_step}")
        self.past_scans = int(past_scans)
        self.past_step = int(past_step)
        #: The motion detector whose moved returns are an input channel (None: no motion input).
        self.motion = MotionDetector() if motion else None
        self._moved: NDArray[np.bool_] | None = None
        self._past: deque[tuple[LaserScan, Pose2D]] = deque(maxlen=max(1, past_scans * past_step))
        self._latest: LaserScan | None = None

    def clear(self) -> None:
        """Forget every scan."""
        self._past.clear()
        self._latest = None
        if self.motion is not None:
            self.motion.reset()

    def advance(self, scan: LaserScan, motion: Pose2D | None) -> None:
        """``scan`` becomes the current scan; ``motion`` is the laser frame's motion since the previous one."""
        if self.motion is not None:
            self.motion.observe_motion(motion)
            self._moved = self.motion.moved_beams(scan)
        if not self.past_scans:
            return
        prev = self._latest
        if motion is None:
            self._past.clear()
        elif prev is not None:
            moved = [(s, pose.compose(motion)) for s, pose in self._past]
            self._past.clear()
            self._past.append((prev, motion))
            self._past.extend(moved[: (self._past.maxlen or 1) - 1])
        self._latest = scan

    def inputs(self, scan: LaserScan, cut: CutoutParams) -> tuple[NDArray[np.intp], NDArray[np.float32]]:
        """The looked-at beams ``(C,)`` of the current ``scan`` and the network input
        ``(C, cut.points, 1 + past_scans)``."""
        idx = centre_beams(scan, cut)
        bearing, rng = scan.angles[idx], scan.ranges[idx]
        channels = [cutouts(scan, bearing, rng, cut)]
        if self.past_scans:
            pts = np.column_stack((rng * np.cos(bearing), rng * np.sin(bearing)))
            for k in range(self.past_scans):
                j = (k + 1) * self.past_step - 1
                if j >= len(self._past):
                    channels.append(channels[0])
                    continue
                past, pose = self._past[j]
                q = pose.apply(pts)
                channels.append(cutouts(past, np.arctan2(q[:, 1], q[:, 0]), np.hypot(q[:, 0], q[:, 1]), cut))
        if self.motion is not None:
            moved = self._moved if self._moved is not None else np.zeros(scan.ranges.size, dtype=bool)
            channels.append(beam_cutouts(scan, moved.astype(np.float64), bearing, rng, cut))
        return idx, np.stack(channels, axis=-1)

    @property
    def channels(self) -> int:
        """Input channels: the current scan, the past scans, the moved returns."""
        return 1 + self.past_scans + (self.motion is not None)
