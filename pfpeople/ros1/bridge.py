"""The ROS 1 transport of ``pfpeople node``: a thin rospy process, run by the system's ``python3``.

Debian's ROS 1 packages (``python3-rospy`` ...) install into the system Python (``/usr/lib/python3/dist-packages``),
whose minor version may differ from the one pfpeople runs in (a virtual environment, another interpreter), and
rospy's dependencies hold compiled modules built for it. So the node does not import rospy: it starts this script
with the system interpreter and talks to it over two pipes. The script imports only the standard library and rospy
(never pfpeople), and moves bytes: every message of the subscribed topics goes out as its ROS 1 serialisation with
its type, MD5 sum, definition and arrival time (``rospy.AnyMsg``); every message pfpeople sends comes in as bytes and
is published under its own type (a class made from its type, MD5 sum and definition). Decoding, the work and the
encoding happen in pfpeople (:mod:`pfpeople.live`).

Framing (both directions): a record is ``<u32 n><n bytes of JSON header><u32 m><m bytes of payload>``,
little-endian. Bridge -> pfpeople headers: ``{"kind": "ready"}``; ``{"kind": "msg", "topic", "type", "md5", "t"
(arrival, ns since the epoch), "def" (the definition, first message of a topic only)}`` with the message as payload;
``{"kind": "connected", "topics": {topic: n}}`` when asked (``wait``). pfpeople -> bridge: ``{"kind": "advertise",
"topic", "type", "md5", "def", "latch"}``; ``{"kind": "publish", "topic"}`` with the bytes as payload;
``{"kind": "shutdown"}``. The bridge ends when its input ends.

Usage: ``python3 bridge.py '{"node": "pfpeople", "subscribe": ["/scan", "/tf"], "wait": false}'``.
"""

from __future__ import annotations

import json
import struct
import sys
import threading
import time
from typing import Any, BinaryIO

_U32 = struct.Struct("<I")


def write_record(out: BinaryIO, header: dict[str, Any], data: bytes = b"", lock: Any = None) -> None:
    """Write one record (see the module docstring) and flush; ``lock`` serialises writers."""
    head = json.dumps(header, separators=(",", ":")).encode()
    blob = _U32.pack(len(head)) + head + _U32.pack(len(data)) + data
    if lock is None:
        out.write(blob)
        out.flush()
        return
    with lock:
        out.write(blob)
        out.flush()


def _read_exact(inp: BinaryIO, n: int) -> bytes | None:
    chunks, got = [], 0
    while got < n:
        chunk = inp.read(n - got)
        if not chunk:
            return None
        chunks.append(chunk)
        got += len(chunk)
    return b"".join(chunks)


def read_record(inp: BinaryIO) -> tuple[dict[str, Any], bytes] | None:
    """The next record of ``inp``; None at its end (a record cut short included)."""
    size = _read_exact(inp, 4)
    if size is None:
        return None
    head = _read_exact(inp, _U32.unpack(size)[0])
    size = _read_exact(inp, 4) if head is not None else None
    if head is None or size is None:
        return None
    data = _read_exact(inp, _U32.unpack(size)[0])
    if data is None:
        return None
    return json.loads(head.decode()), data


def _raw_class(anymsg: Any, msgtype: str, md5: str, definition: str) -> Any:
    """A message class publishing given bytes as ``msgtype`` (what subscribers of that type expect)."""
    name = "Raw_" + msgtype.replace("/", "_")
    attrs = {"_type": msgtype, "_md5sum": md5, "_full_text": definition, "_has_header": False, "__slots__": ()}
    return type(name, (anymsg,), attrs)


class Bridge:
    """The rospy side: subscriptions out, publications in."""

    def __init__(self, spec: dict[str, Any]) -> None:
        import rospy
        from rospy.msg import AnyMsg

        self.rospy, self.anymsg = rospy, AnyMsg
        self.out = sys.stdout.buffer
        self.lock = threading.Lock()
        self.seen: set[tuple[str, str]] = set()
        self.pubs: dict[str, Any] = {}
        self.classes: dict[str, Any] = {}
        rospy.init_node(spec.get("node", "pfpeople"), anonymous=bool(spec.get("anonymous")), disable_signals=True)
        self.subs = [rospy.Subscriber(t, AnyMsg, self.received, callback_args=t) for t in spec.get("subscribe", [])]

    def received(self, msg: Any, topic: str) -> None:
        """A subscription's message: out, with its arrival time."""
        t = time.time_ns()
        h = msg._connection_header
        header = {"kind": "msg", "topic": topic, "type": h["type"], "md5": h["md5sum"], "t": t}
        if (topic, h["md5sum"]) not in self.seen:
            self.seen.add((topic, h["md5sum"]))
            header["def"] = h.get("message_definition", "")
        write_record(self.out, header, bytes(msg._buff), self.lock)

    def wait_connected(self, timeout_s: float = 60.0) -> None:
        """Wait until every subscription has a publisher connected (or the time is up); say how many."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end and any(s.get_num_connections() == 0 for s in self.subs):
            time.sleep(0.05)
        counts = {s.name: s.get_num_connections() for s in self.subs}
        write_record(self.out, {"kind": "connected", "topics": counts}, b"", self.lock)

    def command(self, header: dict[str, Any], data: bytes) -> bool:
        """Carry out one command; False at shutdown."""
        kind = header.get("kind")
        if kind == "advertise":
            topic = header["topic"]
            cls = _raw_class(self.anymsg, header["type"], header["md5"], header.get("def", ""))
            self.classes[topic] = cls
            latch = bool(header.get("latch"))
            self.pubs[topic] = self.rospy.Publisher(topic, cls, queue_size=100, latch=latch)
        elif kind == "publish":
            msg = self.classes[header["topic"]]()
            msg._buff = data
            self.pubs[header["topic"]].publish(msg)
        elif kind == "wait":
            self.wait_connected(float(header.get("timeout_s", 60.0)))
        elif kind == "shutdown":
            return False
        return True


def main(argv: list[str]) -> int:
    spec = json.loads(argv[1]) if len(argv) > 1 else {}
    try:
        bridge = Bridge(spec)
    except ImportError as exc:
        print(f"pfpeople ROS 1 bridge: cannot import rospy ({exc})", file=sys.stderr)
        return 3
    write_record(bridge.out, {"kind": "ready"}, b"", bridge.lock)
    inp = sys.stdin.buffer
    try:
        while True:
            rec = read_record(inp)
            if rec is None or not bridge.command(*rec):
                break
    except (BrokenPipeError, KeyboardInterrupt):
        pass
    finally:
        bridge.rospy.signal_shutdown("pfpeople node ended")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
