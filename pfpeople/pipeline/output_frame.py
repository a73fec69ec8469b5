"""Results in a fixed frame (``[output] frame``, e.g. ``"odom"``): the grid frame's pose there, frame by frame.

The grid moves with the robot; a planner wants people and tracks in a frame that does not (leg_tracker publishes
them in ``odom``). Per frame, the grid frame's pose ``P`` in the output frame comes from

1. the odometry, when the output frame is the frame of the frame's odometry messages (their ``header.frame_id``):
   the grid frame's odometry pose interpolated to the frame stamp (:mod:`pfpeople.perception.odometry`: the same
   pose the filter's ego-motion comes from);
2. else TF (``/tf``, ``/tf_static``): the latest transforms at or before the frame stamp along the chain from the
   output frame to the grid frame (:class:`pfpeople.io.bag.tf.MountFollower`);
3. else it is unknown in that frame: the results have no output-frame position there (NaN in the run directory's
   ``out_*`` columns, no people or tracks message in the result bag or from the node), counted in ``run.json``
   ``stats.output_unplaced`` and warned once.

A position ``p`` (grid frame) is ``P p`` in the output frame, a velocity ``v`` is ``R v`` and a covariance ``C``
is ``R C R^T`` (``R`` the rotation of ``P``; the tracks' ``(x, y, vx, vy)`` covariance by ``diag(R, R)``).
The grid itself stays in the grid frame.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge.geometry import Pose2D
from pfpeople.io.bag.sync import Frame
from pfpeople.io.bag.tf import MountFollower, TfBuffer, TfLookupError
from pfpeople.perception.odometry import EgoMotion
from pfpeople.run_state import RunSummary, WarnOnce

__all__ = ["OutputFrame", "positions_in", "results_in", "tracks_in"]

log = logging.getLogger(__name__)


def positions_in(pose: Pose2D, positions: ArrayLike) -> NDArray[np.float64]:
    """``(P, 2)`` positions (m, grid frame) in the frame where the grid frame's pose is ``pose``."""
    xy = np.asarray(positions, dtype=float).reshape(-1, 2)
    return pose.apply(xy) if len(xy) else np.zeros((0, 2))


def tracks_in(pose: Pose2D, tracks: Sequence[Any]) -> list[Any]:
    """The tracks (:class:`pfpeople.track.Track`, grid frame) in the frame where the grid frame's pose is ``pose``:
    positions moved, velocities and the ``(x, y, vx, vy)`` covariance rotated."""
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    rot = np.array([[c, -s], [s, c]])
    block = np.zeros((4, 4))
    block[:2, :2] = block[2:, 2:] = rot
    out = []
    for t in tracks:
        (x, y), (vx, vy) = pose.apply(np.array([[t.x, t.y]]))[0], rot @ np.array([t.vx, t.vy])
        cov = np.asarray(t.covariance, dtype=float)
        rc = block[: len(cov), : len(cov)]
        out.append(replace(t, x=float(x), y=float(y), vx=float(vx), vy=float(vy), covariance=rc @ cov @ rc.T))
    return out


def results_in(result: Any, *, output: bool) -> tuple[NDArray[np.float64] | None, list[Any] | None]:
    """The people ``(P, 2)`` and tracks of a :class:`~pfpeople.run_state.FrameResult` to publish: as they are (grid
    frame) without an ``output`` frame, else in the output frame (:attr:`FrameResult.output_pose`), or
    ``(None, None)`` where the pose there is unknown (tracks None also when the run has none)."""
    people, tracks = result.people, result.tracks
    if not output:
        return people, tracks
    pose = result.output_pose
    if pose is None:
        return None, None
    return positions_in(pose, people), None if tracks is None else tracks_in(pose, tracks)


class OutputFrame:
    """The grid frame's pose in the output frame, frame after frame (see the module docstring).

    Parameters
    ----------
    frame : str
        The output frame.
    tf : TfBuffer
        The transforms read before the run.
    grid_frame : str
        The run's grid frame.
    odometry_topic : str
        The run's odometry topic (``""``: none).
    summary : RunSummary
        Where ``output_unplaced`` is counted.
    warn : WarnOnce
        The run's warn-once logger.
    """

    def __init__(
        self, frame: str, *, tf: TfBuffer, grid_frame: str, odometry_topic: str, summary: RunSummary, warn: WarnOnce
    ) -> None:
        self.frame = frame
        self.odometry_topic = odometry_topic
        self.follower = MountFollower(tf, grid_frame, frames=[frame])
        self.summary = summary
        self.warn = warn
        self.grid_frame = grid_frame
        summary.output_unplaced = 0

    def add(self, msg: object, topic: str) -> None:
        """A TF message read during the run."""
        self.follower.add(msg, topic=topic)

    def pose(self, frame: Frame, motion: EgoMotion) -> Pose2D | None:
        """The grid frame's pose in the output frame at ``frame``'s stamp (None: unknown, counted)."""
        odometry = frame.inputs.get(self.odometry_topic, []) if self.odometry_topic else []
        if motion.pose is not None and odometry and odometry[0].frame_id == self.frame:
            return motion.pose
        self.follower.advance(frame.stamp_ns)
        try:
            return self.follower.mount(self.frame).inverse()
        except TfLookupError as exc:
            self.summary.output_unplaced = (self.summary.output_unplaced or 0) + 1
            self.warn(
                "output-frame",
                "[output] frame %r: no pose of the grid frame %r in it at frame %d (neither odometry in that frame "
                "nor TF: %s); the frame's people and tracks have no position there (counted in "
                "stats.output_unplaced)",
                self.frame,
                self.grid_frame,
                frame.index,
                exc,
                logger=log,
            )
            return None
