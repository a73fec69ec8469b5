"""``pfpeople-eval benchmark``: every built-in scene and the real bags, each detector alone, the paper's modes and
the recommended mode, in one table (see :mod:`evaluation.harness.benchmark`).

Examples::

    pfpeople-eval benchmark                                  # everything (several minutes on 2 cores)
    pfpeople-eval benchmark --scenes eth scan:wheelchair --frames 200 --json bench.json
    pfpeople-eval benchmark --scenes scan:wheelchair scan:corridor scan:crowd --seed 1   # other people, same rooms
    pfpeople-eval benchmark --scenes eth hotel --particle seed=3          # another draw of the particle rows
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import asdict
from pathlib import Path
from typing import Any

from evaluation.harness.benchmark import SCENES, format_rows, particle_overrides, run_benchmark
from evaluation.harness.detector_ap import ApRow, format_ap_rows
from evaluation.harness.mot_eval import MotRow
from evaluation.harness.mot_eval import format_rows as format_mot_rows
from evaluation.scenarios.eth_ucy import default_data_root
from pfpeople.cli.support import examples
from pfpeople.io.jsonio import dumps


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "benchmark",
        epilog=examples(
            "pfpeople-eval benchmark",
            "pfpeople-eval benchmark --scenes eth scan:wheelchair --frames 200 --json bench.json",
        ),
        help="people-detection benchmark over every scene: detectors, paper modes, recommended mode",
        description="Run every built-in scene (ETH/UCY replays, scan-level scenes written as bags) and the real bags "
        "in the data folder; print recall, precision, false people per scan, FPCPF and ms per frame per source.",
    )
    p.add_argument(
        "--scenes",
        nargs="+",
        default=list(SCENES),
        choices=SCENES,
        metavar="SCENE",
        help=f"scenes to run (default: all of {', '.join(SCENES)})",
    )
    p.add_argument("--data", type=Path, default=None, help="data folder (default ../shared/data or $PFPEOPLE_DATA)")
    p.add_argument("--frames", type=int, default=None, help="frames per scene (default: each scene's own length)")
    p.add_argument("--work", type=Path, default=None, help="keep the written bags and runs in this folder")
    p.add_argument("--json", type=Path, default=None, help="also write the rows to this JSON file")
    p.add_argument("--no-progress", action="store_true", help="no progress lines")
    p.add_argument(
        "--seed",
        type=int,
        default=None,
        help="simulation seed of the scan-level scenes (default: each scene's own, 0)",
    )
    p.add_argument(
        "--particle",
        nargs="+",
        default=[],
        metavar="KEY=VALUE",
        help="[filter] settings of every particle filter run: seed=3 (another Monte Carlo draw), compiled_draws=false",
    )
    p.add_argument("--no-mot", action="store_true", help="no multi-person tracking table (CLEAR-MOT: MOTA, IDSW, ...)")
    p.add_argument(
        "--no-ap", action="store_true", help="no detection table (each detector alone: AP, recall at P 0.90)"
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.frames is not None and args.frames < 1:
        raise ValueError(f"--frames must be a positive integer, got {args.frames}")
    particle = particle_overrides(args.particle)  # before anything runs
    data = args.data if args.data is not None else default_data_root()
    scenes = list(args.scenes)

    def progress(scene: str) -> None:
        if not args.no_progress:
            print(f"[{scenes.index(scene) + 1}/{len(scenes)}] {scene} ...", file=sys.stderr, flush=True)

    if args.work is not None:
        args.work.mkdir(parents=True, exist_ok=True)
    mot: list[MotRow] | None = None if args.no_mot else []
    ap: list[ApRow] | None = None if args.no_ap else []
    rows = run_benchmark(
        scenes,
        data=data,
        frames=args.frames,
        work=args.work,
        progress=progress,
        mot=mot,
        scan_seed=args.seed,
        particle=particle,
        ap=ap,
    )
    if args.seed is not None:
        print(f"scan-level scenes simulated with seed {args.seed}")
    if particle:
        print("particle filter runs with " + " ".join(f"{k}={v!r}" for k, v in particle.items()))
    print(format_rows(rows))
    if mot:
        print(
            "\nMulti-person tracking (CLEAR-MOT, gate 0.75 m; tracker on the recommended output vs on raw detections):"
        )
        print(format_mot_rows(mot))
    if ap:
        print(
            "\nEach detector alone and the fused output (AP at 0.3 / 0.5 m, recall at precision 0.90, standing / "
            "walking recall at the operating threshold, false people per scan; people with fewer than 3 returns "
            "ignored):"
        )
        print(format_ap_rows(ap))
    if args.json is not None:
        data_out: Any = [asdict(r) for r in rows]
        if mot or ap:
            data_out = {"detection": data_out}
        if mot:
            data_out["tracking"] = [
                {"scene": r.sequence, "source": r.source, **r.scores.as_dict(), **r.extra} for r in mot
            ]
        if ap:
            data_out["detectors"] = [asdict(r) for r in ap]
        args.json.write_text(dumps(data_out, default=str) + "\n")
    return 0
