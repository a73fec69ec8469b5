"""Benchmark of one full grid-filter iteration (both predictions, fusion of 3 detectors, update).

Run ``python -m evaluation.bench.grid [--baseline REV] [--clock cpu]``. It prints the median time per iteration
on one core (wall clock, or with ``--clock cpu`` the thread's CPU time) for 30 x 30, 100 x 100 and 300 x 300
grids of 0.3 m cells (the paper's form and the linear form), the time per cell (constant when cost is linear in
cells), the same in the previous release (``--baseline REV``, default
:data:`evaluation.bench.release_baseline.PREVIOUS_RELEASE`, checked out under ``.bench/``; ``none`` skips it) and
the ratio, the speed-up over the paper's MATLAB prototype (1.78 s per iteration on an Intel Core2 Duo
1.8 GHz, Sect. 4) and over a plain-loop Python implementation of the same equations measured in the same run
at 30 x 30: the people prediction and the fusion and update as the loops of :mod:`gridbridge.reference` (hard
firing, full fields of view), the sensor warp the vectorised numpy one. Each variant runs in its own process
(``--worker`` prints one JSON line), whose peak RSS is printed too.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, as the speed target says

import argparse  # noqa: E402
import functools  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import resource  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable, Sequence  # noqa: E402
from typing import Any, Literal  # noqa: E402

import numpy as np  # noqa: E402

from gridbridge import GridFilter, GridSpec, Odometry, people_motion_kernel, predict_sensor  # noqa: E402
from gridbridge.reference import fuse_and_update_loop, predict_people_loop  # noqa: E402

PAPER_SECONDS = 1.78
FORMS: tuple[Literal["paper", "linear"], ...] = ("paper", "linear")

#: The clocks a benchmark can time with: wall clock, or this thread's CPU time (less sensitive to other load on
#: a shared machine; ``--clock cpu``).
CLOCKS: dict[str, Callable[[], float]] = {"wall": time.perf_counter, "cpu": time.thread_time}
_clock = {"now": time.perf_counter}


def set_clock(name: str) -> None:
    """Time with ``CLOCKS[name]`` from now on (this process)."""
    _clock["now"] = CLOCKS[name]


def median_ms(fn: Callable[[], object], repeats: int, warmup: int = 3) -> float:
    for _ in range(warmup):
        fn()
    times = []
    clock = _clock["now"]
    for _ in range(repeats):
        t0 = clock()
        fn()
        times.append(clock() - t0)
    return 1e3 * statistics.median(times)


def scene(spec: GridSpec, rng: np.random.Generator) -> list[np.ndarray]:
    """Detections of a busy frame: people spread over the grid, each detector seeing some of them."""
    n_people = max(3, spec.n_cells // 150)
    people = np.column_stack((rng.uniform(spec.x0, spec.x1, n_people), rng.uniform(spec.y0, spec.y1, n_people)))
    return [people[rng.random(n_people) < p] for p in (0.7, 0.6, 0.5)]


def measure_grid(sizes: Sequence[int] = (30, 100, 300), repeats: int = 200, seed: int = 0) -> list[dict[str, Any]]:
    """Median ms of one full iteration per grid side and form; ``repeats`` at 30 x 30, scaled down above."""
    rng = np.random.default_rng(seed)
    odo = Odometry(v=0.35, omega=0.2)
    rows = []
    for side in sizes:
        spec = GridSpec.centred_on_edge(side, side, 0.3)
        dets = scene(spec, rng)
        n_rep = max(5, repeats * 900 // spec.n_cells)
        for form in FORMS:
            f = GridFilter(spec, form=form)
            ms = median_ms(functools.partial(f.step, dets, odo, 0.1), n_rep)
            rows.append(
                {
                    "side": side,
                    "form": form,
                    "cells": spec.n_cells,
                    "ms": ms,
                    "us_per_cell": 1e3 * ms / spec.n_cells,
                    "speedup_vs_paper": PAPER_SECONDS * 1e3 / ms,
                }
            )
    return rows


def measure_plain_loops(repeats: int = 5, seed: int = 0) -> float:
    """Median ms of the same iteration with the plain-loop reference (30 x 30, paper form)."""
    rng = np.random.default_rng(seed)
    odo = Odometry(v=0.35, omega=0.2)
    spec = GridSpec()
    f = GridFilter(spec)
    out = f.step(scene(spec, rng), odo, 0.1)
    kernel = people_motion_kernel(spec, form="paper")
    fired = out.fired > 0
    ppv = np.array([d.ppv for d in f.detectors])
    fnr = np.array([d.fnr for d in f.detectors])

    def naive() -> None:
        people = predict_people_loop(f.belief, kernel, 0.5, "paper")
        prior = predict_sensor(people, spec, odo, 0.1, noise=f.noise)
        fuse_and_update_loop(prior, fired, ppv, fnr)

    return median_ms(naive, repeats, warmup=1)


def measure_plain_loops_numpy(repeats: int = 5, seed: int = 0) -> float:
    """:func:`measure_plain_loops` with the sensor warp on its numpy path (the baseline the speed-up has always
    been measured against; the compiled warp would make the plain loops faster too)."""
    try:
        from gridbridge import jit
    except ImportError:  # a release without compiled kernels
        return measure_plain_loops(repeats, seed)
    with jit.override(False):
        return measure_plain_loops(repeats, seed)


def _rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def worker(sizes: Sequence[int], repeats: int, plain: bool) -> dict[str, Any]:
    """The worker's measurements: :func:`measure_grid`'s rows, the plain loops (NaN unless ``plain``), peak RSS."""
    rows = measure_grid(sizes, repeats)
    return {"rows": rows, "plain_ms": measure_plain_loops_numpy(15) if plain else math.nan, "rss_mb": _rss_mb()}


def collect(sizes: Sequence[int], repeats: int, baseline: str, clock: str = "wall") -> dict[str, Any]:
    """This checkout's worker (with the plain loops) and the previous release's, each in its own process."""
    from evaluation.bench.release_baseline import REPO, release_checkout, run_worker

    args = ["--worker", "--sizes", *map(str, sizes), "--repeats", str(repeats), "--clock", clock]
    now = run_worker(REPO, "evaluation.bench.grid", [*args, "--plain"])
    rel = None
    if baseline.lower() != "none":
        rel = run_worker(release_checkout(baseline), "evaluation.bench.grid", args)
    return {"now": now, "release": rel}


def _f(value: float, spec: str, width: int) -> str:
    return f"{'-':>{width}}" if math.isnan(value) else f"{value:{width}{spec}}"


def table(data: dict[str, Any]) -> list[str]:
    """The table's lines from :func:`collect`'s result."""
    now, rel = data["now"], data["release"]
    rel_ms = {(r["side"], r["form"]): r["ms"] for r in rel["rows"]} if rel else {}
    plain = now["plain_ms"]
    header = (
        f"{'grid':>9} {'form':>7} {'cells':>7} {'now ms':>8} {'us/cell':>8} {'release':>8} {'ratio':>6} "
        f"{'x paper':>8} {'x loops':>8}"
    )
    lines = [header, "-" * len(header)]
    for r in now["rows"]:
        old = rel_ms.get((r["side"], r["form"]), math.nan)
        loops = plain / r["ms"] if r["side"] == 30 and r["form"] == "paper" else math.nan
        cells = [f"{r['side']:>4}x{r['side']:<4}", f"{r['form']:>7}", f"{r['cells']:>7}", f"{r['ms']:8.3f}"]
        cells += [f"{r['us_per_cell']:8.3f}", _f(old, ".3f", 8), _f(old / r["ms"], ".2f", 6)]
        cells += [f"{r['speedup_vs_paper']:8.0f}", _f(loops, ".0f", 8)]
        lines.append(" ".join(cells))
    lines.append(f"plain-loop Python baseline, 30x30 paper form (numpy warp): {plain:.1f} ms/iter")
    lines.append(f"peak RSS: now {now['rss_mb']:.0f} MB" + (f", release {rel['rss_mb']:.0f} MB" if rel else ""))
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[30, 100, 300], help="grid sides (cells)")
    parser.add_argument("--repeats", type=int, default=200, help="timed iterations at 30 x 30 (fewer above)")
    parser.add_argument("--baseline", default=None, help="git revision of the previous release ('none': skip)")
    parser.add_argument("--worker", action="store_true", help="measure in this process, print one JSON line")
    parser.add_argument("--plain", action="store_true", help="(worker) also time the plain-loop baseline")
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="wall", help="wall clock or thread CPU time")
    args = parser.parse_args(argv)
    if args.repeats < 1 or any(n < 1 for n in args.sizes):
        parser.error("--repeats must be >= 1 and --sizes positive")
    set_clock(args.clock)
    if args.worker:
        print(json.dumps(worker(args.sizes, args.repeats, args.plain)), flush=True)
        return 0
    if args.baseline is None:
        from evaluation.bench.release_baseline import PREVIOUS_RELEASE

        args.baseline = PREVIOUS_RELEASE
    print(f"one full iteration, median over repeats, one core (OMP_NUM_THREADS={os.environ['OMP_NUM_THREADS']})")
    print(f"previous release {args.baseline}, measured in the same run; clock: {args.clock}")
    for line in table(collect(args.sizes, args.repeats, args.baseline, args.clock)):
        print(line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
