"""The core of a live node, free of any transport: decoded messages in, each frame's output messages out.

A :class:`LiveSession` goes through two phases:

1. **Setting up.** It buffers every message until it can set the run up as a bag run is set up
   (:class:`pfpeople.live.source.BufferedSource`, :func:`pfpeople.pipeline.stream.setup_run`): each sensor topic
   of the configuration (the driver, the lasers and cameras of the detectors) has a message, the odometry topic
   too when one is configured, and the messages span :data:`SETTLE_S` (so ``/tf`` has given each frame's first
   transform, as a bag run reads the first second of ``/tf``). A set-up that fails for want of TF (a mount not
   published yet) is tried again as messages arrive, for up to :data:`SETUP_TIMEOUT_S`; any other bad setting
   fails at once, naming it. Then the buffered messages go through the run in their order.
2. **Running.** Each message goes to the streaming API (:class:`pfpeople.pipeline.stream.PeopleStream`); each frame
   it completes gives its output messages (:class:`pfpeople.live.outputs.ResultMessages`). A driving scan a newer one
   waits behind (in the buffer, or in the transport's queue as the transport says) is dropped (counted in
   :attr:`LiveSession.latency`): the node never falls behind by more than a frame. The frames of scans that arrived
   before the run was set up are the warm-up: their latency is left out of the figures. With ``drop=False`` every
   scan is processed, however late (a bag replayed into the node gives the offline run's frames).

The same configuration (TOML) as ``pfpeople run``; people, tracks and markers in its ``[output] frame``.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pfpeople.config import BagConfig, run_topics
from pfpeople.io.bag.reader import BagMessage
from pfpeople.live.latency import LatencyStats
from pfpeople.live.outputs import DEFAULT_PREFIX, ResultMessages
from pfpeople.live.source import BufferedSource
from pfpeople.pipeline.stream import PeopleStream, setup_run
from pfpeople.run_state import FrameResult

__all__ = ["SETTLE_S", "SETUP_TIMEOUT_S", "FrameOutput", "LiveSession", "SetupTimeout"]

log = logging.getLogger(__name__)

#: Time (s) the first messages must span before the run is set up (TF's first transforms; a bag run reads 1 s).
SETTLE_S = 1.0
#: Longest time (s) a set-up waits for the TF of its mounts.
SETUP_TIMEOUT_S = 30.0


class SetupTimeout(RuntimeError):
    """The run could not be set up in time (a sensor topic or a mount never came)."""


@dataclass(frozen=True, eq=False)
class FrameOutput:
    """One frame's output.

    Attributes
    ----------
    result : FrameResult
        The frame's result (people, tracks, grid, ...).
    messages : list of (str, str, object)
        ``(topic, type, message)`` to publish (rosbags messages; the transport encodes them).
    received_ns : int
        When the frame's driving scan arrived (ns, the transport's clock).
    warm_up : bool
        True for the frames whose driving scan arrived before the run was set up.
    """

    result: FrameResult
    messages: list[tuple[str, str, Any]]
    received_ns: int
    warm_up: bool = False


class LiveSession:
    """A live run (see the module docstring).

    Parameters
    ----------
    config : BagConfig
        The run's configuration.
    typestore : rosbags Typestore
        The store of the output messages (the transport's codec's).
    prefix : str
        The output topics' namespace.
    clock : callable
        ``clock() -> ns``, the transport's clock (of ``received_ns``).
    drop : bool
        Drop the driving scans a newer one waits behind (default); False: process every scan however late (a bag
        replayed into the node, whose results must be the offline run's).
    """

    def __init__(
        self,
        config: BagConfig,
        typestore: Any,
        *,
        prefix: str = DEFAULT_PREFIX,
        clock: Callable[[], int] | None = None,
        drop: bool = True,
    ) -> None:
        import time

        self.config = config
        self.drop = drop
        self.typestore = typestore
        self.prefix = prefix
        self.clock = clock or time.time_ns
        self.stream: PeopleStream | None = None
        self.outputs: ResultMessages | None = None
        self.latency = LatencyStats()
        self._buffer: list[BagMessage] = []
        self._first_ns: int | None = None
        self._last_try_ns = 0
        #: When the run was set up (ns, :attr:`clock`): messages that arrived before are the warm-up.
        self.ready_ns: int | None = None

    @property
    def topics(self) -> list[str]:
        """The topics to subscribe to: the run's (driver, detectors, odometry) and its TF topics."""
        return [*run_topics(self.config), *self.config.tf_topics]

    @property
    def ready(self) -> bool:
        """Whether the run is set up (running)."""
        return self.stream is not None

    def receive(self, message: BagMessage, *, newer_driver_waiting: bool = False) -> list[FrameOutput]:
        """Take one message (its ``bag_time_ns``: its arrival); returns the outputs of the frames it completed.

        ``newer_driver_waiting``: the transport holds a newer message of the driving topic, so a driving message
        is dropped (counted) rather than processed.

        Raises
        ------
        SetupTimeout
            If the run could not be set up within :data:`SETUP_TIMEOUT_S` of the first message.
        ValueError
            For a setting the first messages contradict (naming it).
        """
        if self.stream is None:
            return self._buffered(message, newer_driver_waiting)
        if self._dropped(message, newer_driver_waiting):
            return []
        return [self._output(r) for r in self.stream.push(message)]

    def _dropped(self, message: BagMessage, newer_driver_waiting: bool) -> bool:
        """Whether ``message`` is a driving scan to drop (a newer one waits); counted."""
        if self.drop and newer_driver_waiting and message.topic == self.config.driver:
            self.latency.dropped += 1
            return True
        return False

    def finish(self) -> list[FrameOutput]:
        """The outputs of the frames still pending (the input ended)."""
        if self.stream is None:
            return []
        return [self._output(r) for r in self.stream.finish()]

    def _output(self, result: FrameResult) -> FrameOutput:
        assert self.outputs is not None and self.ready_ns is not None
        received = result.frame.driver.bag_time_ns
        return FrameOutput(result, self.outputs.frame(result), received, received <= self.ready_ns)

    def _buffered(self, message: BagMessage, newer_driver_waiting: bool) -> list[FrameOutput]:
        """Buffer ``message``; set the run up when the buffer allows it, and run the buffered messages (a driving
        scan a newer one waits behind dropped)."""
        self._buffer.append(message)
        if self._first_ns is None:
            self._first_ns = message.bag_time_ns
        if not self._can_set_up(message.bag_time_ns):
            return []
        try:
            self._set_up()
        except ValueError as exc:
            if "no transform from frame" not in str(exc):  # a mount not on TF yet: wait for it
                raise
            if message.bag_time_ns - self._first_ns > SETUP_TIMEOUT_S * 1e9:
                raise SetupTimeout(f"no set-up after {SETUP_TIMEOUT_S:g} s: {exc}") from None
            return []
        assert self.stream is not None
        buffered, self._buffer = self._buffer, []
        driver = [k for k, m in enumerate(buffered) if m.topic == self.config.driver]
        last = driver[-1] if driver else -1
        out = []
        for k, m in enumerate(buffered):
            if not self._dropped(m, k < last or newer_driver_waiting):
                out += [self._output(r) for r in self.stream.push(m)]
        return out

    def _can_set_up(self, now_ns: int) -> bool:
        """Whether every sensor (and odometry) topic has a message and the messages span :data:`SETTLE_S`."""
        assert self._first_ns is not None
        if now_ns - self._first_ns < SETTLE_S * 1e9 or now_ns - self._last_try_ns < 0.2e9:
            return False
        have = {m.topic for m in self._buffer}
        sensors = {self.config.driver, *(d.topic for d in self.config.detectors if d.kind != "topic")}
        missing = sorted(t for t in sensors if t not in have)
        if self.config.odometry and self.config.odometry not in have:
            missing.append(self.config.odometry)
        if missing:
            if now_ns - self._first_ns > SETUP_TIMEOUT_S * 1e9:
                raise SetupTimeout(f"no message on {missing} within {SETUP_TIMEOUT_S:g} s of the first one")
            return False
        self._last_try_ns = now_ns
        return True

    def _set_up(self) -> None:
        """Build the run from the buffered messages (as a bag run from its bag)."""
        source = BufferedSource(self._buffer)
        setup = setup_run(self.config, source)
        stream = PeopleStream(self.config, setup, start_time_ns=source.start_time_ns)
        self.outputs = ResultMessages(
            self.typestore,
            spec=stream.spec,
            grid_frame=stream.grid_frame,
            detector_names=[d.name for d in self.config.detectors],
            output_frame=stream.output_frame,
            prefix=self.prefix,
        )
        self.stream = stream
        self.ready_ns = self.clock()
        log.info(
            "set up from %d messages: grid frame %r, %s; people and tracks in %r",
            len(self._buffer),
            stream.grid_frame,
            stream.spec,
            stream.output_frame,
        )
