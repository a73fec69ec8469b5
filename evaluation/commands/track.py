"""``pfpeople-eval track``: multi-person tracking scored with CLEAR-MOT, fused filter output vs raw detections.

Two inputs (see :mod:`evaluation.harness.mot_eval`):

- ``--scenario NAME`` (repeatable): the tracker on each filter's classified posterior (grid filter, particle
  filter; classifier: the peak picker) and on each detector's raw detections and all detectors merged;
- ``--run RUN_DIR --gt GT.csv``: the tracker on a ``pfpeople run`` output (``people.csv`` and each detector
  in ``detections.csv``) against a GT CSV with person ids, plus the followed-person figure.

Prints one table: sequence, source, MOTA, MOTP (m), IDSW, Frag, MT, ML, recall, precision.
"""

from __future__ import annotations

import argparse
import functools
import math
from pathlib import Path
from typing import Any

from evaluation.harness.ab import FilterSpec, particles_label
from evaluation.harness.mot_eval import MotRow, evaluate_run, evaluate_scenario, format_rows, peak_classifier
from evaluation.scenarios.scenario import Scenario, builtin_scenarios
from pfpeople.cli.support import examples
from pfpeople.config import TrackingConfig
from pfpeople.io.ground_truth import read_gt_csv
from pfpeople.io.jsonio import dumps
from pfpeople.io.run_dir import load_run
from pfpeople.pipeline.assembly import PEAK_THRESHOLD
from pfpeople.track import TrackerConfig

__all__ = ["add_parser", "register", "run"]


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "track",
        epilog=examples(
            "pfpeople-eval track --scenario eth --no-paper",
            "pfpeople-eval track --run runs/pf1 --gt person_following_outdoor_1_gt.csv",
        ),
        help="multi-person tracking (CLEAR-MOT): tracker on fused filter output vs tracking-by-detection",
        description="Run the multi-person tracker on each filter's classified posterior and on each detector's raw "
        "detections (and all merged) of a scenario, and/or on a 'pfpeople run' directory against a GT CSV with "
        "person ids; print CLEAR-MOT scores (MOTA, MOTP, IDSW, Frag, MT, ML, recall, precision) per source.",
    )
    p.add_argument(
        "--scenario",
        action="append",
        default=None,
        help=f"scenario to evaluate ({', '.join(builtin_scenarios())} or a TOML file); repeatable",
    )
    p.add_argument("--frames", type=int, default=300, help="frames per scenario (default 300)")
    p.add_argument("--seed", type=int, default=None, help="scenario seed (default: the scenario's)")
    p.add_argument(
        "--particles", type=int, nargs="*", default=[5_000], help="particle-filter rows (default 5000; none: no PF)"
    )
    p.add_argument("--no-grid", action="store_true", help="no grid-filter rows")
    p.add_argument("--no-paper", action="store_true", help="no paper grid-filter row (the recommended grid only)")
    p.add_argument("--pf-seed", type=int, default=0, help="seed of the particle filters (default 0)")
    p.add_argument("--run", type=Path, help="run directory written by 'pfpeople run'")
    p.add_argument("--gt", type=Path, help="ground-truth CSV with person ids (with --run)")
    p.add_argument("--frame", default="laser", help="frame of the GT positions (with --run; default laser)")
    p.add_argument("--sector", nargs=2, type=float, metavar=("DEG_MIN", "DEG_MAX"), help="bearing sector (deg)")
    p.add_argument("--max-range", type=float, help="range limit (m)")
    p.add_argument("--follow-id", type=int, help="followed person's GT id (default: the most annotated)")
    p.add_argument("--gate", type=float, default=0.75, help="CLEAR-MOT matching distance (m), default 0.75")
    p.add_argument("--max-coast", type=float, help="tracker: longest coasting before deletion (s; default 5)")
    p.add_argument(
        "--report-coast", type=float, help="tracker: longest coasting still reported (s; default 1; <0: always)"
    )
    p.add_argument(
        "--peak-threshold",
        type=float,
        default=TrackingConfig().peak_threshold,
        help="scenarios: the tracker is fed the belief peaks above this; tracks start only from peaks above the "
        f"classifier's {PEAK_THRESHOLD} (default: [tracking] peak_threshold, {TrackingConfig().peak_threshold})",
    )
    p.add_argument("--json", type=Path, help="also write the rows to this JSON file")
    p.set_defaults(func=run)


add_parser = register


def run(args: argparse.Namespace) -> int:
    if args.scenario is None and args.run is None:
        raise ValueError("give --scenario NAME and/or --run RUN_DIR --gt GT.csv")
    if args.run is not None and args.gt is None:
        raise ValueError("--run needs --gt GT.csv")
    if args.frames < 1:
        raise ValueError(f"--frames must be positive, got {args.frames}")
    tracker_opts: dict[str, Any] = {}
    if args.max_coast is not None:
        tracker_opts["max_coast_s"] = args.max_coast
    if args.report_coast is not None:
        tracker_opts["report_coast_s"] = None if args.report_coast < 0 else args.report_coast
    peak_threshold = PEAK_THRESHOLD if args.peak_threshold is None else args.peak_threshold
    if not 0 <= peak_threshold <= PEAK_THRESHOLD:
        raise ValueError(f"--peak-threshold must be in [0, {PEAK_THRESHOLD}], got {peak_threshold}")
    rows: list[MotRow] = []
    filters = [] if args.no_grid or args.no_paper else [FilterSpec(name="grid (paper)", form="paper")]
    if not args.no_grid:
        filters.append(FilterSpec(name="recommended grid", mode="recommended"))
    filters += [FilterSpec(name=particles_label(n), kind="particle", n_particles=n) for n in args.particles]
    for name in args.scenario or []:
        overrides: dict[str, Any] = {"n_frames": args.frames}
        if args.seed is not None:
            overrides["seed"] = args.seed
        scenario = Scenario.from_name(name, **overrides)
        # as the pipeline feeds its tracker (TrackingConfig): the peaks above peak_threshold update tracks, the
        # people (peaks above the classifier's PEAK_THRESHOLD) start them; raw detections (no scores) start them
        config = TrackerConfig(region=scenario.spec.extent, **{"birth_min_score": PEAK_THRESHOLD, **tracker_opts})
        rows += evaluate_scenario(
            scenario,
            filters=filters,
            classify=functools.partial(peak_classifier, threshold=peak_threshold),
            config=config,
            gate=args.gate,
            seed=args.pf_seed,
            n_frames=args.frames,
        )
    if args.run is not None:
        sector = tuple(math.radians(a) for a in args.sector) if args.sector else None
        run_data = load_run(args.run)
        rows += evaluate_run(
            run_data,
            read_gt_csv(args.gt),
            config=TrackerConfig(region=run_data.spec.extent, **tracker_opts),
            frame=args.frame,
            gate=args.gate,
            sector=sector,  # type: ignore[arg-type]
            max_range=args.max_range,
            follow_id=args.follow_id,
        )
    print(format_rows(rows))
    if args.json:
        data = [{"sequence": r.sequence, "source": r.source, **r.scores.as_dict(), **r.extra} for r in rows]
        args.json.write_text(dumps(data, default=str) + "\n")
    return 0
