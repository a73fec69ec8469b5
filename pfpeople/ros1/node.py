"""``pfpeople node``: people, tracks and the grid live, every scan, on ROS 1.

The node subscribes to the configuration's topics (the driver, the detectors' topics, the odometry, ``/tf`` and
``/tf_static``) through the rospy bridge process (:mod:`pfpeople.ros1.bridge`), decodes each message with rosbags
(:class:`pfpeople.live.codec.Ros1Codec`), runs it through a :class:`pfpeople.live.session.LiveSession` (the same
run loop as ``pfpeople run``) and publishes each frame's results as a result bag holds them
(:mod:`pfpeople.live.outputs`: ``/pfpeople/belief``, ``/pfpeople/people``, ``/pfpeople/tracks``, markers,
detections), people and tracks in the ``[output] frame``.

It never falls behind: messages are read from the bridge as they arrive (a reader thread), and a driving scan is
dropped (counted) when a newer one is already waiting. Each published frame's latency (scan arrival at the bridge ->
results handed to it) is measured; a line every :data:`REPORT_EVERY_S` and at the end gives the frames, the drops
and the latency p50 / p99, and ``stats_path`` receives them as JSON.
"""

from __future__ import annotations

import collections
import json
import logging
import signal
import subprocess
import threading
import time
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import Any

from pfpeople.config import BagConfig
from pfpeople.io.jsonio import dumps
from pfpeople.live.codec import Encoded, Ros1Codec
from pfpeople.live.latency import LatencyStats
from pfpeople.live.outputs import DEFAULT_PREFIX, ResultMessages
from pfpeople.live.session import FrameOutput, LiveSession
from pfpeople.ros1.bridge import read_record, write_record
from pfpeople.ros1.system import bridge_env, bridge_script, find_ros_python

__all__ = ["REPORT_EVERY_S", "BridgeProcess", "run_node"]

log = logging.getLogger(__name__)

#: Seconds between two latency lines in the log.
REPORT_EVERY_S = 10.0


class BridgeProcess:
    """The rospy bridge process: its messages queued as they arrive, commands sent to it.

    Parameters
    ----------
    python : str
        An interpreter that imports rospy (:func:`pfpeople.ros1.system.find_ros_python`).
    spec : dict
        The bridge's argument (``node``, ``subscribe``).
    driver : str
        The driving topic (its queued messages are counted: :attr:`pending_driver`).
    env : dict, optional
        The bridge's environment (default this one less this interpreter's paths; ``ROS_MASTER_URI`` as set).
    """

    def __init__(self, python: str, spec: dict[str, Any], driver: str = "", env: dict[str, str] | None = None) -> None:
        self.driver = driver
        self.proc = subprocess.Popen(
            [python, str(bridge_script()), json.dumps(spec)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            env=bridge_env() if env is None else env,
        )
        self._inbox: collections.deque[tuple[dict[str, Any], bytes] | None] = collections.deque()
        self._ready = threading.Condition()
        #: Messages of the driving topic queued and not taken yet.
        self.pending_driver = 0
        self._reader = threading.Thread(target=self._read, name="pfpeople-bridge-reader", daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        while True:
            rec = read_record(self.proc.stdout)  # type: ignore[arg-type]
            with self._ready:
                self._inbox.append(rec)
                if rec is not None and rec[0].get("topic") == self.driver and rec[0].get("kind") == "msg":
                    self.pending_driver += 1
                self._ready.notify()
            if rec is None:
                return

    def next(self, timeout_s: float | None = None) -> tuple[dict[str, Any], bytes] | None:
        """The next record (None: the bridge ended); raises ``TimeoutError`` after ``timeout_s``."""
        with self._ready:
            if not self._ready.wait_for(lambda: bool(self._inbox), timeout=timeout_s):
                raise TimeoutError("no message from the ROS bridge")
            rec = self._inbox.popleft()
            if rec is None:
                self._inbox.appendleft(None)  # the end stays the end
            elif rec[0].get("topic") == self.driver and rec[0].get("kind") == "msg":
                self.pending_driver -= 1
            return rec

    def send(self, header: dict[str, Any], data: bytes = b"") -> None:
        """Send one command (see :mod:`pfpeople.ros1.bridge`)."""
        assert self.proc.stdin is not None
        write_record(self.proc.stdin, header, data)  # type: ignore[arg-type]

    def advertise(self, topic: str, msgtype: str, md5: str, definition: str) -> None:
        self.send({"kind": "advertise", "topic": topic, "type": msgtype, "md5": md5, "def": definition})

    def publish(self, enc: Encoded) -> None:
        self.send({"kind": "publish", "topic": enc.topic}, enc.data)

    def close(self, timeout_s: float = 5.0) -> None:
        """Shut the bridge down (idempotent)."""
        if self.proc.poll() is None:
            try:
                self.send({"kind": "shutdown"})
                assert self.proc.stdin is not None
                self.proc.stdin.close()
            except (BrokenPipeError, OSError, ValueError):
                pass
            try:
                self.proc.wait(timeout_s)
            except subprocess.TimeoutExpired:
                self.proc.terminate()
                self.proc.wait(timeout_s)
        self._reader.join(timeout_s)
        for pipe in (self.proc.stdin, self.proc.stdout):
            if pipe is not None and not pipe.closed:
                pipe.close()


class _Publisher:
    """Encodes a frame's messages and hands them to the bridge, advertising each topic once."""

    def __init__(self, bridge: BridgeProcess, codec: Ros1Codec) -> None:
        self.bridge, self.codec = bridge, codec
        self.advertised: set[str] = set()

    def advertise(self, topics: dict[str, str]) -> None:
        """Advertise ``topics`` (topic -> rosbags type) now, so subscribers connect before the first frame."""
        for topic, typename in topics.items():
            definition, md5 = self.codec.ts.generate_msgdef(typename)
            self.bridge.advertise(topic, typename.replace("/msg/", "/"), md5, definition)
            self.advertised.add(topic)

    def frame(self, out: FrameOutput) -> None:
        for topic, typename, msg in out.messages:
            enc = self.codec.encode(topic, typename, msg)
            if topic not in self.advertised:
                self.bridge.advertise(topic, enc.msgtype, enc.md5, enc.definition)
                self.advertised.add(topic)
            self.bridge.publish(enc)


def _stop_on_signals(stop: threading.Event) -> Callable[[], None]:
    """SIGINT and SIGTERM end the node's loop; returns the function restoring the previous handlers."""
    old = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}

    def handler(signum: int, frame: FrameType | None) -> None:
        stop.set()

    for s in old:
        signal.signal(s, handler)

    def restore() -> None:
        for s, h in old.items():
            signal.signal(s, h)

    return restore


def run_node(
    config: BagConfig,
    *,
    prefix: str = DEFAULT_PREFIX,
    python: str | None = None,
    node_name: str = "pfpeople",
    stats_path: str | Path | None = None,
    max_frames: int | None = None,
    stop: threading.Event | None = None,
    drop: bool = True,
) -> LatencyStats:
    """Run the node until SIGINT / SIGTERM, ``stop``, ``max_frames`` frames or the bridge's end (``drop``: see
    :class:`pfpeople.live.session.LiveSession`).

    Raises
    ------
    RosMissingError
        When no Python here imports rospy (naming the apt packages to install).
    """
    ros_python = find_ros_python(python)
    codec = Ros1Codec()
    session = LiveSession(config, codec.ts, prefix=prefix, drop=drop)
    bridge = BridgeProcess(ros_python, {"node": node_name, "subscribe": session.topics}, driver=config.driver)
    publisher = _Publisher(bridge, codec)
    stop = stop or threading.Event()
    restore = _stop_on_signals(stop) if threading.current_thread() is threading.main_thread() else (lambda: None)
    names = [d.name for d in config.detectors]
    log.info(
        "pfpeople node: subscribing to %s through %s (rospy); results under %s", session.topics, ros_python, prefix
    )
    try:
        publisher.advertise(ResultMessages.topic_types(names, prefix))
        _loop(bridge, codec, session, publisher, stop, max_frames)
        for out in session.finish():  # frames still waiting for later messages at the end: no latency of the node's
            publisher.frame(out)
            session.latency.record(0, warm_up=True)
    finally:
        restore()
        bridge.close()
        log.info("pfpeople node: %s", session.latency.summary())
        if stats_path is not None:
            Path(stats_path).write_text(dumps(session.latency.as_dict()) + "\n")
    return session.latency


def _published(session: LiveSession, publisher: _Publisher, out: FrameOutput) -> None:
    publisher.frame(out)
    session.latency.record(time.time_ns() - out.received_ns, warm_up=out.warm_up)


def _loop(
    bridge: BridgeProcess,
    codec: Ros1Codec,
    session: LiveSession,
    publisher: _Publisher,
    stop: threading.Event,
    max_frames: int | None,
) -> None:
    """Take the bridge's messages until the end, ``stop`` or ``max_frames``."""
    next_report = time.monotonic() + REPORT_EVERY_S
    while not stop.is_set():
        try:
            rec = bridge.next(timeout_s=0.5)
        except TimeoutError:
            continue
        if rec is None:
            log.warning("pfpeople node: the ROS bridge ended (exit code %s)", bridge.proc.poll())
            return
        head, data = rec
        if head.get("kind") != "msg":
            continue
        msg = codec.decode(head["topic"], head["type"], head["md5"], head.get("def", ""), data, int(head["t"]))
        newer = bridge.pending_driver > 0
        for out in session.receive(msg, newer_driver_waiting=newer):
            _published(session, publisher, out)
        if max_frames is not None and session.latency.frames >= max_frames:
            return
        if time.monotonic() >= next_report:
            next_report += REPORT_EVERY_S
            log.info("pfpeople node: %s", session.latency.summary())
