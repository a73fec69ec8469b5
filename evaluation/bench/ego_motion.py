"""Benchmark of the ego-motion sigma points (:func:`gridbridge.ego_motion_sigma_points`), the grid and particle
filters' per-frame sensor-motion step, against a baseline revision in the same run.

Run ``python -m evaluation.bench.ego_motion [--calls 20000] [--repeat 5] [--baseline REV]``. Each code measures in
its own process (``--worker`` prints one JSON line), interleaved ``--repeat`` times: the median microseconds per
call over odometry that changes every call, as a robot's does (the function's cache never hits then), with the
default noise and a lateral speed (an off-axis laser). The baseline is ``--baseline REV`` (default
:data:`evaluation.bench.release_baseline.PREVIOUS_RELEASE`; ``none``: this code only); ``ratio`` is baseline / this.
Times depend on the machine; tests never assert them.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core

import argparse  # noqa: E402
import importlib.util  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Sequence  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[2]


def _local(name: str) -> Any:
    """A module of this checkout's ``evaluation`` folder, loaded from its file (the release may not have it)."""
    spec = importlib.util.spec_from_file_location(f"_bench_{name}", Path(__file__).with_name(f"{name}.py"))
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def sigma_points_us(calls: int, seed: int = 0) -> float:
    """Microseconds per :func:`gridbridge.ego_motion_sigma_points` call, each with new odometry (no cache hit)."""
    from gridbridge import Odometry, SensorMotionNoise, ego_motion_sigma_points

    rng = np.random.default_rng(seed)
    controls = np.column_stack((rng.uniform(0, 1.5, calls), rng.uniform(-1, 1, calls), rng.uniform(-0.2, 0.2, calls)))
    odos = [Odometry(v=v, omega=w, vy=vy) for v, w, vy in controls.tolist()]
    noise = SensorMotionNoise()
    t0 = time.perf_counter()
    for odo in odos:
        ego_motion_sigma_points(odo, 0.1333, noise)
    return 1e6 * (time.perf_counter() - t0) / calls


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m evaluation.bench.ego_motion", description=__doc__.split("\n")[0])
    ap.add_argument("--calls", type=int, default=20000, help="calls per measurement")
    ap.add_argument("--repeat", type=int, default=5, help="interleaved rounds (medians)")
    ap.add_argument("--baseline", default=None, help="git revision to compare against ('none': no comparison)")
    ap.add_argument("--worker", action="store_true", help="measure in this process, print one JSON line")
    a = ap.parse_args(sys.argv[1:] if argv is None else argv)
    if a.worker:
        print(json.dumps({"us": sigma_points_us(a.calls)}))
        return 0
    rel = _local("release_baseline")
    roots = {"this": REPO}
    rev = a.baseline if a.baseline is not None else rel.PREVIOUS_RELEASE
    if str(rev).lower() != "none":
        roots["baseline"] = rel.release_checkout(rev)
    runs: dict[str, list[float]] = {name: [] for name in roots}
    for _ in range(max(a.repeat, 1)):
        for name, root in roots.items():
            runs[name].append(
                rel.run_worker(root, "evaluation.bench.ego_motion", ["--worker", "--calls", str(a.calls)])["us"]
            )
    med = {name: statistics.median(v) for name, v in runs.items()}
    line = f"ego_motion_sigma_points: this {med['this']:.1f} us/call"
    if "baseline" in med:
        line += f", baseline {rev} {med['baseline']:.1f} us/call, ratio {med['baseline'] / med['this']:.2f}"
    print(
        f"code: {', '.join(f'{n} = {p}' for n, p in roots.items())}; {a.repeat} interleaved rounds of {a.calls} calls"
    )
    print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
