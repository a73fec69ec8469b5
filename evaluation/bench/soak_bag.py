"""The bag-level soak (``python -m evaluation.bench.soak --bag-frames N``): ``pfpeople run`` over a long bag.

:func:`write_soak_bag` writes the bag; :func:`soak_bag` runs ``pfpeople run`` on it in a subprocess and samples
its process tree's resident memory (see :mod:`evaluation.bench.soak`, bag mode).
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import psutil

__all__ = ["BagSoakResult", "soak_bag", "write_soak_bag"]

#: Distinct scans the soak bag cycles through (people walk back and forth over this many frames).
CYCLE = 200
T0_NS = 1_000 * 1_000_000_000


def _typestore() -> Any:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    ts = get_typestore(Stores.ROS1_NOETIC)
    if "tf2_msgs/msg/TFMessage" not in ts.types:
        ts.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms\n", "tf2_msgs/msg/TFMessage"))
    return ts


def _cycle_ranges(inc: float) -> list[np.ndarray]:
    """The :data:`CYCLE` scans: two people (legs 0.3 m apart) walking back and forth across the laser's view."""
    from pfpeople.detect.synthetic import render_scan

    out = []
    for k in range(CYCLE):
        s = math.sin(2 * math.pi * k / CYCLE)
        circles = []
        for x, y in ((3.0 + s, 1.5 * s), (5.0 - s, -1.0 + 0.5 * s)):
            b = math.atan2(y, x)
            px, py = -math.sin(b) * 0.15, math.cos(b) * 0.15
            circles += [(x + px, y + py, 0.06), (x - px, y - py, 0.06)]
        out.append(np.asarray(render_scan(circles=circles, angle_increment=inc).ranges, dtype=np.float32))
    return out


def write_soak_bag(path: Path, frames: int) -> None:
    """A ROS1 bag of ``frames`` LaserScans on ``/scan`` at 10 Hz (frame ``laser``, mounted on ``base_link`` at
    (0.2 m, 0, 0) by ``/tf_static``), cycling through :data:`CYCLE` scans of two walking people."""
    from rosbags.rosbag1 import Writer

    ts = _typestore()
    T = ts.types
    inc = math.radians(0.5)
    ranges = _cycle_ranges(inc)

    def header(stamp: int, frame: str) -> Any:
        t = T["builtin_interfaces/msg/Time"](sec=stamp // 10**9, nanosec=stamp % 10**9)
        return T["std_msgs/msg/Header"](seq=0, stamp=t, frame_id=frame)

    vec, quat = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
    tf = T["geometry_msgs/msg/TransformStamped"](
        header=header(T0_NS, "base_link"),
        child_frame_id="laser",
        transform=T["geometry_msgs/msg/Transform"](
            translation=vec(x=0.2, y=0.0, z=0.3), rotation=quat(x=0.0, y=0.0, z=0.0, w=1.0)
        ),
    )
    w = Writer(path)
    w.open()
    tf_conn = w.add_connection("/tf_static", "tf2_msgs/msg/TFMessage", typestore=ts)
    w.write(tf_conn, T0_NS - 1, ts.serialize_ros1(T["tf2_msgs/msg/TFMessage"](transforms=[tf]), tf_conn.msgtype))
    conn = w.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=ts)
    empty = np.zeros(0, dtype=np.float32)
    for k in range(frames):
        stamp = T0_NS + k * 100_000_000
        r = ranges[k % CYCLE]
        msg = T["sensor_msgs/msg/LaserScan"](
            header=header(stamp, "laser"),
            angle_min=-math.pi / 2,
            angle_max=-math.pi / 2 + inc * (r.size - 1),
            angle_increment=inc,
            time_increment=0.0,
            scan_time=0.1,
            range_min=0.05,
            range_max=10.0,
            ranges=r,
            intensities=empty,
        )
        w.write(conn, stamp + 1_000_000, ts.serialize_ros1(msg, conn.msgtype))
    w.close()


@dataclass
class BagSoakResult:
    """What :func:`soak_bag` measured: memory (MiB) at fractions of the frames, the run's output sizes (bytes)."""

    frames: int
    frames_written: int
    returncode: int
    elapsed_s: float
    rss_at: dict[int, float] = field(default_factory=dict)
    peak_rss_mib: float = 0.0
    outputs: dict[str, int] = field(default_factory=dict)
    bag_bytes: int = 0
    command: str = ""


def _tree_rss_mib(proc: psutil.Process) -> float:
    total = 0
    for p in [proc, *proc.children(recursive=True)]:
        try:
            total += p.memory_info().rss
        except psutil.Error:
            pass
    return total / 2**20


def _rows(path: Path) -> int:
    """Frames written so far: the rows of ``frames.csv`` (its lines but the header)."""
    try:
        with path.open("rb") as f:
            return max(0, sum(chunk.count(b"\n") for chunk in iter(lambda: f.read(1 << 20), b"")) - 1)
    except OSError:
        return 0


def soak_bag(frames: int, workdir: Path, *, period_s: float = 0.5) -> BagSoakResult:
    """Write the soak bag of ``frames`` scans in ``workdir`` and run ``pfpeople run`` on it, sampling memory."""
    bag, out = workdir / "soak.bag", workdir / "soak_run"
    write_soak_bag(bag, frames)
    cmd = [sys.executable, "-m", "pfpeople.cli", "run", str(bag), "--driver", "/scan", "--out", str(out)]
    cmd += ["--no-progress", "--overwrite"]
    res = BagSoakResult(frames=frames, frames_written=0, returncode=-1, elapsed_s=0.0, bag_bytes=bag.stat().st_size)
    res.command = " ".join(cmd)
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=dict(os.environ))
    ps = psutil.Process(proc.pid)
    marks = [(10, frames // 10), (50, frames // 2)]
    polls, last = 0, 0.0
    while proc.poll() is None:
        rss = _tree_rss_mib(ps)
        last = rss or last  # the last sample of the running tree: memory at 100 % of the frames
        res.peak_rss_mib = max(res.peak_rss_mib, rss)
        polls += 1
        if marks and polls % 4 == 0 and _rows(out / "frames.csv") >= marks[0][1]:
            res.rss_at[marks.pop(0)[0]] = rss
        time.sleep(period_s)
    res.elapsed_s = time.perf_counter() - t0
    res.returncode = proc.returncode
    sys.stdout.write(proc.stdout.read().decode(errors="replace")[-2000:] if proc.stdout else "")
    res.rss_at[100] = last
    res.frames_written = _rows(out / "frames.csv")
    res.outputs = {p.name: p.stat().st_size for p in sorted(out.iterdir()) if p.is_file()} if out.is_dir() else {}
    return res
