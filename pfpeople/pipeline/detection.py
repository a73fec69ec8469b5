"""The detection stage of a run: each detector's input messages in a frame -> its positions, or no data.

Per detector (:mod:`pfpeople.detect.adapters`), in the configuration's order: its input message is chosen by its
sync policy (:mod:`pfpeople.io.bag.sync`); a detector whose input is missing (nothing within the tolerance),
empty (a LaserScan with no beams) or unusable (the converters raise
:class:`~pfpeople.io.bag.reader.MessageDataError`) has **no data** in the frame: its entry is None and the filter
treats it as covering no cell (counted in ``run.json`` ``stats`` and warned once). A ``topic`` detector with
``assign = "preceding"`` and no message in the frame detected nobody (an empty array). Any other exception from a
detector is a bug: it ends the run.

Before a detector runs it is placed with its frame's TF mount at the frame's stamp (:mod:`pfpeople.pipeline.mounts`);
an adapter that declares ``uses_ego_motion`` gets the motion of its sensor frame
(:class:`pfpeople.detect.adapters.SensorMotion`) from the ego-motion stage (:mod:`pfpeople.pipeline.ego_stage`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gridbridge.geometry import Pose2D
from pfpeople.detect.adapters import Detections, DetectorAdapter, EmptyInputError, SensorMotion
from pfpeople.io.bag.reader import BadScanError, BagMessage, MessageDataError
from pfpeople.io.bag.sync import Frame
from pfpeople.perception.odometry import EgoMotion
from pfpeople.pipeline.mounts import MountTracker
from pfpeople.run_state import RunSummary, WarnOnce, count

__all__ = ["DetectionStage"]


class DetectionStage:
    """The run's detectors on one frame at a time (see the module docstring).

    Parameters
    ----------
    adapters : sequence of DetectorAdapter
        The run's detectors, in the configuration's order.
    driver : str
        The topic driving the frames (its detectors read the frame's driving message).
    mounts : MountTracker or None
        Places each detector in each frame (None: the mounts read before the run hold).
    summary : RunSummary
        Where ``no_data``, ``empty_scans``, ``bad_messages`` and ``bad_scans`` are counted.
    warn : WarnOnce
        The run's warn-once logger.
    """

    def __init__(
        self,
        adapters: Sequence[DetectorAdapter],
        *,
        driver: str,
        mounts: MountTracker | None,
        summary: RunSummary,
        warn: WarnOnce,
    ) -> None:
        self.adapters = list(adapters)
        self.driver = driver
        self.mounts = mounts
        self.summary = summary
        self.warn = warn

    def _inputs(self, adapter: DetectorAdapter, frame: Frame) -> list[BagMessage]:
        topic = adapter.config.topic
        return [frame.driver] if topic == self.driver else frame.inputs.get(topic, [])

    def driver_mount(self, frame: Frame) -> Pose2D | None:
        """The mount of the first detector on the driving topic that is placed in ``frame`` (None: none is)."""
        for k, a in enumerate(self.adapters):
            if a.config.topic != self.driver:
                continue
            mount = a.mount if self.mounts is None else self.mounts.peek(k, a, frame.driver)
            if mount is not None:
                return mount
        return None

    def detect(self, frame: Frame, motion: EgoMotion) -> list[Detections | None]:
        """Every detector's output in ``frame`` (None: no data), ``motion`` given to those that use it."""
        return [self._detect(k, a, frame, motion) for k, a in enumerate(self.adapters)]

    def _detect(self, k: int, adapter: DetectorAdapter, frame: Frame, motion: EgoMotion) -> Detections | None:
        """One detector's output in ``frame``; None when it has no data there (counted, warned once)."""
        d = adapter.config
        msgs = self._inputs(adapter, frame)
        if not msgs:
            if adapter.nobody_when_missing:
                nobody = np.zeros((0, 2))
                return Detections(nobody, nobody)
            count(self.summary.no_data, d.name)
            self.warn(
                f"nodata:{d.name}",
                "detector %s: no %s message within the tolerance of frame %d "
                "(it covers no cell in such frames; counted)",
                d.name,
                d.topic,
                frame.index,
            )
            return None
        if self.mounts is not None and not self.mounts.place(k, adapter, msgs[0]):
            count(self.summary.no_data, d.name)
            return None
        try:
            if getattr(adapter, "uses_ego_motion", False):
                return adapter.detect(msgs, motion=_sensor_motion(adapter.mount, frame, motion))  # type: ignore[call-arg]
            return adapter.detect(msgs)
        except MessageDataError as exc:  # bad data only: a bug in a detector propagates
            self._no_data(adapter, exc)
        return None

    def _no_data(self, adapter: DetectorAdapter, exc: MessageDataError) -> None:
        """Count (and warn once about) a detector's unusable input."""
        d, s = adapter.config, self.summary
        if isinstance(exc, EmptyInputError):
            count(s.empty_scans, d.name)
            count(s.no_data, d.name)
            self.warn(
                f"empty:{d.name}",
                "topic %s: empty LaserScan (no beams) at %d ns; detector %s has no data in such frames (counted)",
                exc.topic,
                exc.stamp_ns,
                d.name,
            )
            return
        count(s.bad_messages, d.name)
        count(s.no_data, d.name)
        if isinstance(exc, BadScanError):  # one warning per topic and reason: the message names the topic
            count(s.bad_scans.setdefault(d.name, {}), exc.reason)
            self.warn(
                f"badscan:{d.topic}:{exc.reason}",
                "detector %s: unusable input (%s); the detectors on %s have no data in such frames (they cover "
                "no cell; counted in stats.bad_messages and stats.bad_scans.%s)",
                d.name,
                exc,
                d.topic,
                exc.reason,
            )
            return
        self.warn(f"bad:{d.name}", "detector %s: unusable input (%s); no data in such frames (counted)", d.name, exc)


def _sensor_motion(mount: Pose2D, frame: Frame, motion: EgoMotion) -> SensorMotion:
    """The motion of a sensor mounted at ``mount`` (grid frame) into ``frame``: ``T^-1 E T``."""
    ego = motion.motion
    return SensorMotion(
        ego=None if ego is None else mount.inverse().compose(ego).compose(mount),
        dt=motion.dt,
        stamp_ns=frame.stamp_ns,
        restarted=motion.first or motion.restarted,
    )
