"""Benchmark of ``pfpeople node``: latency per scan and dropped scans at several playback rates.

For each rate of ``--rates`` (default 1 and 4): a ROS master of its own on a free loopback port, ``pfpeople node``
(its default mode: a scan a newer one waits behind is dropped and counted), a subscriber to ``/pfpeople/people``
(:mod:`evaluation.bench.live_ros`), ``rosbag play -r RATE`` of the bag; the node's own figures (``--stats``: a
scan's arrival at the node's rospy bridge -> its frame's results handed to it, wall clock) are printed as one table
row per rate: frames published, scans dropped, warm-up frames (those of the messages that arrived while the run was
set up, left out of the latency), latency p50 / p90 / p99 / max (ms), and the people messages the subscriber got::

    python -m evaluation.bench.node [--bag BAG --config TOML] [--scene lobby --frames 300] [--rates 1 4]
        [--work DIR] [--json]

Without ``--bag`` a scan-level scene is simulated into ``--work`` (``--scene``, default ``lobby``: 768 beams at
7.5 Hz, odometry and TF; its configuration with ``[output] frame = "odom"``). Needs ROS 1 (Debian's packages).
Wall-clock figures depend on the machine and its load; tests never assert them.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

__all__ = ["main", "measure"]


def _scene(name: str, frames: int, work: Path) -> tuple[Path, Path]:
    from evaluation.scenarios.scan import write_scene_bag

    sb = write_scene_bag(name, work / "scene", frames=frames, seed=1, overwrite=True)
    toml = sb.run_toml.with_name(f"{name}_odom.toml")
    toml.write_text(sb.run_toml.read_text() + '\n[output]\nframe = "odom"\n')
    return sb.bag, toml


def measure(bag: Path, config: Path, rate: float, work: Path) -> dict[str, Any]:
    """The node's figures at one playback ``rate`` (see the module docstring)."""
    from evaluation.bench.live_ros import Recorder, ros_world

    stats_path = work / f"stats_{rate:g}.json"
    with ros_world(work / f"world_{rate:g}") as world:
        node = world.node(config, "--stats", str(stats_path))
        recorder = Recorder(world, ["/pfpeople/people"])
        try:
            recorder.wait_connected(120.0)
            t0 = time.monotonic()
            world.play(bag, rate=rate).wait()
            played = time.monotonic() - t0
            time.sleep(2.0)
        finally:
            node.terminate()
            node.wait(60)
            recorder.close()
    out: dict[str, Any] = json.loads(stats_path.read_text())
    out.update(rate=rate, played_s=played, people_messages=len(recorder.records))
    return out


def _row(r: dict[str, Any]) -> str:
    lat = r["latency_ms"]
    return (
        f"{r['rate']:>5g}x  {r['frames']:>6d}  {r['dropped']:>7d}  {r['warm_up_frames']:>7d}  "
        f"{lat['p50']:>7.1f}  {lat['p90']:>7.1f}  {lat['p99']:>7.1f}  {lat['max']:>7.1f}  {r['people_messages']:>7d}"
    )


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m evaluation.bench.node", description=__doc__.split("\n")[0])
    p.add_argument("--bag", help="a ROS 1 bag to play (default: a simulated scene)")
    p.add_argument("--config", help="its run configuration (TOML)")
    p.add_argument("--scene", default="lobby", help="scan-level scene simulated without --bag (default lobby)")
    p.add_argument("--frames", type=int, default=300, help="scans of the simulated scene (default 300)")
    p.add_argument("--rates", type=float, nargs="+", default=[1.0, 4.0], help="playback rates (default 1 4)")
    p.add_argument("--work", help="working folder (default a temporary one)")
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = p.parse_args(argv)
    if bool(args.bag) != bool(args.config):
        p.error("--bag and --config go together")
    with tempfile.TemporaryDirectory(prefix="pfpeople-node-bench-") as tmp:
        work = Path(args.work or tmp)
        work.mkdir(parents=True, exist_ok=True)
        bag, config = (Path(args.bag), Path(args.config)) if args.bag else _scene(args.scene, args.frames, work)
        rows = [measure(bag, config, rate, work) for rate in args.rates]
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    print(f"pfpeople node on {bag.name} (latency per scan, ms: arrival at the node -> results published)")
    print(" rate  frames  dropped  warm-up      p50      p90      p99      max   people")
    for r in rows:
        print(_row(r))
    return 0


if __name__ == "__main__":
    sys.exit(main())
