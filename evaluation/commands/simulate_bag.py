"""``pfpeople-eval simulate-bag SCENE --out DIR``: a scan-level scene as a ROS1 / ROS2 bag with ground truth.

Writes ``<name>.bag`` (or the ROS2 folder ``<name>``), ``<name>_gt.csv`` and ``<name>.toml`` (see
:mod:`evaluation.scenarios.scan.bagfile`); then::

    python -m pfpeople.cli run DIR/<name>.bag --config DIR/<name>.toml --out RUN
    pfpeople-eval score RUN --gt DIR/<name>_gt.csv --frame laser
"""

from __future__ import annotations

import argparse
import shlex
from pathlib import Path

from tqdm import tqdm

from evaluation.scenarios.scan import builtin_scan_scenes, load_scene, write_scene_bag
from pfpeople.cli.support import examples
from pfpeople.progress import progress_bar

__all__ = ["add_parser", "register", "run"]


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``simulate-bag`` subcommand."""
    p: argparse.ArgumentParser = subparsers.add_parser(
        "simulate-bag",
        epilog=examples(
            "pfpeople-eval simulate-bag corridor --out bags --frames 200",
            "pfpeople-eval simulate-bag crowd --out bags --format ros2",
        ),
        help="simulate a scan-level scene (raw laser scans, odometry, TF) and write it as a bag with ground truth",
        description=(
            "Ray-cast a scene of walls, furniture and walking people (two legs each) for a moving robot and "
            "write a ROS1 bag or ROS2 bag folder (/scan, /odom, /tf, /tf_static, /ground_truth_people), the "
            "ground-truth CSV <name>_gt.csv and a run config <name>.toml for 'pfpeople run'. Built-in scenes: "
            + ", ".join(builtin_scan_scenes())
            + "."
        ),
    )
    p.add_argument("scene", help="built-in scene name or path to a scene TOML file")
    p.add_argument("--out", type=Path, required=True, help="output folder")
    p.add_argument("--frames", type=int, default=None, help="number of scans (default: the scene's length)")
    p.add_argument("--seed", type=int, default=None, help="seed (default: the scene's)")
    p.add_argument("--format", dest="fmt", choices=("ros1", "ros2"), default="ros1", help="bag format (default ros1)")
    p.add_argument("--storage", choices=("sqlite3", "mcap"), default="sqlite3", help="ROS2 storage (default sqlite3)")
    p.add_argument("--name", default=None, help="file stem (default: the scene's name)")
    p.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    p.set_defaults(func=run)
    return p


def register(subparsers: argparse._SubParsersAction) -> None:
    """Hook of :func:`pfpeople.cli.support.build_parser` (commands are discovered, not listed)."""
    add_parser(subparsers)


def run(args: argparse.Namespace) -> int:
    if args.frames is not None and args.frames < 1:
        raise ValueError(f"--frames must be >= 1, got {args.frames}")
    cfg = load_scene(args.scene)
    total = args.frames if args.frames is not None else cfg.n_frames
    bars: dict[str, tqdm] = {}

    def progress(stage: str, n: int) -> None:
        if args.no_progress:
            return
        if stage not in bars:
            for bar in bars.values():
                bar.close()
            bars[stage] = progress_bar(
                total=total if stage == "simulate" else None,
                desc=stage,
                unit=" scans" if stage == "simulate" else " msgs",
                every=10_000,  # off a terminal, a line per 10k messages written (their total is not known)
            )
        bars[stage].update(n)

    try:
        out = write_scene_bag(
            cfg,
            args.out,
            seed=args.seed,
            frames=args.frames,
            fmt=args.fmt,
            storage=args.storage,
            name=args.name,
            overwrite=args.overwrite,
            progress=progress,
        )
    finally:
        for bar in bars.values():
            bar.close()
    las = cfg.lasers[0]
    print(
        f"scene {cfg.name!r}: {out.frames} scans of {las.topic} ({las.n_beams} beams, {las.rate_hz:g} Hz), "
        f"{out.people_per_scan:.2f} people per scan in the laser's FOV and range "
        f"({out.seen_per_scan:.2f} with >= 3 beams on their legs), {out.ms_per_scan:.2f} ms per scan to simulate"
    )
    print(f"wrote {out.bag} ({out.size_bytes / 1e6:.1f} MB), {out.gt_csv}, {out.run_toml}")
    bag, toml, gt, frame = (shlex.quote(str(v)) for v in (out.bag, out.run_toml, out.gt_csv, las.frame_id))
    print(f"next: python -m pfpeople.cli run {bag} --config {toml} --out RUN")
    print(f"      pfpeople-eval score RUN --gt {gt} --frame {frame}")
    return 0
