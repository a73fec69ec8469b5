"""The ego-motion stage of a run: the grid frame's motion into each frame, known before the detectors run.

Per frame, first of the front end (:mod:`pfpeople.pipeline.front`):

1. frame timing and odometry (:class:`pfpeople.perception.odometry.OdometryIntegrator`: the odometry pose
   interpolated to the frame stamp, restarts after a gap or an odometry jump);
2. without an odometry pose in the frame, the driving laser's scan matcher
   (:class:`pfpeople.perception.scan_matching.LaserEgoMotion`, with its back-off) on the driver's scan: its
   motion ``E_laser`` (laser frame) becomes the grid frame's ``T E_laser T^-1`` (``T``: the driving laser's mount
   in this frame) and, with ``[clutter] laser_odometry`` and no odometry topic, the filter's ego-motion
   (:meth:`~pfpeople.perception.odometry.OdometryIntegrator.from_laser`). The match itself (known or not) is
   the driving laser's static-clutter map's ego-motion (:class:`pfpeople.pipeline.clutter_stage.ClutterStage`).

The matcher runs in the frames where the driving laser's static-clutter map steps (the run has a map on the
driver, the driver's scan converts and a detector on it is placed by TF) and has no odometry: exactly where the
map matched the scan itself before this stage existed, so the runs are the same bit for bit. Its first step is
known (the identity), as the map's first scan was.

Detectors see the result (:class:`pfpeople.detect.adapters.SensorMotion`, :mod:`pfpeople.pipeline.detection`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from gridbridge.geometry import Pose2D
from pfpeople.detect.adapters import read_scan
from pfpeople.io.bag.reader import MessageDataError
from pfpeople.io.bag.sync import Frame
from pfpeople.perception.odometry import EgoMotion, OdometryIntegrator
from pfpeople.perception.scan_matching import EgoMatch, LaserEgoMotion
from pfpeople.run_state import RunSummary

__all__ = ["EgoMotionStage", "log_ego_motion"]

log = logging.getLogger(__name__)


class EgoMotionStage:
    """Frame timing and the grid frame's ego-motion, frame by frame (see the module docstring).

    Parameters
    ----------
    integrator : OdometryIntegrator
        Frame timing and odometry; its :meth:`~OdometryIntegrator.from_laser` takes the scan-matched motion.
    matcher : LaserEgoMotion or None
        The driving laser's scan matcher (None: the run has no static-clutter map on the driving laser, and no
        scan matching).
    driver_mount : callable
        ``driver_mount(frame) -> Pose2D | None``: the driving laser's mount in the grid frame in ``frame`` (None:
        no detector on the driving laser is placed there, so its map does not step).
    """

    def __init__(
        self,
        integrator: OdometryIntegrator,
        *,
        matcher: LaserEgoMotion | None,
        driver_mount: Callable[[Frame], Pose2D | None],
    ) -> None:
        self.integrator = integrator
        self.matcher = matcher
        self.driver_mount = driver_mount
        #: Frames in which the driving laser's static-clutter map stepped.
        self.driver_steps = 0

    def reset(self) -> None:
        """Forget the previous frame (a new run); the scan matcher keeps its keyframe, as the maps do."""
        self.integrator.reset()

    def begin(self, frame: Frame) -> tuple[EgoMotion, EgoMatch | None]:
        """The motion into ``frame`` and the driving laser's scan match (None: not matched in this frame)."""
        motion = self.integrator.begin(frame)
        match = self._match(frame, matched=motion.ego is None)
        if match is not None and match[1].ok:
            mount, m = match
            motion = self.integrator.from_laser(motion, mount.compose(m.ego).compose(mount.inverse()))
        self.integrator.end(frame, motion)
        return motion, None if match is None else match[1]

    def _match(self, frame: Frame, *, matched: bool) -> tuple[Pose2D, EgoMatch] | None:
        """The driving laser's mount and scan match in ``frame`` when its map steps and ``matched`` (no odometry
        motion), else None; counts the map's steps."""
        if self.matcher is None:
            return None
        mount = self.driver_mount(frame)
        if mount is None:
            return None
        try:
            scan = read_scan(frame.driver)
        except MessageDataError:  # the detectors meet (and count) the same error: the map does not step
            return None
        first = self.driver_steps == 0
        self.driver_steps += 1
        if not matched:
            return None
        ego, ok = self.matcher.match(scan.points(), first=first)
        return mount, EgoMatch(ego, ok)


def log_ego_motion(summary: RunSummary, *, scan_matched: bool, driver: str) -> None:
    """Log where the frames' ego-motion came from; warn when scan matching gave it in under half the frames
    that could have had it (all but the first frame of the run and after each restart).

    Parameters
    ----------
    summary : RunSummary
        The run's counts (``ego_motion``, ``filter_restarts``).
    scan_matched : bool
        Whether the run's ego-motion comes from scan matching the driving laser.
    driver : str
        The driving laser's topic (named in the warning).
    """
    e = summary.ego_motion
    total = sum(e.values())
    if not total:
        return
    log.info(
        "ego-motion of %d frames: %d from odometry, %d from scan matching, %d none (the robot stood)",
        total,
        e.get("odometry", 0),
        e.get("scan_matching", 0),
        e.get("none", 0),
    )
    possible = total - 1 - summary.filter_restarts
    matched = e.get("scan_matching", 0)
    if scan_matched and possible > 0 and matched < 0.5 * possible:
        log.warning(
            "scan matching of %s gave the ego-motion of only %d of %d frames (%.0f %%): the other frames had "
            "none (for the filter the robot stood still), so wherever it moved then, the grid and the tracks "
            "moved with it (an odometry topic would give the motion)",
            driver,
            matched,
            possible,
            100.0 * matched / possible,
        )
