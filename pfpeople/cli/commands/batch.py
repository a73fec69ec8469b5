"""``pfpeople batch BAG...``: the pipeline over many bags, one Dask task per bag, results in one table.

Examples::

    pfpeople batch recordings/*.bag --config my.toml --out runs/fleet                 # local cluster, 1 worker/core
    pfpeople batch recordings/*.bag --config my.toml --out runs/fleet --workers 4 --table runs/fleet.parquet
    pfpeople batch /shared/bags/*.bag --config my.toml --out /shared/runs --scheduler tcp://10.0.0.5:8786

Exit status: 0 when every bag completed, 1 when some failed (their errors are in the table), 2 on bad input.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

from pfpeople.cli.support import add_blas_threads_argument, examples
from pfpeople.config import BagConfig, builtin_config_path, load_config
from pfpeople.pipeline.batch import check_table_path, quiet_dask_logs, run_batch, write_table


def _config(args: argparse.Namespace) -> BagConfig:
    path = Path(args.config)
    cfg = load_config(path if path.suffix == ".toml" or path.exists() else builtin_config_path(args.config))
    if args.filter:
        cfg = replace(cfg, filter=replace(cfg.filter, kind=args.filter))
    return cfg


def _run(args: argparse.Namespace) -> int:
    quiet_dask_logs(verbose=args.verbose)  # the cluster's start/stop messages only with -v
    cfg = _config(args)
    out = Path(args.out)
    table = check_table_path(args.table if args.table else out / "results.csv")
    if args.max_frames is not None and args.max_frames < 0:
        raise ValueError(f"--max-frames must be >= 0, got {args.max_frames}")
    rows = run_batch(
        args.bags,
        cfg,
        out,
        scheduler=args.scheduler,
        workers=args.workers,
        max_frames=args.max_frames,
        overwrite=args.overwrite,
        progress=not args.no_progress,
        blas_threads=args.blas_threads,
    )
    write_table(rows, table)
    failed = [r for r in rows if r["status"] != "complete"]
    for r in rows:
        fps = "-" if not math.isfinite(r["fps"]) else f"{r['fps']:.1f}"
        line = f"  {r['status']:8} {r['bag']}: {r['frames']} frames, {fps} frames/s, {r['wall_s']:.1f} s"
        print(line + (f"  ({r['error']})" if r["error"] else ""))
    print(f"{len(rows)} bag(s): {len(rows) - len(failed)} complete, {len(failed)} failed -> {table}, runs in {out}")
    return 1 if failed else 0


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "batch",
        epilog=examples(
            "pfpeople batch recordings/*.bag --config my.toml --out runs/fleet --workers 2",
            "pfpeople batch a.bag b.bag --config my.toml --out runs/ab --scheduler tcp://host:8786",
        ),
        help="run the pipeline over many bags as Dask tasks (local cluster or --scheduler); one results table",
        description="One task per bag on dask.distributed; each writes OUT/<bag stem> (a run directory); a bag "
        "that fails is recorded (table row and OUT/<stem>/batch_error.txt) and the others go on.",
    )
    p.add_argument("bags", nargs="+", metavar="BAG", help="ROS1 .bag, ROS2 bag folder, or a .zip of either")
    p.add_argument("--config", required=True, help="TOML run config, or the name of a built-in one")
    p.add_argument("--out", required=True, help="output folder: one run directory per bag")
    p.add_argument("--filter", choices=("grid", "particle"), help="filter (default: the config's)")
    p.add_argument("--scheduler", help="address of a running Dask scheduler (default: start a local cluster)")
    p.add_argument("--workers", type=int, help="local cluster worker processes (default: one per core)")
    p.add_argument("--table", help="results table, .csv or .parquet (default: OUT/results.csv)")
    p.add_argument("--max-frames", type=int, default=None, help="stop each run after N frames")
    p.add_argument("--overwrite", action="store_true", help="replace existing runs in OUT")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_blas_threads_argument(p)
    p.set_defaults(func=_run)
