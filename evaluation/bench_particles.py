"""Benchmark: particle filter ms/step against the grid filter and a filterpy-resampling baseline.

Run ``python -m evaluation.bench_particles [--repeats K] [--sizes N ...]`` (it pins one core, as
the targets are stated: 1e5 particles <= 10 ms/step and 1e6 <= 100 ms/step on the paper's 30 x 30 grid).

Scenario (fixed): the paper's grid and detectors; the robot drives at 0.5 m/s turning at 0.2 rad/s with the
default odometry noise; every frame the three detectors fire (laser-legs twice, laser-boosted twice, camera
once) at fixed positions; dt = 0.1 s. Each configuration runs ``--warmup`` steps, then ``--repeats`` timed
steps; the table gives the median ms per step.

Columns: ``pf`` is :class:`pfpeople.ParticleFilter` as configured by default (ESS-triggered resampling; the
``resampled`` column gives the fraction of timed steps that resampled). ``pf-forced`` resamples every step
with our systematic resampler; ``filterpy`` is the same, with ``filterpy.monte_carlo.systematic_resample`` (a
pure-Python loop on the global NumPy RNG, the baseline a user would otherwise write) in its place; ``ratio`` is
filterpy / pf-forced. The grid filter's ms/step (paper and linear forms) is measured in the same run.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, as the speed targets say

import argparse  # noqa: E402
import functools  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable, Sequence  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
from filterpy.monte_carlo import systematic_resample  # noqa: E402
from numpy.typing import NDArray  # noqa: E402

from evaluation.bench_grid import FORMS  # noqa: E402
from gridbridge import GridFilter, Odometry  # noqa: E402
from pfpeople.particle_filter import ParticleFilter  # noqa: E402

DETECTIONS = [
    np.array([[3.0, 0.5], [5.0, -1.0]]),
    np.array([[3.1, 0.4], [6.0, 2.0]]),
    np.array([[4.0, 0.0]]),
]
ODOMETRY = Odometry(v=0.5, omega=0.2)
DT = 0.1


def filterpy_systematic(weights: NDArray[np.float64], n: int, *, rng: np.random.Generator) -> NDArray[np.intp]:
    """filterpy's systematic resampler as a drop-in: ``len(weights)`` draws thinned evenly to ``n``.

    filterpy draws its offset from the global ``np.random``; it is seeded from ``rng`` so runs repeat.
    """
    np.random.seed(int(rng.integers(2**32)))  # noqa: NPY002 (filterpy reads the global RNG)
    w = np.asarray(weights, dtype=float)
    idx = systematic_resample(w / w.sum())
    pick = np.linspace(0, len(idx) - 1, n).astype(np.intp) if n < len(idx) else np.arange(len(idx))
    return np.asarray(idx[pick], dtype=np.intp)


def _time_steps(step: Callable[[], object], warmup: int, repeats: int) -> tuple[float, list[bool]]:
    """Median ms of ``step`` and whether each timed step resampled.

    Only the flag of each output is kept: holding on to the outputs (with 1e6 particles, 40 MB each) would make
    every later step allocate fresh pages and measure the allocator instead of the filter.
    """
    for _ in range(warmup):
        step()
    times, flags = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = step()
        times.append(time.perf_counter() - t0)
        flags.append(bool(getattr(out, "resampled", False)))
        del out
    return 1e3 * statistics.median(times), flags


def _pf_case(n: int, warmup: int, repeats: int, **kwargs: object) -> tuple[float, float]:
    pf = ParticleFilter(n_particles=n, rng=np.random.default_rng(2015), **kwargs)  # type: ignore[arg-type]
    ms, flags = _time_steps(lambda: pf.step(DETECTIONS, ODOMETRY, DT), warmup, repeats)
    frac = float(np.mean(flags))
    return ms, frac


def measure(sizes: Sequence[int], repeats: int, warmup: int, baseline_max: int) -> dict[str, Any]:
    """Measure the grid filter and, per particle count, the PF (ESS, forced) and the filterpy baseline.

    Returns ``{"grid": {form: ms}, "particles": [{"n", "pf_ms", "resampled", "forced_ms", "filterpy_ms",
    "ratio"}, ...]}`` (``filterpy_ms`` and ``ratio`` are NaN above ``baseline_max``).
    """
    _pf_case(max(sizes), 3, 1)  # untimed: lets the process grow its heap once, so the first row is not penalised
    grid = {}
    for form in FORMS:
        gf = GridFilter(form=form)
        grid[form], _ = _time_steps(functools.partial(gf.step, DETECTIONS, ODOMETRY, DT), warmup, repeats)
    rows = []
    for n in sizes:
        ms, frac = _pf_case(n, warmup, repeats)
        forced, _ = _pf_case(n, warmup, repeats, ess_threshold=2.0)
        base = math.nan
        if n <= baseline_max:
            base, _ = _pf_case(
                n, min(warmup, 1), max(3, repeats // 4), ess_threshold=2.0, resampler=filterpy_systematic
            )
        rows.append(
            {"n": n, "pf_ms": ms, "resampled": frac, "forced_ms": forced, "filterpy_ms": base, "ratio": base / forced}
        )
    return {"grid": grid, "particles": rows}


def run(sizes: Sequence[int], repeats: int, warmup: int, baseline_max: int) -> list[str]:
    """Measure and return the table's lines."""
    data = measure(sizes, repeats, warmup, baseline_max)
    lines = [f"grid filter ({form:6s})  {ms:8.2f} ms/step" for form, ms in data["grid"].items()]
    header = f"{'particles':>10} {'pf ms':>9} {'resampled':>9} {'pf-forced':>10} {'filterpy':>10} {'ratio':>7}"
    lines += ["", header, "-" * len(header)]
    for r in data["particles"]:
        tail = (
            f"{'skipped':>10} {'':>7}"
            if math.isnan(r["filterpy_ms"])
            else f"{r['filterpy_ms']:10.1f} {r['ratio']:7.1f}"
        )
        lines.append(f"{r['n']:>10d} {r['pf_ms']:9.2f} {r['resampled']:9.2f} {r['forced_ms']:10.2f} {tail}")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m evaluation.bench_particles", description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10_000, 100_000, 1_000_000])
    parser.add_argument("--repeats", type=int, default=20, help="timed steps per configuration (median)")
    parser.add_argument("--warmup", type=int, default=5, help="untimed steps first")
    parser.add_argument(
        "--baseline-max", type=int, default=1_000_000, help="largest N for the (slow) filterpy baseline"
    )
    args = parser.parse_args(argv)
    if args.repeats < 1 or args.warmup < 0 or any(n < 1 for n in args.sizes):
        parser.error("--repeats must be >= 1, --warmup >= 0 and --sizes positive")
    for line in run(args.sizes, args.repeats, args.warmup, args.baseline_max):
        print(line, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
