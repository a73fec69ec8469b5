"""Benchmark of ``pfpeople batch`` on Dask: speed-up of 2 workers over 1, and the per-task overhead.

``python -m evaluation.bench.batch [--bags 4] [--scans 300] [--scene corridor | --synthetic] [--out DIR]``
writes ``--bags`` bags: the scan-level simulator's scene (``evaluation.scenarios.scan.write_scene_bag``, seeds
0, 1, ..., with the run configuration it writes) when that simulator is installed, otherwise (or with
``--synthetic``) this module's ROS 1 bags (:func:`write_synthetic_bag`: a laser-only scene of people walking
past a standing robot, legs ray-cast with :func:`pfpeople.detect.synthetic.render_scan`, grid filter and one
leg detector). It then runs the batch on local clusters of worker processes (``threads_per_worker=1``) with 1 and 2
workers and prints the wall times (cluster start included and excluded), the speed-up, and the per-task overhead: the
wall time per task of a batch of trivial tasks on the started 2-worker cluster (submit, schedule, run, gather). The
speed-up is bounded by the CPU this session can get: on a machine shared with other jobs, Linux's autogroup scheduler
gives each session (terminal, job runner) a fair share of the cores however many processes it starts, so more workers
cannot go faster than that share. The benchmark prints the cores the tasks obtained (their threads' CPU time over the
wall time) so a missing speed-up can be told apart from a Dask overhead.

:func:`write_synthetic_bag` and :data:`SYNTHETIC_CONFIG` are also used by the batch tests.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import math
import os
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from pfpeople.config import BagConfig, DetectorConfig, load_config
from pfpeople.detect.synthetic import render_scan

__all__ = ["SYNTHETIC_CONFIG", "main", "write_synthetic_bag"]

#: The run configuration of the synthetic bags: frames driven by /scan, one leg detector, no odometry.
SYNTHETIC_CONFIG = BagConfig(driver="/scan", detectors=(DetectorConfig(name="laser_legs", kind="leg", topic="/scan"),))

_T0_NS = 1_000 * 1_000_000_000


def write_synthetic_bag(
    path: str | Path,
    *,
    n_scans: int = 50,
    n_people: int = 2,
    rng: np.random.Generator,
    dt: float = 0.1,
    chunk_threshold: int | None = None,
) -> Path:
    """A ROS 1 bag of ``n_scans`` LaserScans (``/scan``, frame ``laser``, 0.5 deg beams over 180 deg) at ``dt``.

    People walk on straight lines at 0.3-1.2 m/s, starting 2-7 m ahead and -3..3 m aside (laser frame); each
    is two legs (circles of 6 cm radius 0.3 m apart across the walking direction). No odometry, no TF: the
    grid frame is the laser frame. ``chunk_threshold`` (bytes) sets rosbags' chunk size (small chunks let a test
    corrupt the end of a bag only).

    Returns
    -------
    Path
        ``path``.
    """
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    if n_scans < 1 or n_people < 0:
        raise ValueError(f"n_scans must be >= 1 and n_people >= 0, got {n_scans}, {n_people}")
    ts = get_typestore(Stores.ROS1_NOETIC)
    T = ts.types
    start = np.column_stack([rng.uniform(2.0, 7.0, n_people), rng.uniform(-3.0, 3.0, n_people)])
    heading = rng.uniform(-math.pi, math.pi, n_people)
    speed = rng.uniform(0.3, 1.2, n_people)
    vel = np.column_stack([np.cos(heading), np.sin(heading)]) * speed[:, None]
    inc = math.radians(0.5)
    p = Path(path)
    writer = Writer(p)
    if chunk_threshold is not None:
        writer.chunk_threshold = chunk_threshold
    with writer as w:
        conn = w.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=ts)
        for k in range(n_scans):
            stamp = _T0_NS + round(k * dt * 1e9)
            circles = []
            for (x, y), (vx, vy) in zip(start + vel * k * dt, vel, strict=True):
                n = math.hypot(vx, vy) or 1.0
                ox, oy = -vy / n * 0.15, vx / n * 0.15
                circles += [(x + ox, y + oy, 0.06), (x - ox, y - oy, 0.06)]
            ranges = render_scan(circles=circles, angle_increment=inc).ranges.astype(np.float32)
            header = T["std_msgs/msg/Header"](
                seq=k,
                stamp=T["builtin_interfaces/msg/Time"](sec=stamp // 10**9, nanosec=stamp % 10**9),
                frame_id="laser",
            )
            msg = T["sensor_msgs/msg/LaserScan"](
                header=header,
                angle_min=-math.pi / 2,
                angle_max=-math.pi / 2 + inc * (len(ranges) - 1),
                angle_increment=inc,
                time_increment=0.0,
                scan_time=dt,
                range_min=0.05,
                range_max=10.0,
                ranges=ranges,
                intensities=np.zeros(0, dtype=np.float32),
            )
            w.write(conn, stamp + 1_000_000, ts.serialize_ros1(msg, "sensor_msgs/msg/LaserScan"))
    return p


def scene_bags(out_dir: Path, n_bags: int, n_scans: int, scene: str) -> tuple[list[Path], BagConfig] | None:
    """``n_bags`` bags of a scan-level simulator scene (seeds 0, 1, ...) and their run configuration.

    None when the scan-level simulator (``evaluation.scenarios.scan.write_scene_bag``) is not installed.
    """
    try:
        scan = importlib.import_module("evaluation.scenarios.scan")
        write_scene_bag = scan.write_scene_bag
    except (ImportError, AttributeError):
        return None
    made = [write_scene_bag(scene, out_dir, seed=k, frames=n_scans, name=f"{scene}{k}") for k in range(n_bags)]
    return [m.bag for m in made], load_config(made[0].run_toml)


def _noop(k: int) -> int:
    return k


def _timed_batch(
    bags: Sequence[Path], config: BagConfig, out: Path, workers: int
) -> tuple[float, float, list[dict[str, Any]]]:
    """(wall with cluster start, wall of the tasks alone, rows) of one batch on a fresh local cluster."""
    from pfpeople.pipeline.batch import dask_client, run_batch

    t0 = time.perf_counter()
    with dask_client(workers=workers) as client:
        client.wait_for_workers(workers)
        t1 = time.perf_counter()
        rows = run_batch(bags, config, out, client=client, progress=False)
        t2 = time.perf_counter()
    return t2 - t0, t2 - t1, rows


def _overhead(workers: int, n_tasks: int) -> float:
    """Seconds per trivial task on a started local cluster (submit, schedule, run, gather)."""
    from pfpeople.pipeline.batch import dask_client, run_tasks

    with dask_client(workers=workers) as client:
        client.wait_for_workers(workers)
        run_tasks(client, _noop, [(0,)], keys=["warm-up"], on_error=lambda i, e: None, progress=False)
        t0 = time.perf_counter()
        keys = [f"noop-{k}" for k in range(n_tasks)]
        run_tasks(client, _noop, [(k,) for k in range(n_tasks)], keys=keys, on_error=lambda i, e: None, progress=False)
        return (time.perf_counter() - t0) / n_tasks


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m evaluation.bench.batch", description=__doc__.split("\n")[0])
    parser.add_argument("--bags", type=int, default=4, help="number of synthetic bags (default 4)")
    parser.add_argument("--scans", type=int, default=300, help="scans per bag (default 300)")
    parser.add_argument("--noop-tasks", type=int, default=200, help="trivial tasks for the overhead (default 200)")
    parser.add_argument("--scene", default="corridor", help="scan-level simulator scene (default corridor)")
    parser.add_argument("--synthetic", action="store_true", help="this module's synthetic bags, not the simulator's")
    parser.add_argument("--out", type=Path, default=None, help="working folder (default: a temporary one)")
    args = parser.parse_args(argv)
    logging.getLogger("distributed").setLevel(logging.WARNING)
    if args.bags < 1 or args.scans < 1 or args.noop_tasks < 1:
        parser.error("--bags, --scans and --noop-tasks must be positive")
    with tempfile.TemporaryDirectory() as tmp:
        work = args.out if args.out is not None else Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        made = None if args.synthetic else scene_bags(work, args.bags, args.scans, args.scene)
        if made is None:
            rng = np.random.default_rng(12)
            bags = [write_synthetic_bag(work / f"walk{k}.bag", n_scans=args.scans, rng=rng) for k in range(args.bags)]
            config, what = SYNTHETIC_CONFIG, "synthetic bags (ROS 1, people walking past a standing laser)"
        else:
            bags, config = made
            what = f"bags of the scan-level scene {args.scene!r} (seeds 0..{args.bags - 1})"
        load = os.getloadavg()[0] if hasattr(os, "getloadavg") else math.nan
        print(
            f"{args.bags} {what} x {args.scans} scans, {config.filter.kind} filter, "
            f"detectors {[d.name for d in config.detectors]}; "
            f"{os.cpu_count()} cores, load average {load:.1f} before the run"
        )
        times: dict[int, tuple[float, float]] = {}
        cores: dict[int, float] = {}
        for workers in (1, 2):
            total, tasks, rows = _timed_batch(bags, config, work / f"runs_{workers}w", workers)
            bad = [r for r in rows if r["status"] != "complete"]
            if bad:
                print(f"failed: {bad}", file=sys.stderr)
                return 1
            fps = np.mean([r["fps"] for r in rows])
            busy = sum(r["wall_s"] for r in rows)
            cpu = sum(r["cpu_s"] for r in rows)
            times[workers] = (total, tasks)
            cores[workers] = cpu / tasks
            print(
                f"{workers} worker(s): {tasks:6.2f} s for the tasks, {total:6.2f} s with cluster start; "
                f"pipeline {fps:.0f} frames/s per task; {busy / tasks:.2f} tasks running and "
                f"{cpu / tasks:.2f} cores used on average, {cpu:.1f} CPU s in all"
            )
        print(
            f"speed-up 2 over 1 workers: {times[1][1] / times[2][1]:.2f}x (tasks), "
            f"{times[1][0] / times[2][0]:.2f}x (with cluster start)"
        )
        if cores[2] < 1.5:
            print(
                f"note: the 2 workers obtained {cores[2]:.2f} cores in all (1 worker: {cores[1]:.2f}): the CPU "
                "available to this session limits the speed-up, not the batch (see the module docstring)"
            )
        per_task = _overhead(2, args.noop_tasks)
        print(f"per-task overhead (trivial tasks, 2 workers, {args.noop_tasks} tasks): {1e3 * per_task:.1f} ms/task")
    return 0


if __name__ == "__main__":
    sys.exit(main())
