"""Benchmark of the scan simulator's ray caster (:func:`evaluation.scenarios.scan.raycast.cast_rays`).

Run ``python -m evaluation.bench.raycast [--scenes wheelchair lobby] [--frames 200] [--repeat 3] [--baseline REV]
[--clock cpu]``. Every measurement is a worker process (``--worker`` prints one JSON line) that times, one core:

* ``random``: ``cast_rays`` of 768 evenly spaced beams against 40 random circles and 30 random segments (median
  ms per call);
* per scene of ``--scenes``: the scan simulator over its first ``--frames`` scans (``simulate_scene``): the ray
  casts of those scans (ms per scan: ``cast_rays`` as the simulator calls it, a swept scan's blocks at once) and
  the simulator's whole loop per scan (``SceneSim.ms_per_scan``), and a SHA-256 of every simulated range.

It runs with three codes, interleaved, ``--repeat`` rounds: ``this`` (the compiled intersection loop,
:mod:`evaluation.scenarios.scan.raycast_kernels`), ``numpy`` (this checkout with ``PFPEOPLE_NUMBA=0``'s switch
off: the numpy code) and ``release`` (``--baseline REV``, default
:data:`evaluation.bench.release_baseline.PREVIOUS_RELEASE`; ``none`` skips it), and prints the medians, the same-run
ratios ``release / this`` and ``numpy / this`` (speed-ups) and whether the three simulated the same ranges
(``same``: the hashes agree). Times depend on the machine; tests never assert them.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core

import argparse  # noqa: E402
import hashlib  # noqa: E402
import importlib.util  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable, Iterator, Sequence  # noqa: E402
from contextlib import contextmanager, nullcontext  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
CLOCKS: dict[str, Callable[[], float]] = {"wall": time.perf_counter, "cpu": time.thread_time}


def _local(name: str) -> Any:
    """A module of this checkout's ``evaluation`` folder, loaded from its file (the release may not have it)."""
    spec = importlib.util.spec_from_file_location(f"_bench_{name}", Path(__file__).with_name(f"{name}.py"))
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def random_scene_ms(clock: Callable[[], float], calls: int = 300) -> float:
    """Median ms of ``cast_rays`` on 768 beams, 40 circles and 30 segments (the raycast module's old timing)."""
    from evaluation.scenarios.scan.raycast import beam_angles, cast_rays

    rng = np.random.default_rng(0)
    a = beam_angles(-0.75 * math.pi, 0.75 * math.pi, 768)
    circles = np.column_stack((rng.uniform(-8, 8, (40, 2)), rng.uniform(0.02, 0.08, 40)))
    segments = rng.uniform(-8, 8, (30, 4))
    for _ in range(5):  # the compiled loop loads (or compiles) at its first call
        cast_rays(a, circles=circles, segments=segments)
    times = []
    for _ in range(calls):
        t0 = clock()
        cast_rays(a, circles=circles, segments=segments)
        times.append(clock() - t0)
    return 1e3 * statistics.median(times)


@contextmanager
def _timed_casts(clock: Callable[[], float]) -> Iterator[list[float]]:
    """The simulator's ``cast_rays`` timed call by call (the seconds of each call appended to the list)."""
    from evaluation.scenarios.scan import simulate

    real = simulate.cast_rays
    spent: list[float] = []

    def timed(*args: Any, **kwargs: Any) -> Any:
        t0 = clock()
        try:
            return real(*args, **kwargs)
        finally:
            spent.append(clock() - t0)

    simulate.cast_rays = timed
    try:
        yield spent
    finally:
        simulate.cast_rays = real


def scene_figures(scene: str, frames: int, clock: Callable[[], float]) -> dict[str, Any]:
    """The simulator over ``frames`` scans of ``scene``: ray-cast ms per scan, loop ms per scan, ranges' hash."""
    from evaluation.scenarios.scan.simulate import simulate_scene

    simulate_scene(scene, frames=2)  # compiled code loaded before the timing
    with _timed_casts(clock) as spent:
        sim = simulate_scene(scene, frames=frames)
    digest = hashlib.sha256()
    for rec in sim.lasers:
        digest.update(np.ascontiguousarray(rec.ranges).tobytes())
    scans = sum(len(rec.times) for rec in sim.lasers)
    return {"cast_ms": 1e3 * sum(spent) / scans, "loop_ms": float(sim.ms_per_scan), "sha256": digest.hexdigest()}


def _kernels(on: bool) -> Any:
    """The compiled kernels on or off within the block (:func:`gridbridge.jit.override`; code without the
    switch runs as it is)."""
    try:
        from gridbridge import jit
    except ImportError:  # a release before the compiled kernels
        return nullcontext()
    return jit.override(on)


def worker(args: argparse.Namespace) -> dict[str, Any]:
    """One code's figures (module docstring); ``--numpy`` turns the compiled kernels off."""
    clock = CLOCKS[args.clock]
    with _kernels(not args.numpy):
        out: dict[str, Any] = {"random_ms": random_scene_ms(clock)}
        out["scenes"] = {s: scene_figures(s, args.frames, clock) for s in args.scenes}
    return out


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="python -m evaluation.bench.raycast", description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", nargs="*", default=["wheelchair", "lobby"], help="built-in scan scenes")
    ap.add_argument("--frames", type=int, default=200, help="scans of each scene's first laser")
    ap.add_argument("--repeat", type=int, default=3, help="interleaved rounds (medians)")
    ap.add_argument("--baseline", default=None, help="git revision to compare against ('none': no comparison)")
    ap.add_argument("--clock", choices=sorted(CLOCKS), default="wall")
    ap.add_argument("--worker", action="store_true", help="measure in this process, print one JSON line")
    ap.add_argument("--numpy", action="store_true", help="worker: the numpy code (compiled kernels off)")
    return ap


def _codes(a: argparse.Namespace) -> list[tuple[str, Path, list[str]]]:
    """(name, work tree, extra worker arguments) of every code measured."""
    rel = _local("release_baseline")
    codes = [("this", REPO, []), ("numpy", REPO, ["--numpy"])]
    rev = a.baseline if a.baseline is not None else rel.PREVIOUS_RELEASE
    if str(rev).lower() != "none":
        codes.append(("release", rel.release_checkout(rev), []))
    return codes


def _figure(run: dict[str, Any], key: tuple[str, ...]) -> float:
    value: Any = run
    for k in key:
        value = value[k]
    return float(value)


def _table(runs: dict[str, list[dict[str, Any]]], scenes: Sequence[str]) -> list[str]:
    """The medians per code and the speed-ups of ``this`` over the others."""
    names = list(runs)
    rows: list[tuple[str, tuple[str, ...]]] = [("random scene (ms/call)", ("random_ms",))]
    for s in scenes:
        rows.append((f"{s}: ray casts (ms/scan)", ("scenes", s, "cast_ms")))
        rows.append((f"{s}: simulator (ms/scan)", ("scenes", s, "loop_ms")))
    head = f"{'':<32}" + "".join(f"{n:>10}" for n in names) + "".join(f"{n + '/this':>14}" for n in names[1:])
    out = [head]
    for label, key in rows:
        vals = [statistics.median(_figure(r, key) for r in runs[n]) for n in names]
        out.append(
            f"{label:<32}" + "".join(f"{v:>10.3f}" for v in vals) + "".join(f"{v / vals[0]:>14.2f}" for v in vals[1:])
        )
    for s in scenes:
        hashes = {r["scenes"][s]["sha256"] for rs in runs.values() for r in rs}
        out.append(f"{s}: the same ranges in every run and code: {'yes' if len(hashes) == 1 else 'NO'}")
    return out


def main(argv: Sequence[str] | None = None) -> int:
    a = _parser().parse_args(sys.argv[1:] if argv is None else argv)
    if a.worker:
        print(json.dumps(worker(a)))
        return 0
    run_worker = _local("release_baseline").run_worker
    codes = _codes(a)
    print(f"code: {', '.join(f'{n} = {root}' + (' (numpy)' if extra else '') for n, root, extra in codes)}")
    print(f"{a.frames} scans per scene, {a.repeat} interleaved round(s), one core, clock: {a.clock}", flush=True)
    argv_w = ["--worker", "--frames", str(a.frames), "--clock", a.clock, "--scenes", *a.scenes]
    runs: dict[str, list[dict[str, Any]]] = {n: [] for n, _r, _e in codes}
    for _ in range(max(a.repeat, 1)):
        for name, root, extra in codes:
            runs[name].append(run_worker(root, "evaluation.bench.raycast", [*argv_w, *extra]))
    print("\n".join(_table(runs, a.scenes)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
