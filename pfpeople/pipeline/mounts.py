"""Mounts followed during a run: each detector placed with its frame's TF mount at the frame's stamp.

:class:`MountTracker` is the pipeline's part of this (:mod:`pfpeople.pipeline.runner`). The TF messages read along the
frames go to a :class:`pfpeople.io.bag.tf.MountFollower`; before a frame's detectors run, the follower is advanced
to the frame's stamp and each detector's mount is looked up for the frame its message is in:

- the detector's configured ``frame``, else the message's ``frame_id``, else the grid frame (as before the run);
- a mount that moved (a panning laser) is used for that frame: the detections are placed with it, and the filter's
  model of the detector gets it too (its field of view follows); frames placed with a mount other than the one
  read before the run are counted per detector in ``stats.mounts_followed``;
- a transform read during the run that is broken (a NaN or infinite translation, a zero or non-finite quaternion:
  refused before the run, :meth:`pfpeople.io.bag.tf.TfBuffer.add_message`) is left out, its edge keeping its last
  good transform: counted per edge in ``stats.bad_transforms`` and warned once per edge;
- a message whose ``frame_id`` differs from the detector's first one (two lasers on one topic, a renamed frame) is
  placed by its own frame's TF mount, counted in ``stats.frame_id_changes`` and warned once per detector; when TF
  does not connect that frame to the grid frame the detector has no data in the frame (counted in ``no_data`` and
  ``stats.frame_id_unplaced``, warned once), as its positions could be anywhere.

Not followed: detectors whose ``[detectors.model]`` gives the mount (``mount_x``, ``mount_y``, ``mount_yaw``), self-
mounted detectors (HOG, placed by its ``mounting``), and the grid frame's mount on the base frame that odometry
uses (:mod:`pfpeople.perception.odometry`), which keeps the value read before the run.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Any

from pfpeople.detect.adapters import DetectorAdapter
from pfpeople.io.bag.reader import BagMessage
from pfpeople.io.bag.tf import MountFollower, TfBuffer, TfLookupError
from pfpeople.run_state import RunSummary, WarnOnce, count
from pfpeople.sensors import Pose2D

__all__ = ["MountTracker"]

_MOUNT_KEYS = ("mount_x", "mount_y", "mount_yaw")


class MountTracker:
    """Places a run's detectors frame by frame (see the module docstring).

    Parameters
    ----------
    tf : TfBuffer
        The transforms read before the run.
    grid_frame : str
        The run's grid frame.
    adapters : sequence of DetectorAdapter
        The run's detectors, with the mounts read before the run.
    first : mapping of str to BagMessage
        The first message of each topic (its frame is each detector's first frame).
    summary : RunSummary
        Where the counts go.
    warn : WarnOnce
        The run's warn-once logger.
    """

    def __init__(
        self,
        tf: TfBuffer,
        grid_frame: str,
        adapters: Sequence[DetectorAdapter],
        first: dict[str, BagMessage],
        summary: RunSummary,
        warn: WarnOnce,
    ) -> None:
        self.grid_frame = grid_frame
        self.summary, self.warn = summary, warn
        self.initial = [a.mount for a in adapters]
        self.frames = [
            a.config.frame or (first[a.config.topic].frame_id if a.config.topic in first else "") or grid_frame
            for a in adapters
        ]
        self.follower = MountFollower(tf, grid_frame, frames=self.frames)
        self.fixed = [bool(getattr(a, "self_mounted", False)) or a.config.model.gives_mount for a in adapters]

    def add(self, msg: object, topic: str) -> None:
        """A TF message read during the run; its broken transforms (NaN, a zero quaternion) are left out, counted
        per edge in ``stats.bad_transforms`` and warned once per edge."""
        for edge in self.follower.add(msg, topic=topic):
            count(self.summary.bad_transforms, edge)
            self.warn(
                f"badtf:{edge}",
                "topic %r: transform %s is not finite (a NaN or infinite translation, a zero or non-finite "
                "quaternion): left out, the edge keeps its last good transform (counted in stats.bad_transforms)",
                topic,
                edge,
            )

    def advance(self, stamp_ns: int) -> None:
        """Apply the transforms stamped at or before a frame's stamp (call before the frame's detectors)."""
        self.follower.advance(stamp_ns)

    def peek(self, k: int, adapter: DetectorAdapter, msg: BagMessage) -> Pose2D | None:
        """The mount :meth:`place` gives detector ``k`` for ``msg`` (None: its frame has no mount), without placing
        it or counting (the ego-motion stage asks before the detectors run)."""
        frame = adapter.config.frame or msg.frame_id or self.grid_frame
        if frame == self.frames[k] and self.fixed[k]:
            return adapter.mount
        try:
            return self.follower.mount(frame)
        except TfLookupError:
            if frame != self.frames[k]:
                return None
            raise

    def place(self, k: int, adapter: DetectorAdapter, msg: BagMessage) -> bool:
        """Set detector ``k``'s mount (and model mount) for a frame whose input is ``msg``; False when its frame
        has no mount (the detector has no data in the frame: counted, warned once)."""
        d = adapter.config
        frame = d.frame or msg.frame_id or self.grid_frame
        if frame != self.frames[k]:
            count(self.summary.frame_id_changes, d.name)
            try:
                mount = self.follower.mount(frame)
            except TfLookupError as exc:
                count(self.summary.frame_id_unplaced, d.name)
                self.warn(
                    f"frameid-unplaced:{d.name}",
                    "detector %s: topic %s has a message in frame %r, not its first frame %r, and TF does not place "
                    "that frame (%s); such messages are no data (counted in stats.frame_id_unplaced)",
                    d.name,
                    d.topic,
                    frame,
                    self.frames[k],
                    exc,
                )
                return False
            self.warn(
                f"frameid:{d.name}",
                "detector %s: topic %s has messages in frame %r besides its first frame %r (two lasers on one topic, "
                "or a renamed frame): each is placed by its own frame's TF mount (counted in stats.frame_id_changes)",
                d.name,
                d.topic,
                frame,
                self.frames[k],
            )
        elif self.fixed[k]:
            return True
        else:
            mount = self.follower.mount(frame)
        if mount != self.initial[k]:
            count(self.summary.mounts_followed, d.name)
        set_mount(adapter, mount)
        return True


def set_mount(adapter: DetectorAdapter, mount: Pose2D) -> bool:
    """Give ``adapter`` (and its model) ``mount``; True when it changed."""
    if mount == adapter.mount:
        return False
    adapter.mount = mount
    adapter.model = replace(adapter.model, mount_x=mount.x, mount_y=mount.y, mount_yaw=mount.yaw)
    return True


def remount(adapters: Sequence[DetectorAdapter], mounts: Sequence[Pose2D], filt: Any) -> None:
    """Give the back end's ``adapters`` and the filter's detector models the ``mounts`` the front end used."""
    for a, m in zip(adapters, mounts, strict=True):
        set_mount(a, m)
    set_models = getattr(filt, "set_detector_mounts", None)  # a filter from a custom factory may not move
    models = getattr(filt, "detectors", ())
    want = [(a.model.mount_x, a.model.mount_y, a.model.mount_yaw) for a in adapters]  # a configured mount kept
    if set_models is not None and [(d.mount_x, d.mount_y, d.mount_yaw) for d in models] != want:
        set_models(want)
