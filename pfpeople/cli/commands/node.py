"""``pfpeople node``: the live ROS 1 node (:mod:`pfpeople.ros1.node`), configured by the same TOML as ``pfpeople run``.

Examples::

    pfpeople node --config my.toml                      # ROS_MASTER_URI as usual; results under /pfpeople
    pfpeople node --config my.toml --frame odom         # people, tracks and markers in odom
    pfpeople node --config my.toml --stats node.json    # frames, drops and latency p50 / p99 as JSON at the end

Exit codes: 0 stopped (SIGINT / SIGTERM, or ``--max-frames``), 2 bad input or ROS 1 not installed (one line naming
the apt packages to install).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from typing import Any

from pfpeople.cli.support import examples
from pfpeople.config import OutputConfig
from pfpeople.pipeline.bag_run import resolve_config


def _run(args: argparse.Namespace) -> int:
    from pfpeople.ros1.node import run_node
    from pfpeople.ros1.system import RosMissingError

    cfg = resolve_config(args.config, ())
    if args.frame is not None:
        cfg = replace(cfg, output=OutputConfig(frame=args.frame))
    try:
        stats = run_node(
            cfg,
            prefix=args.prefix,
            python=args.ros_python,
            node_name=args.name,
            stats_path=args.stats,
            max_frames=args.max_frames,
            drop=not args.no_drop,
        )
    except RosMissingError as exc:
        print(f"pfpeople node: error: {exc}", file=sys.stderr)
        return 2
    print(f"pfpeople node: {stats.summary()}")
    return 0


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "node",
        epilog=examples("pfpeople node --config my.toml", "pfpeople node --config my.toml --frame odom --stats n.json"),
        help="run live on ROS 1: subscribe to the config's scans, odometry and TF; publish people, tracks and the grid",
    )
    p.add_argument("--config", required=True, help="TOML run config (as for 'pfpeople run'), or a built-in one's name")
    p.add_argument("--frame", help="frame of the published people, tracks and markers (overrides [output] frame)")
    p.add_argument("--prefix", default="/pfpeople", help="namespace of the output topics (default /pfpeople)")
    p.add_argument("--name", default="pfpeople", help="ROS node name (default pfpeople)")
    p.add_argument(
        "--ros-python",
        help="a Python that imports rospy (default: $PFPEOPLE_ROS_PYTHON, else /usr/bin/python3, else this one)",
    )
    p.add_argument("--stats", help="write frames, dropped scans and the latency per scan (JSON) here at the end")
    p.add_argument("--max-frames", type=int, help="stop after N frames")
    p.add_argument(
        "--no-drop",
        action="store_true",
        help="process every scan however late (a bag replayed into the node; default: a scan a newer one waits "
        "behind is dropped and counted, so the node never falls behind)",
    )
    p.set_defaults(func=_run)
