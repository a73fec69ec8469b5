"""``pfpeople inspect BAG``: what a bag holds, and a starter run configuration for it.

Examples::

    pfpeople inspect my.bag                              # topics, rates, TF tree, lasers, odometry
    pfpeople inspect my_ros2_bag/ --json                 # the same as JSON
    pfpeople inspect my.bag --write-config my.toml       # then: pfpeople run my.bag --config my.toml
    pfpeople inspect my.bag --write-config my.toml --opt-in   # with the learned detector active

See :mod:`pfpeople.io.bag.inspect` for what is measured and how the configuration is chosen.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path
from typing import Any

from pfpeople.cli.support import examples
from pfpeople.io.bag.inspect import format_report, inspect_bag, starter_config
from pfpeople.io.bag.reader import BagReadError, BagSource
from pfpeople.io.jsonio import dumps


def _run(args: argparse.Namespace) -> int:
    path = Path(args.write_config) if args.write_config else None
    if path is not None and path.exists() and not args.overwrite:  # refused before the bag is read and reported
        raise FileExistsError(f"--write-config {str(path)!r} exists (use --overwrite to replace it)")
    try:
        with BagSource(args.bag) as bag:
            report = inspect_bag(bag, sample=args.sample, name=args.bag)
    except BagReadError as exc:  # not caught by the shared CLI plumbing: no traceback
        print(f"pfpeople inspect: error: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(dumps(report.to_dict()))
    else:
        print(format_report(report))
    if path is not None:
        path.write_text(starter_config(report, driver=args.driver, opt_in=args.opt_in))
        bag_arg, cfg_arg = shlex.quote(str(args.bag)), shlex.quote(str(path))  # a command to paste into a shell
        print(f"wrote {path}: run it with  pfpeople run {bag_arg} --config {cfg_arg}", file=sys.stderr)
    return 0


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "inspect",
        epilog=examples(
            "pfpeople inspect my.bag --write-config my.toml",
            "pfpeople inspect person_following_outdoor_1.bag.zip --json",
        ),
        help="list a bag's topics, rates, TF tree, lasers and odometry; write a starter config",
        description=(
            "Inspect a ROS1 .bag, a ROS2 bag folder or a .zip of either: topics, types, counts, rates, header "
            "frame ids, the 2-D TF tree, each LaserScan's field of view, beams and range, odometry, time span."
        ),
    )
    p.add_argument("bag", help="ROS1 .bag, ROS2 bag folder, or a .zip of either")
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.add_argument("--write-config", metavar="FILE", help="write a starter TOML run config for 'pfpeople run'")
    p.add_argument("--driver", help="LaserScan topic for the config (default: the one with the most messages)")
    p.add_argument(
        "--opt-in",
        action="store_true",
        help="write the opt-in detectors (the learned detector) active, not commented out, where they suit a laser",
    )
    p.add_argument("--overwrite", action="store_true", help="replace an existing --write-config file")
    p.add_argument("--sample", type=int, default=200, help="messages decoded per topic (default: %(default)s)")
    p.set_defaults(func=_run)
