"""Time synchronisation: frames driven by one topic, other topics assigned to them in a stream.

Every message of the *driver* topic makes one frame at its stamp ``t``. Every other topic is assigned to the
frame by a policy:

``"nearest"``
    The paper's rule (Sect. 4: the laser reading closest to the latest image): the message whose stamp is
    closest to ``t``, if within the tolerance; otherwise the topic has no data in this frame (the pipeline then
    treats its detector as covering no cell).
``"preceding"``
    All messages with stamps in ``[t, t_next)`` (``t_next`` the next frame's stamp, at most ``t + tolerance``
    for the last frame): for headerless detection messages written after the reading they belong to.
``"interpolate"``
    The two messages bracketing ``t`` (for odometry, interpolated by the pipeline); a single one within the
    tolerance when ``t`` is not bracketed; none otherwise.

Streaming: a frame is finalised as soon as no later message can change its assignment, i.e. once every topic
has a message at or after the frame's bound (``t``, or ``t_next`` for "preceding"), or the driver is more
than two tolerances plus the topic's lag past the bound, or more than ``max_pending`` frames wait (then it is
finalised with what arrived, and this is counted). Buffers keep only what pending frames can still use, so memory
does not grow with the bag's length.

Latency: a topic recorded well after its stamps (odometry or a camera 0.3 s late) would miss nearly every frame
if frames went out two tolerances after the driver. Each topic's *lag* is measured as its messages arrive: the
largest amount (up to 5 s: more is another clock) by which the newest driver stamp is ahead of a message's stamp
(``stats["lag_ms"]``). Frames wait for a topic for that lag more (at most ``max_pending`` frames: a lag longer than
those cover forces frames, and the warning names the topic, its lag and the ``max_pending_frames`` to set). The frames
before a topic's first message cannot know its lag. A lag above two tolerances is warned once per topic.

Non-monotonic stamps: a message whose stamp is earlier than the previous one of its topic (or equal, for the
driver) cannot be placed in a stream; it is skipped, counted in :attr:`FrameAssembler.stats` and logged
(a warning the first time per topic). Never an exception.

Clock jumps: the offset ``stamp - bag_time`` of a topic (header stamp minus record time) changes slowly in a
recording. A message whose offset moves by more than ``max_clock_jump_ns`` (default 5 s) from its topic's
current offset is held back (at most ``resync_after - 1`` messages, default 2) until the topic shows what it
was:

- the next message is back on the current clock: the held messages had **outlier stamps** (a clock glitch,
  a stamp in another time base) and are skipped, counted in ``stats["clock_jump"]`` and logged. One scan
  stamped an hour ahead no longer makes every later scan "non-monotonic";
- ``resync_after`` consecutive messages agree on the new offset: the clock stepped (or the recording has a
  gap in its stamps, as bags rewritten by a script do): the held messages and the topic follow the new clock,
  nothing is lost, and the step is counted in ``stats["resync"]`` and logged.

A driver clock that steps backwards cannot be followed (the frames would go back in time): its messages are
then skipped as non-monotonic (counted); run with ``time_source = "bag"`` for such a recording. With
``time_source = "bag"`` the offset is 0 and no message is held.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass, field

from .reader import BagMessage

__all__ = ["DEFAULT_MAX_CLOCK_JUMP_NS", "POLICIES", "Frame", "FrameAssembler"]

log = logging.getLogger(__name__)

#: Largest change (ns) of a topic's ``stamp - bag_time`` offset accepted between consecutive messages.
DEFAULT_MAX_CLOCK_JUMP_NS = 5_000_000_000

POLICIES = ("nearest", "preceding", "interpolate")


@dataclass(frozen=True, kw_only=True, eq=False)
class Frame:
    """One synchronised frame.

    Attributes
    ----------
    index : int
        Position of the frame in the run (0, 1, ...).
    driver : BagMessage
        The driving message; ``driver.index`` is its index on its topic (e.g. the scan index).
    stamp_ns : int
        Frame stamp (ns): the driver's stamp.
    inputs : dict of str to list of BagMessage
        Messages assigned to the frame per secondary topic (empty list: no data in this frame).
    forced : bool
        True when the frame was finalised by the pending limit before every topic caught up.
    """

    index: int
    driver: BagMessage
    stamp_ns: int
    inputs: dict[str, list[BagMessage]] = field(default_factory=dict)
    forced: bool = False

    @property
    def bag_time_ns(self) -> int:
        return self.driver.bag_time_ns


@dataclass
class _Topic:
    policy: str
    buffer: deque[BagMessage] = field(default_factory=deque)
    last_stamp: int | None = None
    #: How far (ns) the newest driver stamp was ahead of this topic's messages as they arrived (the most seen).
    lag_ns: int = 0


class FrameAssembler:
    """Assemble frames from a stream of messages (see the module docstring).

    Parameters
    ----------
    driver : str
        The driving topic.
    policies : mapping of str to str
        Policy (``"nearest"``, ``"preceding"``, ``"interpolate"``) per secondary topic.
    tolerance_ns : int
        Synchronisation tolerance (ns).
    max_pending : int
        Frames allowed to wait for late messages.
    max_buffer : int
        Messages kept per secondary topic (oldest dropped and counted beyond it).
    max_clock_jump_ns : int or None
        A message whose ``stamp - bag_time`` offset moves by more than this (ns) from its topic's is held
        until the topic shows an outlier or a clock step (see the module docstring); None disables the check.
    resync_after : int
        Consecutive messages agreeing on a new offset after which the topic follows it.
    """

    def __init__(
        self,
        driver: str,
        policies: Mapping[str, str],
        *,
        tolerance_ns: int,
        max_pending: int = 20,
        max_buffer: int = 2000,
        max_clock_jump_ns: int | None = DEFAULT_MAX_CLOCK_JUMP_NS,
        resync_after: int = 3,
    ) -> None:
        if tolerance_ns < 0:
            raise ValueError(f"tolerance_ns must be non-negative, got {tolerance_ns}")
        if max_pending < 1 or max_buffer < 2:
            raise ValueError("max_pending must be >= 1 and max_buffer >= 2")
        for topic, policy in policies.items():
            if policy not in POLICIES:
                raise ValueError(f"sync policy of topic {topic!r} must be one of {POLICIES}, got {policy!r}")
        if driver in policies:
            raise ValueError(f"topic {driver!r} cannot be both the driver and a secondary topic")
        if max_clock_jump_ns is not None and max_clock_jump_ns <= 0:
            raise ValueError(f"max_clock_jump_ns must be positive or None, got {max_clock_jump_ns}")
        if resync_after < 1:
            raise ValueError(f"resync_after must be >= 1, got {resync_after}")
        self.max_clock_jump_ns = max_clock_jump_ns
        self.resync_after = resync_after
        self._offset: dict[str, int] = {}
        self._held: dict[str, list[BagMessage]] = {}
        self.driver = driver
        self.tolerance_ns = int(tolerance_ns)
        self.max_pending = max_pending
        self.max_buffer = max_buffer
        self._topics = {t: _Topic(p) for t, p in policies.items()}
        self._pending: deque[BagMessage] = deque()
        self._last_driver: int | None = None
        self._closed = False
        self._next_index = 0
        #: Counters: frames, skipped non-monotonic messages per topic, forced frames, buffer overflows,
        #: messages skipped for an outlier stamp (clock jump) and resynchronisations per topic.
        self.stats: dict[str, dict[str, int]] = {
            "frames": {"emitted": 0, "forced": 0},
            "non_monotonic": {},
            "buffer_overflow": {},
            "clock_jump": {},
            "resync": {},
            "lag_ms": {},
        }

    @property
    def skipped_driver_messages(self) -> dict[str, int]:
        """Driver messages that made no frame, by reason (``"clock_jump"``, ``"non_monotonic"``)."""
        out = {}
        for reason in ("clock_jump", "non_monotonic"):
            n = self.stats[reason].get(self.driver, 0)
            if n:
                out[reason] = n
        return out

    def _skip_non_monotonic(self, msg: BagMessage, last: int) -> None:
        counts = self.stats["non_monotonic"]
        if msg.topic not in counts:
            log.warning(
                "topic %s: stamp %d ns is not after the previous one (%d ns); skipping such messages "
                "(counted in the run's statistics)",
                msg.topic,
                msg.stamp_ns,
                last,
            )
        counts[msg.topic] = counts.get(msg.topic, 0) + 1

    def _offset_of(self, msg: BagMessage) -> int:
        return msg.stamp_ns - msg.bag_time_ns

    def _drop_outliers(self, topic: str, held: list[BagMessage], ref: int) -> None:
        if not held:
            return
        counts = self.stats["clock_jump"]
        if topic not in counts:
            log.warning(
                "topic %s: stamp %d ns is %+.3f s off its clock (stamp - bag time moved by more than %.3f s "
                "and the next message is back on the clock): skipped as an outlier stamp (such messages are "
                "counted in the run's statistics)",
                topic,
                held[0].stamp_ns,
                (self._offset_of(held[0]) - ref) * 1e-9,
                (self.max_clock_jump_ns or 0) * 1e-9,
            )
        counts[topic] = counts.get(topic, 0) + len(held)
        held.clear()

    def _admit(self, msg: BagMessage) -> list[BagMessage]:
        """The messages to process now: ``msg``, held messages released with it, or none (``msg`` held)."""
        if self.max_clock_jump_ns is None:
            return [msg]
        topic, jump = msg.topic, self.max_clock_jump_ns
        off = self._offset_of(msg)
        ref = self._offset.get(topic)
        held = self._held.setdefault(topic, [])
        if ref is None or abs(off - ref) <= jump:  # on the current clock: what was held were outliers
            if ref is not None:
                self._drop_outliers(topic, held, ref)
            self._offset[topic] = off
            return [msg]
        if held and abs(off - self._offset_of(held[-1])) > jump:  # not even on the held messages' clock
            self._drop_outliers(topic, held, ref)
        held.append(msg)
        if len(held) < self.resync_after:
            return []
        counts = self.stats["resync"]
        if topic not in counts:
            log.warning(
                "topic %s: its stamps stepped by %+.3f s relative to the bag's record time and %d messages "
                "agree (a clock step or a gap in the stamps): following the new clock (counted)",
                topic,
                (off - ref) * 1e-9,
                len(held),
            )
        counts[topic] = counts.get(topic, 0) + 1
        self._offset[topic] = off
        out = list(held)
        held.clear()
        return out

    def push(self, msg: BagMessage) -> list[Frame]:
        """Add one message; returns the frames that became final (in order)."""
        if self._closed:
            raise RuntimeError("FrameAssembler.push after finish()")
        if msg.topic != self.driver and msg.topic not in self._topics:
            raise ValueError(f"FrameAssembler got a message of topic {msg.topic!r}, which it was not given")
        out: list[Frame] = []
        for m in self._admit(msg):
            out += self._push(m)
        return out

    def _push(self, msg: BagMessage) -> list[Frame]:
        if msg.topic == self.driver:
            if self._last_driver is not None and msg.stamp_ns <= self._last_driver:
                self._skip_non_monotonic(msg, self._last_driver)
                return []
            self._last_driver = msg.stamp_ns
            self._pending.append(msg)
        else:
            topic = self._topics.get(msg.topic)
            if topic is None:
                raise ValueError(f"FrameAssembler got a message of topic {msg.topic!r}, which it was not given")
            if topic.last_stamp is not None and msg.stamp_ns < topic.last_stamp:
                self._skip_non_monotonic(msg, topic.last_stamp)
                return []
            topic.last_stamp = msg.stamp_ns
            self._measure_lag(topic, msg)
            topic.buffer.append(msg)
            if len(topic.buffer) > self.max_buffer:
                topic.buffer.popleft()
                over = self.stats["buffer_overflow"]
                if msg.topic not in over:
                    log.warning(
                        "topic %s: more than %d messages without a frame; dropping the oldest",
                        msg.topic,
                        self.max_buffer,
                    )
                over[msg.topic] = over.get(msg.topic, 0) + 1
        return self._drain()

    def _measure_lag(self, topic: _Topic, msg: BagMessage) -> None:
        """Update the topic's lag behind the driver (see the module docstring); warn once when it exceeds two
        tolerances (the frames then wait for it)."""
        lag = None if self._last_driver is None else self._last_driver - msg.stamp_ns
        if lag is None or lag <= topic.lag_ns or lag > DEFAULT_MAX_CLOCK_JUMP_NS:  # beyond: another clock, not a lag
            return
        before, topic.lag_ns = topic.lag_ns, lag
        self.stats["lag_ms"][msg.topic] = round(topic.lag_ns / 1e6)
        if topic.lag_ns > 2 * self.tolerance_ns >= before:
            log.warning(
                "topic %s arrives %.3f s (or more) after its stamps (behind the driver %s): frames wait for it that "
                "much longer, at most max_pending_frames = %d frames (the lag is in the run's sync statistics, lag_ms)",
                msg.topic,
                topic.lag_ns * 1e-9,
                self.driver,
                self.max_pending,
            )

    def finish(self) -> list[Frame]:
        """End of the stream: release held messages (nothing tells them outliers), finalise every pending frame."""
        held = sorted((m for ms in self._held.values() for m in ms), key=lambda m: m.bag_time_ns)
        self._held.clear()
        out: list[Frame] = []
        for m in held:
            out += self._push(m)
        self._closed = True
        return out + self._drain()

    # -- internals ---------------------------------------------------------------------------------------

    def _bound(self, topic: _Topic, k: int) -> int | None:
        """Stamp a topic must reach for pending frame ``k`` to be final (None: unknown yet)."""
        t = self._pending[k].stamp_ns
        if topic.policy != "preceding":
            return t
        if k + 1 < len(self._pending):
            return self._pending[k + 1].stamp_ns
        return None if not self._closed else t + self.tolerance_ns

    def _ready(self, k: int) -> bool:
        if self._closed:
            return True
        newest = self._last_driver if self._last_driver is not None else 0
        for topic in self._topics.values():
            bound = self._bound(topic, k)
            if bound is None:
                return False
            if topic.last_stamp is not None and topic.last_stamp >= bound:
                continue
            if newest - bound > 2 * self.tolerance_ns + topic.lag_ns:
                continue
            return False
        return True

    def _drain(self) -> list[Frame]:
        out: list[Frame] = []
        while self._pending:
            forced = False
            if not self._ready(0):
                if len(self._pending) <= self.max_pending:
                    break
                forced = True
            out.append(self._finalise(forced))
        return out

    def _lag_advice(self, drv: BagMessage) -> str:
        """For the forced-frame warning: the lagging topics and the ``max_pending_frames`` covering their lag."""
        lag = max((tp.lag_ns for tp in self._topics.values()), default=0)
        if not lag or not self._pending:
            return ""
        period = (self._pending[-1].stamp_ns - drv.stamp_ns) / max(len(self._pending), 1)
        need = math.ceil((lag + 2 * self.tolerance_ns) / period) + 1 if period > 0 else self.max_pending + 1
        lagging = ", ".join(f"{n} (lag {tp.lag_ns * 1e-9:.3f} s)" for n, tp in self._topics.items() if tp.lag_ns)
        return f"; lagging topics: {lagging}: set max_pending_frames to at least {need} to wait for them"

    def _finalise(self, forced: bool) -> Frame:
        drv = self._pending[0]
        t = drv.stamp_ns
        tol = self.tolerance_ns
        t_next = self._pending[1].stamp_ns if len(self._pending) > 1 else t + tol
        inputs: dict[str, list[BagMessage]] = {}
        for name, topic in self._topics.items():
            buf = topic.buffer
            if topic.policy == "nearest":
                best = min(buf, key=lambda m: abs(m.stamp_ns - t), default=None)
                inputs[name] = [best] if best is not None and abs(best.stamp_ns - t) <= tol else []
            elif topic.policy == "preceding":
                inputs[name] = [m for m in buf if t <= m.stamp_ns < t_next]
            else:
                before = [m for m in buf if m.stamp_ns <= t]
                after = [m for m in buf if m.stamp_ns > t]
                if before and after:
                    inputs[name] = [before[-1], after[0]]
                else:
                    near = before[-1:] or after[:1]
                    inputs[name] = [m for m in near if abs(m.stamp_ns - t) <= tol]
        self._pending.popleft()
        # Trim: keep only what later frames can still use.
        t_keep = self._pending[0].stamp_ns if self._pending else t
        for topic in self._topics.values():
            buf = topic.buffer
            if topic.policy == "preceding":
                while buf and buf[0].stamp_ns < t_next:
                    buf.popleft()
            else:
                while len(buf) >= 2 and buf[1].stamp_ns <= t_keep:
                    buf.popleft()
        frame = Frame(index=self._next_index, driver=drv, stamp_ns=t, inputs=inputs, forced=forced)
        self._next_index += 1
        self.stats["frames"]["emitted"] += 1
        if forced:
            if self.stats["frames"]["forced"] == 0:
                log.warning(
                    "frame at %d ns finalised after %d pending frames before every topic caught up "
                    "(late messages are not used; counted as 'forced')%s",
                    t,
                    self.max_pending,
                    self._lag_advice(drv),
                )
            self.stats["frames"]["forced"] += 1
        return frame
