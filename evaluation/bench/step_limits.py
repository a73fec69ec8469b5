"""One filter step at the edges of the documented limits, on the paper's 30 x 30 grid: time and peak memory.

Run ``python -m evaluation.bench.step_limits``. For each filter (the grid filter in the paper's and the linear form,
the recommended grid filter, the particle filter with 10 000 particles and the recommended particle filter) and each
step ``dt`` up to :data:`gridbridge.limits.MAX_DT_S` (10 s) at 0.3 m cells, and at 10 s on the finest resolution the
limits allow on 30 x 30 (the people-motion neighbourhood at :data:`gridbridge.limits.MAX_STEP_OPERATIONS`), it runs,
in a process of its own, a warm-up step of 0.1 s (compiling the kernels) and then the step measured, and prints the
step's wall-clock time, the process's peak resident memory (``ru_maxrss``) and that peak before the step (the
interpreter, numpy, numba and the compiled kernels). The target: no step within the limits above 1 GB or 5 s.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import resource  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from gridbridge.limits import MAX_DT_S, MAX_STEP_OPERATIONS  # noqa: E402

FILTERS = ("grid-paper", "grid-linear", "recommended-grid", "particle", "recommended-particle")
STEPS_S = (0.1, 1.0, 2.0, 5.0, MAX_DT_S)


def finest_resolution(n_cells: int = 900, v_max: float = 10.44, dt: float = MAX_DT_S) -> float:
    """The finest resolution (m) whose people-motion step of ``dt`` stays within the operations limit on ``n_cells``
    (radius ``R = ceil(v_max dt / r) + 1`` with ``n_cells (2 R + 1)^2 <= MAX_STEP_OPERATIONS``), rounded up to mm."""
    radius = math.floor((math.sqrt(MAX_STEP_OPERATIONS / n_cells) - 1) / 2)
    return math.ceil(v_max * dt / (radius - 1) * 1000) / 1000


def _filter(kind: str, resolution: float) -> Any:
    from gridbridge import GridFilter, GridSpec
    from pfpeople import recommended
    from pfpeople.particle.filter import ParticleFilter

    spec = GridSpec.centred_on_edge(30, 30, resolution)
    if kind in ("grid-paper", "grid-linear"):
        return GridFilter(spec, form="paper" if kind == "grid-paper" else "linear")
    if kind == "particle":
        return ParticleFilter(spec, n_particles=10_000, rng=np.random.default_rng(0))
    return recommended(spec, kind="grid" if kind == "recommended-grid" else "particle").filter


def _worker(kind: str, dt: float, resolution: float) -> None:
    """One case: a warm-up step, then the step measured; prints one JSON line."""
    filt = _filter(kind, resolution)
    dets = [np.array([[3.0, 0.5]])] + [np.zeros((0, 2))] * (len(filt.detectors) - 1)
    filt.step(dets, (0.5, 0.1), 0.1)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    t0 = time.perf_counter()
    filt.step(dets, (0.5, 0.1), dt)
    seconds = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps({"seconds": seconds, "peak_mb": peak, "before_mb": before}))


def _case(kind: str, dt: float, resolution: float) -> dict[str, Any]:
    cmd = [sys.executable, "-m", "evaluation.bench.step_limits", "--worker", kind, str(dt), str(resolution)]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True)
    result: dict[str, Any] = json.loads(out.stdout.strip().splitlines()[-1])
    return result


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--worker", nargs=3, metavar=("FILTER", "DT", "RES"), help=argparse.SUPPRESS)
    p.add_argument("--filters", nargs="+", default=list(FILTERS), choices=FILTERS)
    args = p.parse_args(argv)
    if args.worker:
        _worker(args.worker[0], float(args.worker[1]), float(args.worker[2]))
        return 0
    fine = finest_resolution()
    cases = [(dt, 0.3) for dt in STEPS_S] + [(MAX_DT_S, fine)]
    print("one step on a 30 x 30 grid after a 0.1 s warm-up step; peak RSS of the process (MB), before the step")
    print(f"{'filter':<22}{'dt (s)':>8}{'cell (m)':>10}{'step (s)':>10}{'peak MB':>10}{'before MB':>11}")
    worst_s = worst_mb = 0.0
    for kind in args.filters:
        for dt, res in cases:
            r = _case(kind, dt, res)
            worst_s, worst_mb = max(worst_s, r["seconds"]), max(worst_mb, r["peak_mb"])
            print(f"{kind:<22}{dt:>8g}{res:>10g}{r['seconds']:>10.3f}{r['peak_mb']:>10.0f}{r['before_mb']:>11.0f}")
    print(f"worst step: {worst_s:.2f} s; worst peak: {worst_mb:.0f} MB (target: 5 s, 1024 MB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
