"""``pfpeople train-detector``: train the boosted leg-segment classifier (``--kind boosted``) or the learned
whole-scan detector (``--kind learned``, needs the ``[train]`` extra) on labelled bags."""

from __future__ import annotations

import argparse
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pfpeople.cli.support import examples
from pfpeople.detect.people_bags import find_people_bags
from pfpeople.detect.segments import SegmentationParams
from pfpeople.detect.training import POSITIVE_BAGS, BoostTrainingParams, train_from_directory


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "train-detector",
        epilog=examples(
            "pfpeople train-detector --data-dir ../shared/data/leg_tracker --people-bags sim-train --out models/",
            "pfpeople train-detector --kind learned --data-dir ../shared/data/leg_tracker --people-bags sim-learned "
            "--weak-bags ../shared/data/leg_tracker/demo_stationary_simple_environment.bag --out pfpeople/models/",
        ),
        help="train a laser detector (boosted segments or the learned whole-scan detector) from labelled bags",
        description=(
            "Train cv2.ml.Boost on leg_tracker's positive_*_extracted.bag (labelled legs) and negative_2.bag "
            "(no people); write <name>.yml and <name>.json (data with SHA-256, parameters, metrics). By default it "
            "trains on all six labelled bags and all of negative_2 and records a leave-one-bag-out evaluation "
            "(each positive bag held out in turn, negatives of another laser and time period). --people-bags adds "
            "bags annotated with people's centres (every <name>.bag below the folder with <name>_gt.csv beside it, "
            "as pfpeople-eval simulate-bag writes them): segments within 0.3 m of a person the laser saw are legs, "
            "segments farther than 1 m from everyone are not. With --kind learned it trains the learned whole-scan "
            "detector (PyTorch on the CPU: pip install 'pfpeople[train]') on the same bags, the followed person of "
            "person_following_outdoor_1, weak labels of standing lasers' recordings (--weak-bags) and the "
            "--people-bags; runs the six leave-one-bag-out folds, chooses the operating threshold and measures PPV / "
            "FNR on what they hold out, and writes <name>.npz (weights, run with NumPy) and <name>.json (the model "
            "card: data, folds, figures, lasers). docs/learned_detector.md says how to adapt it to your laser."
        ),
    )
    p.add_argument(
        "--kind", choices=["boosted", "learned"], default="boosted", help="which detector (default: %(default)s)"
    )
    p.add_argument("--data-dir", required=True, help="folder with the leg_tracker bags")
    p.add_argument("--out", required=True, help="output folder (e.g. pfpeople/models/)")
    p.add_argument("--name", default=None, help="model file stem (default: boosted_legs / learned_people)")
    p.add_argument("--train-positive", nargs="+", default=list(POSITIVE_BAGS), help="default: all six")
    p.add_argument("--test-positive", nargs="*", default=[], help="bags held out of training (default: none)")
    p.add_argument("--negative", default="negative_2.bag")
    p.add_argument("--people-bags", type=Path, default=None, metavar="DIR", help="bags annotated with people")
    p.add_argument("--people-topic", default="/scan", help="their LaserScan topic (default: %(default)s)")
    d = BoostTrainingParams()
    p.add_argument("--boost-type", default=d.boost_type, choices=["real", "gentle", "discrete", "logit"])
    p.add_argument("--weak-count", type=int, default=d.weak_count)
    p.add_argument("--max-depth", type=int, default=d.max_depth)
    p.add_argument("--negatives-per-positive", type=float, default=d.negatives_per_positive)
    p.add_argument("--holdout-fraction", type=float, default=d.holdout_fraction)
    p.add_argument("--match-radius", type=float, default=d.match_radius, help="label match radius (m)")
    p.add_argument("--jump-distance", type=float, default=SegmentationParams().jump_distance, help="(m)")
    p.add_argument("--seed", type=int, default=d.seed)
    p.add_argument(
        "--augment-noise",
        type=float,
        nargs="*",
        default=list(d.augment_noise),
        metavar="SD",
        help="train also on noisy copies of every scan, one per range-noise sd in m (default: %(default)s; "
        "none: no copies)",
    )
    p.add_argument("--scan-step", type=int, default=1, help="use every N-th scan (quick runs; default all)")
    p.add_argument("--no-leave-one-out", action="store_true", help="skip the leave-one-bag-out evaluation")
    _learned_arguments(p)
    p.set_defaults(func=_run)


def _learned_arguments(p: argparse.ArgumentParser) -> None:
    from pfpeople.detect.learned.recipe import LearnedRecipe
    from pfpeople.detect.learned.training import ARCHITECTURES

    r = LearnedRecipe()
    g = p.add_argument_group("--kind learned")
    g.add_argument(
        "--weak-bags",
        nargs="*",
        default=[],
        metavar="BAG[:TOPIC]",
        help="recordings of a standing laser to weakly label (topic default /scan)",
    )
    g.add_argument(
        "--negative-bags",
        nargs="*",
        default=[],
        metavar="BAG[:TOPIC]",
        help="people-free drives through your own rooms (topic default /scan): their clutter is what the "
        "model must learn to say no to",
    )
    g.add_argument("--architecture", choices=sorted(ARCHITECTURES), default=r.architecture)
    g.add_argument("--past-scans", type=int, default=r.past_scans, help="past scans as input (default: %(default)s)")
    g.add_argument("--motion-input", action="store_true", help="the motion detector's moved returns as input")
    g.add_argument("--epochs", type=int, default=r.fit.epochs)
    g.add_argument("--fold-dir", type=Path, default=None, help="also write the six fold models here")
    g.add_argument(
        "--threshold",
        type=float,
        default=None,
        help=f"operating threshold: detections scoring less are not reported nor fused (default: {r.threshold}; "
        "with --recalibrate: the card's)",
    )
    g.add_argument(
        "--calibration-bags",
        type=Path,
        default=None,
        metavar="DIR",
        help="simulated bags (as --people-bags) to measure PPV / FNR on, not trained on",
    )
    g.add_argument(
        "--recalibrate",
        action="store_true",
        help="do not train: measure the model in --out and its fold models in --fold-dir again on what each holds "
        "out and --calibration-bags (PPV, FNR, PPV by score, the leave-one-bag-out table) and rewrite their cards "
        "(no PyTorch needed)",
    )


def _run(args: argparse.Namespace) -> int:
    if args.kind == "learned":
        return _run_learned(args)
    params = BoostTrainingParams(
        boost_type=args.boost_type,
        weak_count=args.weak_count,
        max_depth=args.max_depth,
        negatives_per_positive=args.negatives_per_positive,
        holdout_fraction=args.holdout_fraction,
        match_radius=args.match_radius,
        seed=args.seed,
        augment_noise=tuple(args.augment_noise),
    )
    side = train_from_directory(
        args.data_dir,
        args.out,
        params=params,
        train_positive=args.train_positive,
        test_positive=args.test_positive,
        negative=args.negative,
        name=args.name or "boosted_legs",
        segmentation=SegmentationParams(jump_distance=args.jump_distance),
        leave_one_out=not args.no_leave_one_out,
        scan_step=args.scan_step,
        people_bags=find_people_bags(args.people_bags) if args.people_bags is not None else (),
        people_topic=args.people_topic,
    )
    lobo = side["leave_one_bag_out"]
    print(json.dumps({"model": side["model_file"], "metrics": side["metrics"]}, indent=2, default=str))
    if isinstance(lobo, dict):
        print(format_leave_one_out(lobo))
    return 0


def _bag_topic(spec: str) -> tuple[Path, str]:
    bag, _, topic = spec.partition(":")
    return Path(bag), topic or "/scan"


def _run_learned(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from pfpeople.detect.learned.build import train_learned_from_directory
    from pfpeople.detect.learned.recipe import LearnedRecipe
    from pfpeople.extras import require

    if args.recalibrate:
        return _recalibrate_learned(args)
    require("train", "pfpeople train-detector --kind learned")  # before minutes of loading
    r = LearnedRecipe()
    recipe = replace(
        r,
        architecture=args.architecture,
        past_scans=args.past_scans,
        motion_input=args.motion_input,
        threshold=r.threshold if args.threshold is None else args.threshold,
        fit=replace(r.fit, epochs=args.epochs, seed=args.seed),
    )
    out = Path(args.out) / f"{args.name or 'learned_people'}.npz"
    card = train_learned_from_directory(
        args.data_dir,
        out,
        people_bags=find_people_bags(args.people_bags) if args.people_bags is not None else (),
        weak_bags=[_bag_topic(b) for b in args.weak_bags],
        negative_bags=[_bag_topic(b) for b in args.negative_bags],
        calibration_bags=find_people_bags(args.calibration_bags) if args.calibration_bags is not None else (),
        recipe=recipe,
        leave_one_out=not args.no_leave_one_out,
        fold_dir=args.fold_dir,
        say=lambda m: print(m, flush=True),
    )
    print(f"wrote {out} and {out.with_suffix('.json')}")
    print(format_learned(card))
    return 0


def _recalibrate_learned(args: argparse.Namespace) -> int:
    from pfpeople.detect.learned.build import recalibrate_learned

    if args.fold_dir is None:
        raise SystemExit("pfpeople train-detector --recalibrate: give --fold-dir (the fold models to score)")
    out = Path(args.out) / f"{args.name or 'learned_people'}.npz"
    card = recalibrate_learned(
        args.data_dir,
        out,
        fold_dir=args.fold_dir,
        calibration_bags=find_people_bags(args.calibration_bags) if args.calibration_bags is not None else (),
        threshold=args.threshold,
        say=lambda m: print(m, flush=True),
    )
    print(f"rewrote {out.with_suffix('.json')} and the fold cards in {args.fold_dir}")
    print(format_learned(card))
    return 0


def format_learned(card: Mapping[str, Any]) -> str:
    """The learned model's leave-one-bag-out table and operating point."""
    lobo = card["leave_one_bag_out"]
    lines = [f"{'held out':<44}{'AP0.3':>7}{'AP0.5':>7}{'R@P.90':>8}"]
    for f in lobo["folds"]:
        lines.append(f"{f['fold']:<44}{_f(f['ap_03']):>7}{_f(f['ap_05']):>7}{_f(f['recall_at_p90']):>8}")
    p = lobo["pooled"]
    if p:
        lines.append(f"{'pooled':<44}{_f(p['ap_03']):>7}{_f(p['ap_05']):>7}{_f(p['recall_at_p90']):>8}")
        lines.append(f"negative_2 false people per scan at the threshold: {_f(p['negative_2_false_per_scan'])}")
    cal = card["calibration"]
    lines.append(
        f"threshold {card['threshold']:.3f}: PPV {cal['ppv']:.3f}, FNR {cal['fnr']:.3f} ({cal['measured_on']})"
    )
    return "\n".join(lines)


def _f(v: Any) -> str:
    return "-" if v is None or (isinstance(v, float) and v != v) else f"{v:.3f}"


def format_leave_one_out(lobo: Mapping[str, Any]) -> str:
    """The leave-one-bag-out table: held-out bag, segment precision / recall / F1, false leg segments per scan."""
    lines = [f"{'held-out bag':<26}{'negatives':>14}{'precision':>10}{'recall':>8}{'F1':>7}{'FP seg/scan':>12}"]
    for f in lobo["folds"]:
        neg = f"{f['negative_topic']}#{f['negative_period']}"
        lines.append(
            f"{f['bag']:<26}{neg:>14}{_f(f['precision']):>10}{_f(f['recall']):>8}{_f(f['f1']):>7}"
            f"{_f(f['false_leg_segments_per_negative_scan']):>12}"
        )
    p = lobo["pooled"]
    lines.append(
        f"{'pooled':<26}{'':>14}{_f(p['precision']):>10}{_f(p['recall']):>8}{_f(p['f1']):>7}"
        f"{_f(p['false_leg_segments_per_negative_scan']):>12}"
    )
    return "\n".join(lines)
