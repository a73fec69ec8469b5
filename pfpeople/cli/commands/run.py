"""``pfpeople run BAG``: the whole pipeline over a bag, with a progress bar and frames per second at the end.

Examples::

    pfpeople run person_following_outdoor_1.bag.zip --config person_following_outdoor_1 --out runs/pf1
    pfpeople run my.bag --driver /scan --odom /odom --filter particle --max-frames 500 --bag-out out.bag
    pfpeople run my.bag --config my.toml --bag-out results_ros2              # rosbag2 folder, sqlite3 storage
    pfpeople run my.bag --config my.toml --bag-out results_mcap --bag-format mcap --no-input

Exit codes: 0 done, 2 bad input (one line on stderr; the frames processed before a failure stay in ``--out``
with ``status = "failed"``), 130 interrupted by SIGINT (Ctrl-C), 143 by SIGTERM (``status = "interrupted"``,
the frames on disk kept, the result bag closed).
"""

from __future__ import annotations

import argparse
import functools
import logging
import signal
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

from pfpeople.cli.support import add_blas_threads_argument, examples
from pfpeople.config import BagConfig, DetectorConfig, builtin_config_path, load_config
from pfpeople.io.bag.reader import BagReadError, BagSource
from pfpeople.io.bag.writer import BAG_FORMATS, check_bag_out
from pfpeople.io.run_dir import RunInterrupted, check_output_paths, interrupt_signals
from pfpeople.pipeline.runner import Pipeline
from pfpeople.pipeline.sinks import standard_sinks

log = logging.getLogger(__name__)


def config_from_args(args: argparse.Namespace) -> BagConfig:
    """The run configuration: ``--config`` (a TOML file or a built-in name) with the flags applied on top."""
    if args.config:
        path = Path(args.config)
        cfg = load_config(path if path.suffix == ".toml" or path.exists() else builtin_config_path(args.config))
    else:
        if not args.driver:
            raise ValueError("give --config or --driver (the LaserScan topic that drives the frames)")
        cfg = BagConfig(
            driver=args.driver, detectors=(DetectorConfig(name="laser_legs", kind="leg", topic=args.driver),)
        )
    changes: dict[str, Any] = {}
    if args.driver and args.config:
        changes["driver"] = args.driver
    if args.odom is not None:
        changes["odometry"] = args.odom
    if args.time_source:
        changes["time_source"] = args.time_source
    if args.tolerance is not None:
        changes["sync_tolerance_s"] = args.tolerance
    if args.filter:
        changes["filter"] = replace(cfg.filter, kind=args.filter)
    if args.particles is not None:
        changes["filter"] = replace(changes.get("filter", cfg.filter), n_particles=args.particles)
    if args.seed is not None:
        changes["filter"] = replace(changes.get("filter", cfg.filter), seed=args.seed)
    return replace(cfg, **changes) if changes else cfg


def _log_config(cfg: BagConfig) -> None:
    """The run's configuration, as debug messages (``pfpeople -v run``)."""
    log.debug(
        "frames: driver %s, time source %s, sync tolerance %g s, odometry %s, base frame %s, grid frame %s",
        cfg.driver, cfg.time_source, cfg.sync_tolerance_s, cfg.odometry or "none", cfg.base_frame,
        cfg.grid_frame or "the driver's",
    )  # fmt: skip
    log.debug("filter: %s, %s mode; grid: %s", cfg.filter.kind, cfg.filter.mode, cfg.grid.fixed or "from the lasers")
    for d in cfg.detectors:
        log.debug("detector %s: kind %s on %s", d.name, d.kind, d.topic)
    for frame, (x, y, yaw) in cfg.mounts.items():
        log.debug("[mounts] %s: x=%g y=%g yaw=%g rad in %s (where TF has none)", frame, x, y, yaw, cfg.base_frame)


def _run(args: argparse.Namespace) -> int:
    with interrupt_signals():  # SIGTERM as well as SIGINT end the run through its finally blocks
        try:
            return _run_checked(args)
        except KeyboardInterrupt as exc:  # one line, no traceback
            signum = exc.signum if isinstance(exc, RunInterrupted) else int(signal.SIGINT)
            out = getattr(args, "_out", None)
            kept = ""
            if out is not None and (out / "run.json").is_file():
                kept = f"; the frames processed are kept in {out} (status 'interrupted')"
            print(f"pfpeople run: interrupted by {signal.Signals(signum).name}{kept}", file=sys.stderr)
            return 128 + signum


def _run_checked(args: argparse.Namespace) -> int:
    if not Path(args.bag).exists():  # said first: no configuration helps a bag that is not there
        raise FileNotFoundError(f"bag {args.bag!r} does not exist")
    cfg = config_from_args(args)
    _log_config(cfg)
    out = Path(args.out) if args.out else Path(f"{Path(args.bag).name.split('.')[0]}_{cfg.filter.kind}_run")
    inputs = [Path(args.bag)] + ([Path(args.config)] if args.config and Path(args.config).is_file() else [])
    check_output_paths(inputs, out_dir=out, bag_out=args.bag_out)  # no output writes over an input, or another
    if args.bag_out is not None:  # a bad --bag-out fails now, not after the run
        check_bag_out(args.bag_out, args.bag_format, overwrite=args.overwrite)
    elif args.bag_format is not None:
        raise ValueError("--bag-format needs --bag-out")
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {str(out)!r} exists and is not a directory")
    try:
        with BagSource(args.bag) as bag:
            args._out = out
            factory = functools.partial(standard_sinks, scans=not args.no_scans)
            pipeline = Pipeline(
                cfg,
                front_process=False if args.one_process else None,
                sink_factory=factory,
                blas_threads=args.blas_threads,
            )
            summary, _ = pipeline.run(
                bag,
                out,
                max_frames=args.max_frames,
                progress=not args.no_progress,
                overwrite=args.overwrite,
                metadata={"command": "pfpeople run"},
                bag_out=args.bag_out,
                bag_format=args.bag_format,
                bag_input=args.with_input,
            )
    except (BagReadError, FileExistsError, OSError) as exc:  # not caught by the shared CLI plumbing: no traceback
        print(f"pfpeople run: error: {exc}", file=sys.stderr)
        if (out / "run.json").is_file() and not isinstance(exc, FileExistsError):
            print(f"pfpeople run: the frames processed before the error are in {out}", file=sys.stderr)
        return 2
    print(
        f"{summary.frames} frames in {summary.elapsed_s:.2f} s: {summary.fps:.1f} frames/s "
        f"({cfg.filter.kind} filter) -> {out}"
    )
    for name, n in sorted(summary.no_data.items()):
        print(f"  detector {name}: no data in {n} frame(s)")
    for name, n in sorted(summary.empty_scans.items()):
        print(f"  detector {name}: {n} scan(s) without beams")
    sync = summary.sync
    skipped = sync.get("non_monotonic", {})
    if skipped:
        print(f"  skipped non-monotonic messages: {skipped}")
    jumps = sync.get("clock_jump", {})
    if jumps:
        print(f"  skipped messages with an outlier stamp (clock jump): {jumps}")
    if sync.get("resync"):
        print(f"  topics resynchronised to a new clock: {sync['resync']}")
    return 0


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "run",
        epilog=examples(
            "pfpeople run my.bag --config my.toml --out runs/my",
            "pfpeople run outdoor_1.bag.zip --config person_following_outdoor_1 --out runs/pf1 --max-frames 600",
        ),
        help="run detectors and the filter over a bag; write a run directory",
    )
    p.add_argument("bag", help="ROS1 .bag, ROS2 bag folder, or a .zip of either")
    p.add_argument("--config", help="TOML run config, or the name of a built-in one (pfpeople/configs)")
    p.add_argument("--filter", choices=("grid", "particle"), help="filter (default: the config's, else grid)")
    p.add_argument("--out", help="output run directory (default: <bag>_<filter>_run)")
    p.add_argument("--max-frames", type=int, default=None, help="stop after N frames")
    p.add_argument(
        "--bag-out",
        help="also write the results as a bag: a ROS 1 .bag file, or a rosbag2 folder (any other name): "
        "OccupancyGrid, people_msgs/People (people, tracks with ids and velocities), "
        "spencer_tracking_msgs/TrackedPersons (tracks with covariance), MarkerArrays, PoseArrays, /tf_static (with "
        "the [mounts] of lasers without TF), the input scans and TF; and a Foxglove layout OUT.foxglove-layout.json",
    )
    p.add_argument(
        "--bag-format",
        choices=BAG_FORMATS,
        help="format of --bag-out (default: ros1 for a .bag name, otherwise sqlite3; rosbag2 metadata version 5, "
        "which ROS 2 Humble and later read)",
    )
    p.add_argument(
        "--with-input",
        dest="with_input",
        action="store_true",
        default=True,
        help="copy the LaserScan topics the run reads and /tf, /tf_static into --bag-out (default)",
    )
    p.add_argument(
        "--no-input", dest="with_input", action="store_false", help="do not copy the input scans and TF into --bag-out"
    )
    p.add_argument("--driver", help="topic driving the frames (overrides the config)")
    p.add_argument("--odom", help="nav_msgs/Odometry topic ('' for none; overrides the config)")
    p.add_argument("--time-source", choices=("header", "bag"), help="stamps used for synchronisation")
    p.add_argument("--tolerance", type=float, help="synchronisation tolerance (s)")
    p.add_argument("--particles", type=int, help="number of particles (particle filter)")
    p.add_argument("--seed", type=int, help="particle filter seed")
    p.add_argument("--overwrite", action="store_true", help="replace an existing run in --out (and --bag-out)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument(
        "--no-scans",
        action="store_true",
        help="do not store the laser scans (scans.npy, 10 bytes a return: ~7 kB a 720-beam scan) nor the particles "
        "(particles.npy, <= 16 kB a frame) that 'pfpeople view' draws",
    )
    p.add_argument(
        "--one-process",
        action="store_true",
        help="run everything in this process (default: with 2+ cores the detectors and the static-clutter map run in a "
        "second process, ahead of the filter; same results)",
    )
    add_blas_threads_argument(p)
    p.set_defaults(func=_run)
