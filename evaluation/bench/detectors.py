"""Benchmark of the laser detectors, each alone, on one core: milliseconds per scan.

Run ``python -m evaluation.bench.detectors [--scene lobby] [--frames 300] [--repeat 3] [--clock cpu]``. It simulates a
scan-level scene (768 beams over 270 deg at 7.5 Hz for the built-in ones; :mod:`evaluation.scenarios.scan`), then
times every detector over its scans in turn, ``--repeat`` interleaved rounds, each detector once per round with its
ego-motion given as a run gives it: ``laser_legs`` (:class:`pfpeople.detect.LegDetector`), ``laser_boosted``,
``laser_single_legs`` (the boosted legs, classified again: its own cost), ``laser_learned`` (the shipped learned model)
and ``laser_motion``. It prints the median ms per scan of each, and its ratio to the boosted detector's in the same
run (the machine's speed drifts between runs; the ratio does not). Times depend on the machine; tests never assert
them.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core

import argparse  # noqa: E402
import statistics  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable, Sequence  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

CLOCKS: dict[str, Callable[[], float]] = {"wall": time.perf_counter, "cpu": time.thread_time}


def _detectors() -> dict[str, Callable[[], Any]]:
    from pfpeople.detect import (
        BoostedSegmentDetector,
        LearnedPeopleDetector,
        LegDetector,
        MotionDetector,
        SingleLegDetector,
    )

    return {
        "laser_legs": LegDetector,
        "laser_boosted": BoostedSegmentDetector,
        "laser_single_legs": SingleLegDetector,
        "laser_learned": LearnedPeopleDetector,
        "laser_motion": MotionDetector,
    }


def _scans(scene: str, frames: int) -> list[Any]:
    """The scene's labelled scans (with the laser's motion from its odometry)."""
    from evaluation.scenarios.scan import write_scene_bag
    from pfpeople.detect.learned.samples import simulated_scans

    with tempfile.TemporaryDirectory() as tmp:
        sb = write_scene_bag(scene, Path(tmp), frames=frames)
        return simulated_scans(sb.bag, sb.gt_csv, source=scene)


def time_detector(make: Callable[[], Any], scans: Sequence[Any], clock: Callable[[], float]) -> float:
    """Milliseconds per scan of a fresh detector over ``scans`` (the ego-motion given first, as in a run); the
    scans are copied first so that a detector's per-scan caches start cold, as on new messages."""
    from gridbridge.geometry import Pose2D
    from pfpeople.sensors import LaserScan

    det = make()
    fresh = [
        LaserScan(
            **{
                k: getattr(s.scan, k)
                for k in ("ranges", "angle_min", "angle_increment", "range_min", "range_max", "stamp_ns", "frame_id")
            }
        )
        for s in scans
    ]
    det.detect(fresh[0])  # compile and load before timing
    observe = getattr(det, "observe_motion", None)
    t0 = clock()
    for ls, scan in zip(scans, fresh, strict=True):
        if observe is not None:
            known = bool(np.isfinite(ls.ego).all())
            observe(Pose2D(x=ls.ego[0], y=ls.ego[1], yaw=ls.ego[2]) if known else None)
        det.detect(scan)
    return 1e3 * (clock() - t0) / len(scans)


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m evaluation.bench.detectors", description=__doc__.split("\n")[0])
    p.add_argument("--scene", default="lobby")
    p.add_argument("--frames", type=int, default=300)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--clock", choices=sorted(CLOCKS), default="cpu")
    args = p.parse_args(argv)
    scans = _scans(args.scene, args.frames)
    beams = scans[0].scan.ranges.size
    makers = _detectors()
    times: dict[str, list[float]] = {name: [] for name in makers}
    for _ in range(args.repeat):
        for name, make in makers.items():
            times[name].append(time_detector(make, scans, CLOCKS[args.clock]))
    base = statistics.median(times["laser_boosted"])
    print(
        f"scene {args.scene}: {len(scans)} scans of {beams} beams, {args.clock} clock, one core, {args.repeat} rounds"
    )
    print(f"{'detector':<20}{'ms/scan':>9}{'/ boosted':>11}  rounds (ms)")
    for name, ts in times.items():
        med = statistics.median(ts)
        rounds = ", ".join(f"{t:.2f}" for t in ts)
        print(f"{name:<20}{med:>9.2f}{med / base:>11.2f}  {rounds}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
