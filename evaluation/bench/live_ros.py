"""A ROS 1 world on this machine for the live node's test and benchmark: a master on a free port, a bag played
into it, the node, and a subscriber recording the node's results.

Everything runs on the loopback interface (``ROS_MASTER_URI=http://127.0.0.1:PORT``, ``ROS_IP=127.0.0.1``) with the
ROS 1 of Debian's packages; every process is started here and ended here (:class:`RosWorld` as a context manager).
:class:`Recorder` is the node's own rospy bridge (:mod:`pfpeople.ros1.bridge`) subscribed to the output topics:
it records each message's bytes and arrival, and decodes them with rosbags.
"""

from __future__ import annotations

import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pfpeople.live.codec import Ros1Codec
from pfpeople.ros1.node import BridgeProcess
from pfpeople.ros1.system import bridge_env, find_ros_python, ros_tool

__all__ = ["Recorder", "RosWorld", "free_port"]


def free_port() -> int:
    """A TCP port free on the loopback interface now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@dataclass
class RosWorld:
    """A ROS master of its own (see the module docstring); ``env`` is the environment of its processes."""

    workdir: Path
    port: int = field(default_factory=free_port)
    procs: list[subprocess.Popen[bytes]] = field(default_factory=list)
    logs: list[Any] = field(default_factory=list)

    @property
    def env(self) -> dict[str, str]:
        env = bridge_env()
        env.update(
            ROS_MASTER_URI=f"http://127.0.0.1:{self.port}",
            ROS_IP="127.0.0.1",
            ROS_HOME=str(self.workdir / "ros_home"),
            ROS_LOG_DIR=str(self.workdir / "ros_log"),
        )
        return env

    def start(self, timeout_s: float = 30.0) -> None:
        """Start the master and wait until it answers."""
        rosmaster = ros_tool("rosmaster")
        if rosmaster is None:
            raise FileNotFoundError("rosmaster not found (apt-get install ros-core)")
        self.spawn([rosmaster, "--core", "-p", str(self.port)], "rosmaster")
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", self.port)) == 0:
                    return
            time.sleep(0.05)
        raise TimeoutError(f"rosmaster did not answer on port {self.port}")

    def spawn(self, argv: Sequence[str], name: str, **kwargs: Any) -> subprocess.Popen[bytes]:
        """Start a process of this world (its output in ``workdir/name.log`` unless given)."""
        if "stdout" not in kwargs:
            kwargs["stdout"] = (self.workdir / f"{name}.log").open("wb")
            self.logs.append(kwargs["stdout"])
        kwargs.setdefault("stderr", subprocess.STDOUT)
        proc = subprocess.Popen(list(argv), env={**self.env, **kwargs.pop("env", {})}, **kwargs)
        self.procs.append(proc)
        return proc

    def play(self, bag: str | Path, *, rate: float = 1.0, topics: Sequence[str] = ()) -> subprocess.Popen[bytes]:
        """``rosbag play`` of ``bag`` at ``rate`` (only ``topics`` when given)."""
        rosbag = ros_tool("rosbag")
        if rosbag is None:
            raise FileNotFoundError("rosbag not found (apt-get install python3-rosbag)")
        argv = [rosbag, "play", "-q", "-r", f"{rate:g}", str(bag)]
        if topics:
            argv += ["--topics", *topics]
        return self.spawn(argv, f"play_{len(self.procs)}")

    def node(self, config: str | Path, *extra: str, name: str = "node") -> subprocess.Popen[bytes]:
        """``pfpeople node --config CONFIG`` in this world."""
        argv = [sys.executable, "-m", "pfpeople.cli", "node", "--config", str(config), *extra]
        return self.spawn(argv, name)

    def close(self) -> None:
        """End every process of this world, newest first."""
        for proc in reversed(self.procs):
            if proc.poll() is None:
                proc.terminate()
                try:
                    proc.wait(10.0)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait(10.0)
        for fh in self.logs:
            fh.close()


@contextmanager
def ros_world(workdir: str | Path) -> Iterator[RosWorld]:
    """A started :class:`RosWorld`, closed at the end."""
    world = RosWorld(Path(workdir))
    world.workdir.mkdir(parents=True, exist_ok=True)
    try:
        world.start()
        yield world
    finally:
        world.close()


class Recorder:
    """A subscriber recording the messages of ``topics`` (bytes and arrival) in a thread; :meth:`decoded` after."""

    def __init__(self, world: RosWorld, topics: Sequence[str]) -> None:
        self.python = find_ros_python()
        spec = {"node": "pfpeople_recorder", "subscribe": list(topics)}
        self.bridge = BridgeProcess(self.python, spec, env=world.env)
        self.records: list[tuple[dict[str, Any], bytes]] = []
        self._thread = threading.Thread(target=self._take, daemon=True)
        self.connected: dict[str, int] | None = None
        self._connected = threading.Event()
        self._thread.start()

    def _take(self) -> None:
        while True:
            rec = self.bridge.next()
            if rec is None:
                return
            if rec[0].get("kind") == "connected":
                self.connected = rec[0]["topics"]
                self._connected.set()
            elif rec[0].get("kind") == "msg":
                self.records.append(rec)

    def wait_connected(self, timeout_s: float = 60.0) -> dict[str, int]:
        """Wait until a publisher is connected to each topic (the node advertised them); the counts."""
        self.bridge.send({"kind": "wait", "timeout_s": timeout_s})
        self._connected.wait(timeout_s + 5.0)
        return dict(self.connected or {})

    def close(self) -> None:
        self.bridge.close()
        self._thread.join(5.0)

    def decoded(self) -> list[tuple[str, int, Any]]:
        """``(topic, arrival ns, message)`` of every recorded message, in order."""
        codec = Ros1Codec()
        out = []
        for head, data in self.records:
            m = codec.decode(head["topic"], head["type"], head["md5"], head.get("def", ""), data, int(head["t"]))
            out.append((m.topic, int(head["t"]), m.msg))
        return out
