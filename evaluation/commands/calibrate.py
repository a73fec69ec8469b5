"""``pfpeople-eval calibrate``: measure detectors' PPV and FNR against ground truth.

Three sources:

- ``--scenario NAME``: simulate a scenario and calibrate every detector (also prints the configured miss
  rate and the label-based "oracle" values that matching should recover);
- ``--run RUN_DIR --gt GT.csv``: a ``pfpeople run`` output directory and its ground truth (the CSV format of
  ``pfpeople-eval score``; ``--frame`` names the GT's frame). Every detector of the run is calibrated with its
  recorded field of view. With ``--recall-only`` (ground truth that does not annotate everybody) only the FNR
  is measured: unannotated people would count as false positives;
- ``--truth FILE --detections FILE --detector NAME``: CSV files with a header and columns
  ``frame, x_m, y_m`` (truth: ``frame, person_id, x_m, y_m``; extra columns are ignored), positions in the
  grid's sensor frame; frames run from 0 to the largest frame number in either file (frames without rows
  are empty; only frames with rows are held in memory, and a frame number above 100 million, e.g. a stamp
  in the frame column, is refused naming the file and line). The field of view comes from the named paper
  detector.
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path
from typing import Any

import numpy as np

from evaluation.harness.calibration import (
    MAX_CALIBRATION_FRAMES,
    CalibrationResult,
    calibrate_detector,
    calibrate_frames,
    calibrate_sparse,
    oracle_calibration,
)
from evaluation.harness.run_truth import truth_and_sources
from evaluation.scenarios import Scenario
from gridbridge.grid import GridSpec
from gridbridge.params import PAPER_DETECTORS, DetectorModel, current_detector_name
from pfpeople.cli.support import examples
from pfpeople.io.ground_truth import read_gt_csv
from pfpeople.io.jsonio import dumps
from pfpeople.io.run_dir import load_run


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "calibrate",
        epilog=examples(
            "pfpeople-eval calibrate --scenario complementary",
            "pfpeople-eval calibrate --run runs/pf1 --gt person_following_outdoor_1_gt.csv --recall-only",
        ),
        help="estimate detectors' PPV and FNR from a scenario or from truth + detection CSV files",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--scenario", help="built-in scenario name or scenario TOML file")
    src.add_argument("--truth", type=Path, help="ground-truth CSV (frame, person_id, x_m, y_m)")
    src.add_argument("--run", type=Path, help="run directory written by 'pfpeople run' (with --gt)")
    p.add_argument("--gt", type=Path, help="ground-truth CSV for --run (see pfpeople.io.ground_truth)")
    p.add_argument("--frame", default=None, help="frame of the --gt positions (default: from its columns, else grid)")
    p.add_argument("--recall-only", action="store_true", help="--gt does not annotate everybody: FNR only")
    p.add_argument("--detections", type=Path, help="detections CSV (frame, x_m, y_m) for --truth")
    p.add_argument(
        "--detector",
        default="laser_legs",
        help="paper detector whose field of view applies to --detections (default laser_legs)",
    )
    p.add_argument("--seed", type=int, default=None, help="override the scenario's seed")
    p.add_argument("--frames", type=int, default=None, help="override the scenario's number of frames")
    p.add_argument(
        "--gate",
        action="append",
        default=[],
        metavar="[NAME=]VALUE",
        help="matching gate: metres for point detectors (default 0.5), standard deviations for gaussian ones "
        "(default 3.0); NAME= applies it to one detector (repeatable)",
    )
    p.add_argument("--no-region", action="store_true", help="do not restrict the counts to the grid")
    p.add_argument("--json", type=Path, default=None, help="also write the results as JSON")
    p.set_defaults(func=run)


def _gates(values: list[str]) -> tuple[dict[str, float], float | None]:
    named: dict[str, float] = {}
    default: float | None = None
    for text in values:
        name, sep, value = text.rpartition("=")
        try:
            number = float(value)
        except ValueError:
            raise ValueError(f"--gate {text!r}: not a number") from None
        if sep:
            named[name] = number
        else:
            default = number
    return named, default


def _read_csv(path: Path, what: str) -> dict[int, list[tuple[float, float]]]:
    if not path.is_file():
        raise FileNotFoundError(f"{what} file not found: {path}")
    rows: dict[int, list[tuple[float, float]]] = {}
    with path.open(newline="") as fh:
        reader = csv.DictReader(fh)
        need = {"frame", "x_m", "y_m"}
        if reader.fieldnames is None or not need <= set(reader.fieldnames):
            raise ValueError(f"{path}: header must contain {sorted(need)}, got {reader.fieldnames}")
        for line, row in enumerate(reader, start=2):
            try:
                text = str(row["frame"]).strip()
                frame = int(text) if text.lstrip("+-").isdigit() else int(float(text))
                x, y = float(row["x_m"]), float(row["y_m"])
            except (TypeError, ValueError) as exc:
                raise ValueError(f"{path}:{line}: bad value ({exc})") from exc
            if frame < 0 or not (math.isfinite(x) and math.isfinite(y)):
                raise ValueError(f"{path}:{line}: frame must be >= 0 and positions finite")
            if frame >= MAX_CALIBRATION_FRAMES:
                raise ValueError(
                    f"{path}:{line}: frame {frame} is beyond {MAX_CALIBRATION_FRAMES} frames: the frame column "
                    "must hold frame indices (0, 1, ...), not stamps"
                )
            rows.setdefault(frame, []).append((x, y))
    return rows


def _print(
    results: dict[str, CalibrationResult], extra: dict[str, str] | None = None, *, with_ppv: bool = True
) -> None:
    print(f"{'detector':>16} {'PPV':>6} {'95% CI':>15} {'FNR':>6} {'95% CI':>15} {'TP/det':>11} {'miss/people':>12}")
    for name, r in results.items():
        c = r.counts
        ppv = f"{r.ppv:6.3f} [{r.ppv_interval[0]:.3f},{r.ppv_interval[1]:.3f}]" if with_ppv else f"{'n/a':>6} {'':15}"
        print(
            f"{name:>16} {ppv} {r.fnr:6.3f} "
            f"[{r.fnr_interval[0]:.3f},{r.fnr_interval[1]:.3f}] {c.n_true_positives:>5}/{c.n_detections:<5} "
            f"{c.n_missed:>5}/{c.n_people:<6} {(extra or {}).get(name, '')}"
        )


def _as_json(results: dict[str, CalibrationResult]) -> dict:
    out = {}
    for name, r in results.items():
        c = r.counts
        out[name] = {
            "ppv": r.ppv,
            "fnr": r.fnr,
            "ppv_interval": list(r.ppv_interval),
            "fnr_interval": list(r.fnr_interval),
            "metric": r.metric,
            "gate": r.gate,
            "frames": c.n_frames,
            "detections": c.n_detections,
            "true_positives": c.n_true_positives,
            "people": c.n_people,
            "detected_people": c.n_detected_people,
        }
    return out


def _model_from_run(entry: dict[str, Any]) -> DetectorModel:
    """A ``detector_models`` entry of ``run.json`` as a DetectorModel.

    ``run.json`` is strict JSON, so the run writer stores non-finite floats (an unbounded ``max_range``) as
    the strings ``"inf"``, ``"-inf"``, ``"nan"``; they are turned back into floats here.
    """
    kwargs: dict[str, Any] = {
        k: float(v) if k != "name" and v in ("inf", "-inf", "nan") else v for k, v in entry.items()
    }
    return DetectorModel(**kwargs)


def _calibrate_run(args: argparse.Namespace, named: dict[str, float], default_gate: float | None) -> dict:
    """Calibrate every detector of a pipeline run against a ground-truth CSV."""
    if args.gt is None:
        raise ValueError("--run needs --gt")
    run_data = load_run(args.run)
    truth, sources, unassigned = truth_and_sources(run_data, read_gt_csv(args.gt), frame=args.frame)
    models = {m["name"]: _model_from_run(m) for m in run_data.meta.get("detector_models", [])}
    unknown = set(named) - set(models)
    if unknown:
        raise ValueError(f"--gate names detector(s) {sorted(unknown)} that run {args.run} does not have")
    results = {
        name: calibrate_detector(
            sources[name],
            truth,
            model=model,
            gate=named.get(name, default_gate),
            region=None if args.no_region else run_data.spec,
        )
        for name, model in models.items()
    }
    print(f"run {args.run} ({run_data.n_frames} frames) vs {args.gt} ({unassigned} GT rows outside the run's frames)")
    _print(results, with_ppv=not args.recall_only)
    matched = _as_json(results)
    if args.recall_only:
        print("recall only: the ground truth does not annotate everybody, so PPV is not measured (FNR only)")
        for entry in matched.values():
            entry["ppv"] = None
            entry["ppv_interval"] = None
    return {"run": str(args.run), "gt": str(args.gt), "matched": matched}


def run(args: argparse.Namespace) -> int:
    named, default_gate = _gates(args.gate)
    report: dict = {}
    if args.scenario is not None:
        scenario = Scenario.from_name(args.scenario, seed=args.seed, n_frames=args.frames)
        cfg = scenario.config
        region: GridSpec | None = None if args.no_region else scenario.spec
        models = cfg.detector_models
        unknown = set(named) - {m.name for m in models}
        if unknown:
            raise ValueError(f"--gate names unknown detector(s) {sorted(unknown)}")
        gates = {m.name: named.get(m.name, default_gate) for m in models}
        frames = list(scenario)
        results = calibrate_frames(
            frames, models, gates={k: v for k, v in gates.items() if v is not None}, region=region
        )
        oracle = oracle_calibration(frames, region=region)
        print(f"scenario {cfg.name!r}, {len(frames)} frames, seed {cfg.seed}; matching (Hungarian within the gate):")
        extra = {
            d.name: f"configured miss {d.miss_rate:.3f}, clutter {d.clutter_rate:.3f}/frame; "
            f"labels: PPV {oracle[d.name].ppv:.3f} FNR {oracle[d.name].fnr:.3f}"
            for d in cfg.detectors
        }
        _print(results, extra)
        report = {"scenario": cfg.name, "seed": cfg.seed, "matched": _as_json(results), "labels": _as_json(oracle)}
    elif args.run is not None:
        report = _calibrate_run(args, named, default_gate)
    else:
        if args.detections is None:
            raise ValueError("--truth needs --detections")
        by_name = {m.name: m for m in PAPER_DETECTORS}
        detector = current_detector_name(args.detector)  # the old "laser-legs" reads as "laser_legs"
        if detector not in by_name:
            raise ValueError(f"--detector must be one of {sorted(by_name)}, got {args.detector!r}")
        model = by_name[detector]
        truth = _read_csv(args.truth, "truth")
        dets = _read_csv(args.detections, "detections")
        if not truth and not dets:
            raise ValueError("--truth and --detections hold no rows")
        result = calibrate_sparse(
            {k: np.array(v, dtype=float).reshape(-1, 2) for k, v in dets.items()},
            {k: np.array(v, dtype=float).reshape(-1, 2) for k, v in truth.items()},
            model=model,
            gate=named.get(model.name, default_gate),
            region=None if args.no_region else GridSpec(),
        )
        _print({model.name: result})
        report = {
            "files": {"truth": str(args.truth), "detections": str(args.detections)},
            "matched": _as_json({model.name: result}),
        }
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(dumps(report))
        print(f"wrote {args.json}")
    return 0
