"""Benchmark of ``pfpeople run`` (one process) on scan-level scenes and the real bag, against the previous release.

Cases (``--cases``): the 768-beam, 7.5 Hz scan-level scenes ``wheelchair`` and ``lobby``
(:mod:`evaluation.scenarios.scan`, simulated once into ``--work`` and run with the starter configuration of
``pfpeople inspect BAG --write-config``, the recommended mode) and ``person_following`` (the real
person-following bag, 7170 scans of 245 beams at 10 Hz, with its built-in configuration). Each case runs with
each filter of ``--filters`` (the recommended grid and particle filters) and each variant of ``--processes``
(default 1: everything in one process), ``--max-overflow``, ``--particles``, ``--motion-model`` and ``--draws``
(the particle filter's ``compiled_draws``; releases before round three's eleventh stop lack it: ``--baseline none``).

Every run is a worker process (``--worker``) that runs the whole pipeline (bag reading, the detectors, the
clutter map, the filter, classification, tracking and the run directory) and prints one JSON line: frames,
wall-clock seconds, frames per second, the real-time factor (recorded seconds processed per wall-clock second),
the CPU time per frame of the same span and the real-time factor it gives (steadier than the wall clock on a
loaded machine), the filter step's CPU time (ms per frame), the wall-clock latency of the first and of the
slowest frame (``1st ms``, ``max ms``: from asking the pipeline for a frame to getting it, so a kernel loaded in
the frames shows there), the peak resident memory of the worker process,
the BLAS threads per library during the run (``BLAS``, :mod:`pfpeople.pipeline.blas`) and, with ``--stages``, the CPU
time of each stage (:mod:`evaluation.bench.stage_timer`). With ``--baseline REV`` (default
:data:`evaluation.bench.release_baseline.PREVIOUS_RELEASE`; ``none`` skips it) the same worker also runs with the
release's packages (:func:`evaluation.bench.release_baseline.run_worker`), interleaved with this checkout's runs, and
each row shows the same-run ratios ``this / release`` of both real-time factors
and whether the two runs wrote the same ``people.csv``, ``tracks.csv`` and ``detections.csv`` (byte for byte)::

    python -m evaluation.bench.pipeline [--cases wheelchair lobby person_following] [--filters grid particle]
        [--max-frames N] [--repeat N] [--baseline REV|none] [--stages] [--data ../shared/data] [--work DIR]
        [--processes 1 2] [--max-overflow 0 0.1] [--particles 5000] [--motion-model paper persistent]
        [--draws numpy compiled] [--busy N] [--side-by-side]
    python -m evaluation.bench.pipeline --worker --bag BAG --config CFG --filter grid --out RUN [--stages] ...

``--side-by-side`` runs the codes of a round at the same time, each worker pinned to a core of its own, the codes
swapping cores from round to round. On a machine whose speed drifts (a shared host), runs one after the other see
different speeds and runs side by side the same, so their ratio is steadier (``docs/speed.md``). Each run then has
the other core busy (shared caches and memory bandwidth): its own figures are those of a loaded machine.

``--busy N`` loads the machine the same for every code measured: N processes spin on a core each while the runs
go (on this 2-core machine ``--busy 1`` leaves the pipeline one core, as other jobs often do).

Wall-clock figures depend on the machine; tests never assert them.
"""

from __future__ import annotations

import argparse
import filecmp
import functools
import importlib.util
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]
SCENES = ("wheelchair", "lobby")
REAL = "person_following"
BAG = "leg_tracker/person_following_outdoor_1.bag.zip"
GT = "leg_tracker/person_following_outdoor_1_gt.csv"
#: The run files compared between this checkout and the release.
COMPARED = ("people.csv", "tracks.csv", "detections.csv")


@functools.cache
def _local(name: str) -> Any:
    """A module of this checkout's ``evaluation`` folder, loaded from its file (a worker of the release imports
    the release's ``evaluation`` package, which may not have it)."""
    spec = importlib.util.spec_from_file_location(f"_bench_{name}", Path(__file__).with_name(f"{name}.py"))
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _module(new: str, old: str) -> Any:
    """A module of the packages under test by its name, or by its name before the folder layout of round three
    when those packages are the previous release's (:func:`evaluation.bench.stage_timer.module_exists`)."""
    return importlib.import_module(new if _local("stage_timer").module_exists(new) else old)


def _timed_pipeline(cfg: Any, front_process: bool) -> Any:
    """A :class:`pfpeople.pipeline.runner.Pipeline` whose ``filter_cpu_s`` adds up the CPU time of its filter steps."""
    base: Any = _module("pfpeople.pipeline.runner", "pfpeople.pipeline").Pipeline

    class Timed(base):
        filter_cpu_s = 0.0
        cpu_s = 0.0
        frame_s: list[float]

        def frames(self, bag: Any, *, max_frames: int | None = None) -> Any:
            t0 = time.process_time()  # the CPU time of what summary.elapsed_s times
            self.frame_s = []  # each frame's wall-clock latency: from asking for it to getting it
            it = super().frames(bag, max_frames=max_frames)
            try:
                while True:
                    start = time.perf_counter()
                    try:
                        frame = next(it)
                    except StopIteration:
                        return
                    self.frame_s.append(time.perf_counter() - start)
                    yield frame
            finally:
                it.close()
                self.cpu_s = time.process_time() - t0

        def prepare(self, bag: Any) -> Any:
            out = super().prepare(bag)
            filt: Any = self.filter
            step = filt.step

            def timed(*args: Any, **kwargs: Any) -> Any:
                t0 = time.thread_time()
                try:
                    return step(*args, **kwargs)
                finally:
                    self.filter_cpu_s += time.thread_time() - t0

            filt.step = timed
            return out

    return Timed(cfg, front_process=front_process)


def _worker_config(args: argparse.Namespace) -> Any:
    """The run configuration of a worker: ``--config`` with the variant's filter settings."""
    config = _module("pfpeople.config", "pfpeople.bag.config")
    builtin_config_path, load_config = config.builtin_config_path, config.load_config
    path = Path(args.config)
    cfg = load_config(path if path.suffix == ".toml" else builtin_config_path(args.config))
    filt = replace(cfg.filter, kind=args.filter)
    for field, value in (
        ("n_particles", args.particles),
        ("max_overflow", args.max_overflow),
        ("motion_model", args.motion_model),
        ("compiled_draws", None if args.draws is None else args.draws == "compiled"),
    ):
        if value is not None:
            filt = replace(filt, **{field: value})
    return replace(cfg, filter=filt)


def _motion_model(filt: Any) -> str | None:
    """The people-motion model of a particle filter by its configuration name (None for the grid filter): its sampler's
    ``name`` (:data:`pfpeople.particle.predictor.PEOPLE_SAMPLERS`), or the ``motion_model`` of a release without
    components."""
    people = getattr(filt, "people_motion", None)
    if people is not None:
        return str(getattr(people, "name", type(people).__name__))
    return getattr(filt, "motion_model", None)


def _blas_threads(summary: Any) -> int | None:
    """The BLAS threads per library of the run: its record (``stats.blas_threads``), or, for code that limits
    none, what threadpoolctl sees now (None without threadpoolctl)."""
    if hasattr(summary, "blas_threads"):
        return int(summary.blas_threads)
    try:
        from threadpoolctl import threadpool_info
    except ImportError:
        return None
    return max((int(i["num_threads"]) for i in threadpool_info() if i.get("user_api") == "blas"), default=0)


def worker(args: argparse.Namespace) -> dict[str, Any]:
    """Run one case in this process and return its figures (see the module docstring)."""
    BagSource = _module("pfpeople.io.bag.reader", "pfpeople.bag.reader").BagSource
    load_run = _module("pfpeople.io.run_dir", "pfpeople.output").load_run
    cfg = _worker_config(args)
    stages: dict[str, float] = {}
    timer = _local("stage_timer").timed_stages() if args.stages else None
    pipe = _timed_pipeline(cfg, args.processes == 2)
    with BagSource(Path(args.bag)) as src:
        if timer is not None:
            with timer as stages:
                summary, _ = pipe.run(src, Path(args.out), max_frames=args.max_frames, overwrite=True)
        else:
            summary, _ = pipe.run(src, Path(args.out), max_frames=args.max_frames, overwrite=True)
    stamps = load_run(Path(args.out)).frames["stamp_ns"]
    n = int(summary.frames)
    span = (int(stamps[-1]) - int(stamps[0])) * 1e-9 * n / (n - 1) if n > 1 else 0.0
    elapsed = float(summary.elapsed_s)
    return {
        "frames": n,
        "elapsed_s": elapsed,
        "fps": n / elapsed if elapsed > 0 else float("nan"),
        "recorded_s": span,
        "rtf": span / elapsed if elapsed > 0 else float("nan"),
        "cpu_ms": 1e3 * pipe.cpu_s / max(n, 1),
        "cpu_rtf": span / pipe.cpu_s if pipe.cpu_s > 0 else float("nan"),
        "filter_cpu_ms": 1e3 * pipe.filter_cpu_s / max(n, 1),
        "first_frame_ms": 1e3 * pipe.frame_s[0] if pipe.frame_s else float("nan"),
        "max_frame_ms": 1e3 * max(pipe.frame_s, default=float("nan")),
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "blas_threads": _blas_threads(summary),
        "n_particles": getattr(pipe.filter, "n_particles", None),
        "motion_model": _motion_model(pipe.filter),
        "stages_ms": {k: 1e3 * v / max(n, 1) for k, v in stages.items()},
    }


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="python -m evaluation.bench.pipeline", description=__doc__.split("\n")[0])
    ap.add_argument("--cases", nargs="+", default=[*SCENES, REAL], help=f"scan scenes and/or {REAL!r}")
    ap.add_argument("--filters", nargs="+", default=["grid", "particle"], choices=("grid", "particle"))
    ap.add_argument("--max-frames", type=int, default=None, help="frames per run (scenes: simulated length too)")
    ap.add_argument("--repeat", type=int, default=1, help="runs per case and variant, interleaved (medians)")
    ap.add_argument("--baseline", default=None, help="git revision to compare against ('none': no comparison)")
    ap.add_argument("--stages", action="store_true", help="time every stage (ms per frame)")
    ap.add_argument("--data", default="../shared/data", help="the shared data folder (the real bag)")
    ap.add_argument("--work", default=str(REPO / ".bench" / "scenes"), help="where the scene bags are kept")
    ap.add_argument("--processes", nargs="+", type=int, default=[1], choices=(1, 2), help="2: front-end process")
    ap.add_argument("--max-overflow", nargs="+", type=float, default=[None], help="particle filter max_overflow")
    ap.add_argument("--particles", nargs="+", type=int, default=[None], help="particle counts")
    ap.add_argument("--motion-model", nargs="+", default=[None], choices=("paper", "persistent"))
    ap.add_argument(
        "--draws", nargs="+", default=[None], choices=("numpy", "compiled"), help="particle filter compiled_draws"
    )
    ap.add_argument(
        "--side-by-side",
        action="store_true",
        help="run the codes of a round at the same time, each on its own core (steadier ratios; needs 2 cores)",
    )
    ap.add_argument("--json", default=None, help="also write every run's figures to this JSON file")
    ap.add_argument(
        "--busy", type=int, default=0, help="load the machine: N processes spinning on a core each while it measures"
    )
    w = ap.add_argument_group("worker (one run in this process, one JSON line out)")
    w.add_argument("--worker", action="store_true")
    w.add_argument("--bag", help="the bag")
    w.add_argument("--config", help="run config TOML or built-in config name")
    w.add_argument("--filter", choices=("grid", "particle"), default="grid")
    w.add_argument("--out", help="the run directory")
    return ap


def _worker_argv(bag: Path, config: str, kind: str, out: Path, v: tuple[Any, ...], a: argparse.Namespace) -> list[str]:
    n, ovf, count, model, draws = v
    argv = ["--worker", "--bag", str(bag), "--config", config, "--filter", kind, "--out", str(out)]
    argv += ["--processes", str(n)]
    for flag, value in (("--max-overflow", ovf), ("--particles", count), ("--motion-model", model), ("--draws", draws)):
        if value is not None and kind == "particle":
            argv += [flag, str(value)]
    if a.max_frames is not None:
        argv += ["--max-frames", str(a.max_frames)]
    return argv + (["--stages"] if a.stages else [])


def _worker_args(argv: list[str]) -> argparse.Namespace:
    """The worker's namespace: the parser's, with one value per variant option."""
    args = _parser().parse_args(argv)
    for name in ("processes", "max_overflow", "particles", "motion_model", "draws"):
        setattr(args, name, getattr(args, name)[0])
    return args


def _case(name: str, a: argparse.Namespace) -> tuple[Path, str, Path] | str:
    """(bag, config, ground-truth CSV) of a case, simulating a scene once; or the reason it is skipped."""
    if name == REAL:  # absolute paths: the release's worker runs in the release's folder
        bag = Path(a.data).resolve() / BAG
        return (bag, "person_following_outdoor_1", bag.parent.parent / GT) if bag.is_file() else f"{bag} is absent"
    from evaluation.scenarios.scan import write_scene_bag
    from pfpeople.io.bag.inspect import inspect_path, starter_config

    out = Path(a.work).resolve() / (name if a.max_frames is None else f"{name}_{a.max_frames}")
    bag = out / f"{name}.bag"
    if not bag.is_file():
        write_scene_bag(name, out, frames=a.max_frames, overwrite=True)
    cfg = out / f"{name}_starter.toml"  # as the README: pfpeople inspect BAG --write-config
    if not cfg.is_file():
        cfg.write_text(starter_config(inspect_path(bag)), encoding="utf-8")
    return bag, str(cfg), out / f"{name}_gt.csv"


def _same_outputs(a: Path, b: Path) -> bool:
    """Whether two run directories hold the same :data:`COMPARED` files, byte for byte."""
    return all(
        (a / f).is_file() == (b / f).is_file() and (not (a / f).is_file() or filecmp.cmp(a / f, b / f, shallow=False))
        for f in COMPARED
    )


def _recall(run_dir: Path, gt: Path, real: bool) -> str:
    from evaluation.commands.score import score_run
    from pfpeople.io.ground_truth import read_gt_csv
    from pfpeople.io.run_dir import load_run

    scores = score_run(load_run(run_dir), read_gt_csv(gt), frame="laser", recall_only=real)["scores"]
    return "  ".join(f"{name} {s['recall']:.3f}" for name, s in scores.items())


HEAD = (
    f"{'case':<17}{'filter':<9}{'variant':<12}{'code':<9}{'frames':>7}{'wall s':>8}{'fps':>8}{'RT x':>8}"
    f"{'ratio':>7}{'CPU ms':>8}{'CPU RT':>8}{'ratio':>7}{'filt ms':>8}{'1st ms':>8}{'max ms':>8}{'RSS MB':>8}"
    f"{'BLAS':>5}  same  recall"
)


def _row(case: str, kind: str, label: str, code: str, r: dict[str, Any], ratios: tuple[str, str], rest: str) -> str:
    return (
        f"{case:<17}{kind:<9}{label:<12}{code:<9}{r['frames']:>7}{r['elapsed_s']:>8.2f}{r['fps']:>8.1f}"
        f"{r['rtf']:>8.1f}{ratios[0]:>7}{r['cpu_ms']:>8.2f}{r['cpu_rtf']:>8.1f}{ratios[1]:>7}"
        f"{r['filter_cpu_ms']:>8.3f}{r['first_frame_ms']:>8.1f}{r['max_frame_ms']:>8.1f}{r['peak_rss_mb']:>8.0f}"
        f"{r.get('blas_threads') or '-':>5}  {rest}"
    )


def _label(v: tuple[Any, ...]) -> str:
    n, ovf, count, model, draws = v
    out = f"{n}proc"
    for tag, value in (("ovf", ovf), ("N", count), ("", model), ("", draws)):
        if value is not None:
            out += f" {tag}{value}"
    return out


def _roots(a: argparse.Namespace) -> dict[str, Path]:
    """The code to measure: this checkout, and the release unless ``--baseline none``."""
    rel = _local("release_baseline")
    roots = {"this": REPO}
    rev = a.baseline if a.baseline is not None else rel.PREVIOUS_RELEASE
    if str(rev).lower() != "none":
        roots["release"] = rel.release_checkout(rev)
    return roots


def _measure(
    case: str,
    kind: str,
    v: tuple[Any, ...],
    spec: tuple[Path, str, Path],
    a: argparse.Namespace,
    roots: dict[str, Path],
) -> list[dict[str, Any]]:
    """``--repeat`` interleaved rounds of one case, filter and variant with every code in ``roots``; prints a row
    per run and returns the runs' figures (``code`` and ``round`` added)."""
    bag, config, gt = spec
    runs: list[dict[str, Any]] = []
    for k in range(max(a.repeat, 1)):
        with tempfile.TemporaryDirectory() as tmp:
            outs = {code: Path(tmp) / code for code in roots}
            argvs = {code: _worker_argv(bag, config, kind, outs[code], v, a) for code in roots}
            figures = _round(roots, argvs, k if a.side_by_side else None)
            runs += [dict(figures[code], code=code, round=k) for code in roots]
            this = runs[-len(roots)]
            rel = runs[-1] if "release" in roots else None
            same = "-" if rel is None else ("yes" if _same_outputs(outs["this"], outs["release"]) else "NO")
            for r in runs[-len(roots) :]:
                r["same_outputs"] = same
                ratios = ("", "")
                if rel is not None and r is this:
                    ratios = (f"{this['rtf'] / rel['rtf']:.2f}", f"{this['cpu_rtf'] / rel['cpu_rtf']:.2f}")
                rest = ""
                if r is this:
                    rest = f"{same:<5} " + (_recall(outs[r["code"]], gt, case == REAL) if gt.is_file() else "")
                print(_row(case, kind, _label(v), r["code"], r, ratios, rest), flush=True)
    return runs


def _round(roots: dict[str, Path], argvs: dict[str, list[str]], side_by_side: int | None) -> dict[str, Any]:
    """One round: each code's worker run, one after the other, or (``side_by_side``, the round's number) all at
    once, code ``i`` pinned to CPU ``(i + round) % CPUs`` (the codes swap CPUs from round to round)."""
    run_worker = _local("release_baseline").run_worker
    if side_by_side is None:
        return {code: run_worker(root, "evaluation.bench.pipeline", argvs[code]) for code, root in roots.items()}
    cpus = sorted(os.sched_getaffinity(0))
    with ThreadPoolExecutor(max_workers=len(roots)) as pool:
        futures = {
            code: pool.submit(
                run_worker, root, "evaluation.bench.pipeline", argvs[code], cpu=cpus[(i + side_by_side) % len(cpus)]
            )
            for i, (code, root) in enumerate(roots.items())
        }
        return {code: f.result() for code, f in futures.items()}


def _summary(case: str, kind: str, v: tuple[Any, ...], runs: list[dict[str, Any]], stages: bool) -> None:
    """Medians over the rounds per code, the ratio of the medians, and (``stages``) the stage table."""
    codes = list(dict.fromkeys(r["code"] for r in runs))

    def med(key: str, code: str) -> float:
        return statistics.median(r[key] for r in runs if r["code"] == code)

    parts = [f"{c} {med('rtf', c):.1f}x ({med('fps', c):.0f} frames/s, CPU {med('cpu_rtf', c):.1f}x)" for c in codes]
    if "release" in codes:
        rt, cpu = med("rtf", "this") / med("rtf", "release"), med("cpu_rtf", "this") / med("cpu_rtf", "release")
        parts.append(f"ratio {rt:.2f} (CPU {cpu:.2f})")
    print(f"{case:<17}{kind:<9}{_label(v):<12}median RT factor: " + ", ".join(parts), flush=True)
    if not stages:
        return
    names = list(dict.fromkeys(k for r in runs for k in r["stages_ms"]))
    print(f"  {'stage (CPU ms/frame, median)':<30}" + "".join(f"{c:>10}" for c in codes))
    for name in names:
        vals = [
            statistics.median(r["stages_ms"].get(name, float("nan")) for r in runs if r["code"] == c) for c in codes
        ]
        print(f"  {name:<30}" + "".join(f"{x:>10.3f}" for x in vals))
    print(f"  {'whole frame (CPU)':<30}" + "".join(f"{med('cpu_ms', c):>10.3f}" for c in codes), flush=True)


@contextmanager
def busy_loops(n: int) -> Iterator[None]:
    """``n`` processes that each spin on a core while the block runs (``python -c "while True: pass"``): the
    load of other jobs on a shared machine, the same for every code measured."""
    procs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(max(n, 0))]
    try:
        yield
    finally:
        for p in procs:
            p.kill()
        for p in procs:
            p.wait()


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    a = _parser().parse_args(argv)
    if a.worker:
        if not (a.bag and a.config and a.out):
            print("--worker needs --bag, --config and --out", file=sys.stderr)
            return 2
        print(json.dumps(worker(_worker_args(argv))))
        return 0
    roots = _roots(a)
    if a.side_by_side and (len(os.sched_getaffinity(0)) < len(roots) or 2 in a.processes or a.busy):
        print("--side-by-side needs a core per code measured, one process per run and no --busy", file=sys.stderr)
        return 2
    print(f"code: {', '.join(f'{c} = {p}' for c, p in roots.items())}")
    load = " ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"load: {a.busy} busy-loop process(es) while measuring; load average before: {load}")
    print(HEAD, flush=True)
    with busy_loops(a.busy):
        every = _measure_all(a, roots)
    if a.json:
        Path(a.json).write_text(json.dumps(every, indent=1), encoding="utf-8")
    return 0


def _measure_all(a: argparse.Namespace, roots: dict[str, Path]) -> list[dict[str, Any]]:
    """Every case, filter and variant of ``a`` with every code of ``roots``: the runs' figures."""
    every: list[dict[str, Any]] = []
    for case in a.cases:
        spec = _case(case, a)
        if isinstance(spec, str):
            print(f"{case}: skipped ({spec})", flush=True)
            continue
        for kind in a.filters:
            particle = kind == "particle"
            variants = [
                (n, o, c, m, d)
                for n in a.processes
                for o in (a.max_overflow if particle else [None])
                for c in (a.particles if particle else [None])
                for m in (a.motion_model if particle else [None])
                for d in (a.draws if particle else [None])
            ]
            for v in variants:
                runs = _measure(case, kind, v, spec, a, roots)
                _summary(case, kind, v, runs, a.stages)
                every += [dict(r, case=case, filter=kind, variant=_label(v)) for r in runs]
    return every


if __name__ == "__main__":
    sys.exit(main())
