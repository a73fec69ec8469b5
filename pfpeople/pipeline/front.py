"""The front end of a frame: ego-motion, then the detectors, then the static-clutter maps.

It needs only the frame's messages and its own state, never the filter's, so it can run ahead of the back end in
another process (:mod:`pfpeople.pipeline.front_end`) and a live node can run it as the scans arrive. Per frame:

1. the mounts are advanced to the frame's stamp (:mod:`pfpeople.pipeline.mounts`);
2. the ego-motion stage (:mod:`pfpeople.pipeline.ego_stage`): frame timing, odometry and, without it, the driving
   laser's scan matching; a restart (a gap, an odometry jump) forgets the static-clutter maps;
3. the detectors (:mod:`pfpeople.pipeline.detection`), those that declare ``uses_ego_motion`` with the motion of
   step 2;
4. the static-clutter maps of the laser topics (:mod:`pfpeople.pipeline.clutter_stage`), each moved by the
   ego-motion of step 2, suppress the detections on static clutter;
5. with ``[output] frame``, the grid frame's pose in the output frame (:mod:`pfpeople.pipeline.output_frame`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from gridbridge.geometry import Pose2D
from pfpeople.detect.adapters import Detections
from pfpeople.io.bag.sync import Frame
from pfpeople.perception.odometry import EgoMotion
from pfpeople.pipeline.clutter_stage import ClutterStage
from pfpeople.pipeline.detection import DetectionStage
from pfpeople.pipeline.ego_stage import EgoMotionStage
from pfpeople.pipeline.mounts import MountTracker
from pfpeople.pipeline.output_frame import OutputFrame

__all__ = ["FrontEnd", "FrontResult"]


@dataclass
class FrontResult:
    """The front end's result for one frame (grid frame, m).

    Attributes
    ----------
    motion : EgoMotion
        Time step and ego-motion into the frame (the scan-matched motion when it gave the controls).
    found : list of Detections or None
        Per detector (configuration order), its output; None: no data in the frame.
    dets : list of ndarray (M_k, 2) or (M_k, 3), or None
        Per detector, the detections the filter gets (static clutter removed; with each one's PPV for a detector
        calibrated by score, :attr:`Detections.fused`).
    static : list of ndarray (M_k,) of bool or None
        Per detector, the detections the static-clutter map suppressed (None: no suppression).
    support_static : list of ndarray (S_k,) of bool or None
        Per detector, which support positions (single legs) the static-clutter map called static.
    scan_static : dict of str to ndarray of bool
        Per laser topic with a static-clutter map, which of its scan's end points lie in static cells
        (:attr:`pfpeople.pipeline.clutter_stage.ClutterStage.scan_static`).
    mounts : tuple of Pose2D
        Per detector, the mount it was placed with in this frame (:mod:`pfpeople.pipeline.mounts`; empty: unchanged).
    output_pose : Pose2D or None
        The grid frame's pose in the output frame (None: no ``[output] frame``, or unknown in this frame).
    """

    motion: EgoMotion
    found: list[Detections | None]
    dets: list[NDArray[np.float64] | None]
    static: list[NDArray[np.bool_] | None]
    support_static: list[NDArray[np.bool_] | None]
    scan_static: dict[str, NDArray[np.bool_]] = field(default_factory=dict)
    mounts: tuple[Pose2D, ...] = ()
    output_pose: Pose2D | None = None


class FrontEnd:
    """A frame's front end (see the module docstring); call it on each frame in order.

    Parameters
    ----------
    ego : EgoMotionStage
        Frame timing and ego-motion.
    detection : DetectionStage
        The detectors.
    clutter : ClutterStage
        The static-clutter maps.
    mounts : MountTracker or None
        The mounts followed over TF (None: the mounts read before the run hold).
    output : OutputFrame, optional
        The output frame (None: the results stay in the grid frame).
    """

    def __init__(
        self,
        ego: EgoMotionStage,
        detection: DetectionStage,
        clutter: ClutterStage,
        mounts: MountTracker | None,
        output: OutputFrame | None = None,
    ) -> None:
        self.ego = ego
        self.detection = detection
        self.clutter = clutter
        self.mounts = mounts
        self.output = output

    def __call__(self, frame: Frame) -> FrontResult:
        """The front end's result for ``frame``."""
        if self.mounts is not None:
            self.mounts.advance(frame.stamp_ns)
        motion, match = self.ego.begin(frame)
        if motion.restarted:
            self.clutter.reset()
        found = self.detection.detect(frame, motion)
        static: list[NDArray[np.bool_] | None] = [None] * len(found)
        sup_static: list[NDArray[np.bool_] | None] = [None] * len(found)
        scan_static: dict[str, NDArray[np.bool_]] = {}
        if self.clutter.active:  # the filter's entries less the static detections
            dets, static = self.clutter.step(found, motion.ego, motion.dt, frame.stamp_ns, match)
            sup_static = list(self.clutter.support_static)
            scan_static = dict(self.clutter.scan_static)
        else:
            dets = [None if f is None else f.fused for f in found]
        return FrontResult(
            motion=motion,
            found=found,
            dets=dets,
            static=static,
            support_static=sup_static,
            scan_static=scan_static,
            mounts=tuple(a.mount for a in self.detection.adapters),
            output_pose=None if self.output is None else self.output.pose(frame, motion),
        )
