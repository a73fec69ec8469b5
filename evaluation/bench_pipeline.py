"""Benchmark of the whole bag pipeline on the real person-following bag (7170 scans, 720 s).

Runs ``pfpeople run`` equivalents (bag reading, both laser detectors, the filter, classification, tracking and
the run directory output) for each filter, in one process and with the front end in a second process
(``Pipeline(front_process=...)``, :mod:`pfpeople.frontend`), and prints frames per second, the real-time factor
(recorded seconds processed per wall-clock second), its ratio to the first variant of the same filter measured
just before (the first value of each option), the CPU time of the filter's step alone (ms per frame, its thread;
less sensitive to other load on the machine than the wall clock), and the recall of each detector and of the
filter against the ground truth (recall only: passers-by are not annotated; the two modes give the same)::

    python -m evaluation.bench_pipeline [--data ../shared/data] [--filters grid particle] [--max-frames N]
        [--processes 1 2] [--max-overflow 0 0.1] [--particles 5000 2500] [--motion-model paper persistent]
        [--repeat N]

``--max-overflow``: the particle filter's ``FilterConfig.max_overflow`` values to compare (default: the
configuration's, 0.1 in the recommended mode); 0 resamples whenever births overflow, as before it existed.
``--particles``: particle counts to compare (default: the configuration's, 5 per cell and at least 5000: 5000 on
this bag's 494-cell grid). ``--motion-model``: the particle filter's people-motion samplers to compare (default:
the configuration's, ``"persistent"`` in the recommended mode). Every combination of ``--processes``,
``--max-overflow``, ``--particles`` and ``--motion-model`` is a variant; the first is the baseline of the
ratios.

Wall-clock figures depend on the machine; tests never assert them.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from evaluation.commands.score import score_run
from gridbridge.limits import ResourceLimitError
from pfpeople.bag.config import builtin_config_path, load_config
from pfpeople.bag.reader import BagSource
from pfpeople.gt_csv import read_gt_csv
from pfpeople.output import load_run
from pfpeople.pipeline import Pipeline

BAG = "leg_tracker/person_following_outdoor_1.bag.zip"
GT = "leg_tracker/person_following_outdoor_1_gt.csv"


#: (processes, max_overflow, particle count, motion model); None: the configuration's.
Variant = tuple[int, float | None, int | None, str | None]


def _label(v: Variant, particle: bool) -> str:
    n, ovf, count, model = v
    out = f"{n} process{'es' if n > 1 else ''}"
    if particle and ovf is not None:
        out += f" ovf {ovf:g}"
    if particle and count is not None:
        out += f" N {count}"
    if particle and model is not None:
        out += f" {model}"
    return out


class _TimedPipeline(Pipeline):
    """A :class:`Pipeline` that adds the CPU time (``time.thread_time``) of every filter step to ``filter_cpu_s``
    (the filter runs in this process in both modes)."""

    filter_cpu_s = 0.0

    def prepare(self, bag: BagSource) -> Any:
        out = super().prepare(bag)
        assert self.filter is not None
        step = self.filter.step

        def timed(*args: Any, **kwargs: Any) -> Any:
            t0 = time.thread_time()
            try:
                return step(*args, **kwargs)
            finally:
                self.filter_cpu_s += time.thread_time() - t0

        self.filter.step = timed  # type: ignore[method-assign]
        return out


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m evaluation.bench_pipeline", description=__doc__.split("\n")[0])
    ap.add_argument("--data", default="../shared/data", help="the shared data folder")
    ap.add_argument("--filters", nargs="+", default=["grid", "particle"], choices=("grid", "particle"))
    ap.add_argument("--max-frames", type=int, default=None, help="stop after N frames (default: the whole bag)")
    ap.add_argument(
        "--particles",
        nargs="+",
        type=int,
        default=[None],
        help="particle counts of the particle filter to compare (default: the configuration's)",
    )
    ap.add_argument(
        "--processes",
        nargs="+",
        type=int,
        default=[1, 2],
        choices=(1, 2),
        help="1: one process; 2: front end in a second process",
    )
    ap.add_argument(
        "--max-overflow",
        nargs="+",
        type=float,
        default=[None],
        help="particle filter: FilterConfig.max_overflow values to compare (default: the configuration's)",
    )
    ap.add_argument(
        "--motion-model",
        nargs="+",
        default=[None],
        choices=("paper", "persistent"),
        help="particle filter: people-motion samplers to compare (default: the configuration's)",
    )
    ap.add_argument(
        "--repeat", type=int, default=1, help="runs per filter and mode, interleaved (the median is compared)"
    )
    args = ap.parse_args(argv)
    data = Path(args.data)
    if not (data / BAG).is_file():
        print(f"{data / BAG} is absent; nothing to benchmark", file=sys.stderr)
        return 2
    gt = read_gt_csv(data / GT)
    cfg0 = load_config(builtin_config_path("person_following_outdoor_1"))
    print(
        f"{'filter':<10}{'procs':>6}{'ovf':>5}{'N':>6}{'motion':>11}{'frames':>8}{'wall s':>9}{'fps':>9}"
        f"{'RT factor':>11}"
        f"{'ratio':>7}{'filt CPU ms':>12}   recall per source"
    )
    for kind in args.filters:
        particle = kind == "particle"
        overflows = args.max_overflow if particle else [None]
        counts = args.particles if particle else [None]
        models = args.motion_model if particle else [None]
        variants = [(n, o, c, m) for n in args.processes for o in overflows for c in counts for m in models]
        rtfs: dict[Variant, list[float]] = {v: [] for v in variants}
        cpus: dict[Variant, list[float]] = {v: [] for v in variants}
        for _ in range(max(args.repeat, 1)):
            for v in variants:
                n, ovf, count, model = v
                filt = replace(cfg0.filter, kind=kind, n_particles=count)
                if ovf is not None:
                    filt = replace(filt, max_overflow=ovf)
                if model is not None:
                    filt = replace(filt, motion_model=model)
                cfg = replace(cfg0, filter=filt)
                with tempfile.TemporaryDirectory() as tmp:
                    out = Path(tmp) / "run"
                    try:
                        with BagSource(data / BAG) as src:
                            pipe = _TimedPipeline(cfg, front_process=n == 2)
                            summary, _ = pipe.run(src, out, max_frames=args.max_frames)
                    except ResourceLimitError as exc:  # too large for this machine; any other error is a failure
                        print(f"{kind:<10} skipped: {exc}")
                        break
                    run = load_run(out)
                    stamps = run.frames["stamp_ns"]
                    recorded = (stamps[-1] - stamps[0]) * 1e-9 + 0.1 if len(stamps) else 0.0
                    rtf = recorded / summary.elapsed_s if summary.elapsed_s > 0 else float("nan")
                    rtfs[v].append(rtf)
                    cpu_ms = 1e3 * pipe.filter_cpu_s / max(summary.frames, 1)
                    cpus[v].append(cpu_ms)
                    scores = score_run(run, gt, frame="laser", recall_only=True)["scores"]
                    rec = "  ".join(f"{name} {s['recall']:.3f}" for name, s in scores.items())
                    base = rtfs[variants[0]][-1] if rtfs[variants[0]] else float("nan")
                    shown_o = "-" if not particle else ("cfg" if ovf is None else f"{ovf:g}")
                    n_used = getattr(pipe.filter, "n_particles", None)
                    shown_c = "-" if n_used is None else str(n_used)
                    shown_m = getattr(pipe.filter, "motion_model", "-")
                    print(
                        f"{kind:<10}{n:>6}{shown_o:>5}{shown_c:>6}{shown_m:>11}{summary.frames:>8}{summary.elapsed_s:>9.2f}"
                        f"{summary.fps:>9.1f}{rtf:>11.1f}{rtf / base:>7.2f}{cpu_ms:>12.3f}   {rec}",
                        flush=True,
                    )
        if len(variants) > 1 and all(len(r) > 1 for r in rtfs.values()):
            m0, c0 = statistics.median(rtfs[variants[0]]), statistics.median(cpus[variants[0]])
            parts, cparts = [], []
            for v in variants:
                label = _label(v, particle)
                m, c = statistics.median(rtfs[v]), statistics.median(cpus[v])
                parts.append(f"{label} {m:.1f} (ratio {m / m0:.2f})")
                cparts.append(f"{label} {c:.3f} (ratio {c0 / c:.2f})")
            print(f"{kind:<10} median RT factor: " + ", ".join(parts))
            print(f"{kind:<10} median filter CPU ms per frame (ratio: first variant / this): " + ", ".join(cparts))
    return 0


if __name__ == "__main__":
    sys.exit(main())
