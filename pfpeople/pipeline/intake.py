"""Message intake of a run: messages in arrival order -> synchronised frames; TF -> the mounts followed.

Every message of a run goes through :meth:`FrameIntake.push`, as a bag reader or a live subscriber delivers it:

- a TF message (a ``[tf] topics`` topic) goes to the mounts followed over TF time
  (:class:`pfpeople.pipeline.mounts.MountTracker`), to the output frame's TF (:mod:`pfpeople.pipeline.output_frame`)
  and, when ``watch`` is on, its transforms of the mounts' edges are
  checked against the values read before the run (a mount that moves is warned once per edge and counted in
  ``stats.mount_changes``);
- any other message goes to the frame assembler (:class:`pfpeople.io.bag.sync.FrameAssembler`): the driver's
  messages make the frames, the detectors' topics join them by their ``assign`` policy, the odometry by
  interpolation. With ``time_source = "bag"`` a message's stamp is its record (arrival) time.

:meth:`FrameIntake.push` returns the frames the message completed (often none, sometimes several);
:meth:`FrameIntake.finish` the frames still pending at the end.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Iterator
from dataclasses import replace

from pfpeople.config import BagConfig
from pfpeople.io.bag.reader import BagMessage
from pfpeople.io.bag.sync import Frame, FrameAssembler
from pfpeople.io.bag.tf import MountWatch
from pfpeople.pipeline.mounts import MountTracker
from pfpeople.pipeline.output_frame import OutputFrame
from pfpeople.run_state import RunSummary, WarnOnce, count

__all__ = ["FrameIntake", "sync_policies"]

log = logging.getLogger(__name__)


def sync_policies(config: BagConfig) -> dict[str, str]:
    """How each non-driver topic joins the frames: the detectors' ``assign``, the odometry interpolated.

    Raises
    ------
    ValueError
        For a topic given two policies, or an odometry topic that is also a detector or the driver topic.
    """
    c = config
    policies: dict[str, str] = {}
    for d in c.detectors:
        if d.topic != c.driver:
            old = policies.setdefault(d.topic, d.assign)
            if old != d.assign:
                raise ValueError(f"topic {d.topic!r} is given two sync policies ({old!r}, {d.assign!r})")
    if c.odometry:
        if c.odometry in policies or c.odometry == c.driver:
            raise ValueError(f"odometry topic {c.odometry!r} is also a detector or driver topic")
        policies[c.odometry] = "interpolate"
    return policies


class FrameIntake:
    """Messages -> frames, TF -> mounts (see the module docstring).

    Parameters
    ----------
    config : BagConfig
        Driver, sync tolerance and pending limit, time source, TF topics.
    mounts : MountTracker or None
        Where the TF messages go (None: TF is not followed).
    watch : MountWatch or None
        The mounts' TF edges to check (None: not checked, e.g. in the front-end process, whose parent checks).
    output : OutputFrame, optional
        The output frame's TF (None: no ``[output] frame``).
    summary : RunSummary
        Where ``mount_changes`` is counted.
    warn : WarnOnce
        The run's warn-once logger.
    start_time_ns : int, optional
        The time the warnings count from (a bag's start); default the first message's record time.

    Raises
    ------
    ValueError
        See :func:`sync_policies`.
    """

    def __init__(
        self,
        config: BagConfig,
        *,
        mounts: MountTracker | None,
        watch: MountWatch | None,
        summary: RunSummary,
        warn: WarnOnce,
        start_time_ns: int | None = None,
        output: OutputFrame | None = None,
    ) -> None:
        c = config
        self.output = output
        self.tf_topics = frozenset(c.tf_topics)
        self.mounts = mounts
        self.watch = watch
        self.summary = summary
        self.warn = warn
        self.start_time_ns = start_time_ns
        self.use_bag_time = c.time_source == "bag"
        self.sync = FrameAssembler(
            c.driver, sync_policies(c), tolerance_ns=c.sync_tolerance_ns, max_pending=c.max_pending_frames
        )

    @property
    def stats(self) -> dict[str, dict[str, int]]:
        """The frame assembler's counts (:attr:`pfpeople.io.bag.sync.FrameAssembler.stats`)."""
        return self.sync.stats

    def push(self, m: BagMessage) -> list[Frame]:
        """Take one message; returns the frames it completed."""
        if self.start_time_ns is None:
            self.start_time_ns = m.bag_time_ns
        if m.topic in self.tf_topics:
            if self.mounts is not None:
                self.mounts.add(m.msg, m.topic)
            if self.output is not None:
                self.output.add(m.msg, m.topic)
            if self.watch is not None and m.topic in self.watch.topics:
                self._check_mounts(m)
            return []
        return self.sync.push(replace(m, stamp_ns=m.bag_time_ns) if self.use_bag_time else m)

    def finish(self) -> list[Frame]:
        """The frames still pending (the input ended)."""
        return self.sync.finish()

    def frames(self, messages: Iterable[BagMessage]) -> Iterator[Frame]:
        """The frames of ``messages``, one at a time as they complete, then those pending at the end."""
        for m in messages:
            yield from self.push(m)
        yield from self.finish()

    def _check_mounts(self, m: BagMessage) -> None:
        """Count (per edge) and warn once about the transforms of ``m`` off the mounts' values the run uses."""
        assert self.watch is not None and self.start_time_ns is not None
        for ch in self.watch.check(m.msg):
            e = ch.edge
            count(self.summary.mount_changes, e.name)
            self.warn(
                f"mount:{e.name}",
                "TF %s (topic %r) changes during the run: %.1f s into the bag it is (%.3f m, %.3f m, %.3f rad), "
                "%.3g m and %.3g rad off the value read before the run (%.3f m, %.3f m, %.3f rad). The run follows "
                "it: each frame's detections are placed with the latest transform at or before the frame's stamp "
                "(counted in mount_changes and, per detector, mounts_followed)",
                e.name,
                e.topic,
                (m.bag_time_ns - self.start_time_ns) * 1e-9,
                ch.pose.x,
                ch.pose.y,
                ch.pose.yaw,
                ch.distance_m,
                abs(ch.turn_rad),
                e.pose.x,
                e.pose.y,
                e.pose.yaw,
            )
