"""``pfpeople-eval sweep``: scenarios x seeds x parameter values as Dask tasks, metrics in one table.

Examples::

    pfpeople-eval sweep --scenario complementary corridor --seeds 0 1 2 --param particles=1000,5000 --out runs/sw
    pfpeople-eval sweep --scenario default --seeds 0 1 --param form=paper,linear --param frames=100 \\
        --out runs/sw2 --table runs/sw2.parquet --scheduler tcp://10.0.0.5:8786

Every point runs the paper's filters and the recommended ones (``--param mode=paper`` or ``recommended`` for one
mode), each filter once per sweep (a grid filter is not rerun for every particle count). Sweepable keys: see
``--param`` below (:data:`evaluation.harness.sweep.SWEEP_KEYS`). Exit status: 0 when every task completed, 1 when some
failed (their errors are in the table), 2 on bad input.
"""

from __future__ import annotations

import argparse
import math
from collections import defaultdict
from pathlib import Path
from typing import Any

from evaluation.harness.sweep import SWEEP_KEYS, columns_for, parse_param, run_sweep
from pfpeople.cli.support import examples
from pfpeople.pipeline.batch import check_table_path, quiet_dask_logs, write_table


def register(subparsers: argparse._SubParsersAction) -> None:
    keys = "; ".join(f"{k}: {v.text}" for k, v in SWEEP_KEYS.items())
    p = subparsers.add_parser(
        "sweep",
        epilog=examples(
            "pfpeople-eval sweep --scenario complementary --seeds 0 1 --param particles=5000,50000 --out runs/sweep",
            "pfpeople-eval sweep --scenario corridor --param mode=recommended --param odometry=noisy,true --out sw",
        ),
        help="A/B evaluation over scenarios x seeds x parameter values, as Dask tasks; one metrics table",
        description="One Dask task per point of scenarios x seeds x values; each runs the A/B evaluation of the "
        "paper's and the recommended filters (each filter once per sweep) and returns recall, precision, FPCPF "
        "and ms/iteration per filter and classifier.",
    )
    p.add_argument("--scenario", nargs="+", required=True, help="built-in scenario names or scenario TOML files")
    p.add_argument("--seeds", type=int, nargs="+", default=[0], help="scenario and particle seeds (default: 0)")
    p.add_argument(
        "--param", action="append", default=[], metavar="KEY=V1,V2", help=f"a swept parameter (repeatable). {keys}"
    )
    p.add_argument("--out", type=Path, required=True, help="output folder (task records in OUT/tasks)")
    p.add_argument("--table", help="results table, .csv or .parquet (default: OUT/sweep.csv)")
    p.add_argument("--scheduler", help="address of a running Dask scheduler (default: start a local cluster)")
    p.add_argument("--workers", type=int, help="local cluster worker processes (default: one per core)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def _mean(values: list[Any]) -> float:
    finite = [float(v) for v in values if isinstance(v, int | float) and math.isfinite(v)]
    return sum(finite) / len(finite) if finite else math.nan


def run(args: argparse.Namespace) -> int:
    quiet_dask_logs(verbose=args.verbose)  # the cluster's start/stop messages only with -v
    params: dict[str, list[Any]] = {}
    for text in args.param:
        key, values = parse_param(text)
        if key in params:
            raise ValueError(f"sweep parameter {key!r} given twice")
        params[key] = values
    table = check_table_path(args.table if args.table else args.out / "sweep.csv")
    rows = run_sweep(
        args.scenario,
        args.seeds,
        params,
        args.out,
        scheduler=args.scheduler,
        workers=args.workers,
        progress=not args.no_progress,
    )
    write_table(rows, table, columns_for(list(params)))
    failed = sorted({r["task"] for r in rows if r["status"] != "complete"})
    # Means over seeds of each filter with its own classifier (blobs, or peaks in the recommended mode), per
    # scenario and parameter values ("-": a value the filter does not depend on).
    groups: dict[tuple[Any, ...], list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        if r["status"] == "complete" and r["classifier"] not in ("detector", "threshold"):
            groups[(r["scenario"], *("-" if r[k] is None else r[k] for k in params), r["filter"])].append(r)
    head = ["scenario", *params, "filter"]
    print(" | ".join(head) + " | recall | precision | FPCPF | ms/iter | seeds")
    for group, rs in groups.items():
        m = [_mean([r[c] for r in rs]) for c in ("recall", "precision", "fpcpf", "ms_per_iter")]
        print(" | ".join(str(k) for k in group) + f" | {m[0]:.2f} | {m[1]:.2f} | {m[2]:.2f} | {m[3]:.2f} | {len(rs)}")
    for task in failed:
        err = next(r["error"] for r in rows if r["task"] == task)
        print(f"failed: {task}: {err}")
    n_tasks = len({r["task"] for r in rows})
    print(f"{n_tasks} task(s): {n_tasks - len(failed)} complete, {len(failed)} failed -> {table}")
    return 1 if failed else 0
