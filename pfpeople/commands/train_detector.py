"""``pfpeople train-detector``: train the boosted leg-segment classifier on the leg_tracker bags."""

from __future__ import annotations

import argparse
import json
from typing import Any

from pfpeople.detectors.segments import SegmentationParams
from pfpeople.detectors.training import BoostTrainingParams, train_from_directory


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "train-detector",
        help="train the boosted laser segment classifier (detector 2) from labelled bags",
        description=(
            "Train cv2.ml.Boost on leg_tracker's positive_*_extracted.bag (labelled legs) and negative_2.bag "
            "(no people); write <name>.yml and <name>.json (data, parameters, held-out metrics)."
        ),
    )
    p.add_argument("--data-dir", required=True, help="folder with the leg_tracker bags")
    p.add_argument("--out", required=True, help="output folder (e.g. pfpeople/models/)")
    p.add_argument("--name", default="boosted_legs", help="model file stem (default: %(default)s)")
    p.add_argument("--train-positive", nargs="+", default=["positive_1_extracted.bag"])
    p.add_argument("--test-positive", nargs="+", default=["positive_4_extracted.bag"])
    p.add_argument("--negative", default="negative_2.bag")
    d = BoostTrainingParams()
    p.add_argument("--boost-type", default=d.boost_type, choices=["real", "gentle", "discrete", "logit"])
    p.add_argument("--weak-count", type=int, default=d.weak_count)
    p.add_argument("--max-depth", type=int, default=d.max_depth)
    p.add_argument("--negatives-per-positive", type=float, default=d.negatives_per_positive)
    p.add_argument("--holdout-fraction", type=float, default=d.holdout_fraction)
    p.add_argument("--match-radius", type=float, default=d.match_radius, help="label match radius (m)")
    p.add_argument("--jump-distance", type=float, default=SegmentationParams().jump_distance, help="(m)")
    p.add_argument("--seed", type=int, default=d.seed)
    p.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    params = BoostTrainingParams(
        boost_type=args.boost_type,
        weak_count=args.weak_count,
        max_depth=args.max_depth,
        negatives_per_positive=args.negatives_per_positive,
        holdout_fraction=args.holdout_fraction,
        match_radius=args.match_radius,
        seed=args.seed,
    )
    side = train_from_directory(
        args.data_dir,
        args.out,
        params=params,
        train_positive=args.train_positive,
        test_positive=args.test_positive,
        negative=args.negative,
        name=args.name,
        segmentation=SegmentationParams(jump_distance=args.jump_distance),
    )
    print(json.dumps({"model": side["model_file"], "metrics": side["metrics"]}, indent=2))
    return 0
