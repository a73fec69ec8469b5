"""``pfpeople-eval simulate``: run a scenario and dump its frames (ground truth, odometry, detections)."""

from __future__ import annotations

import argparse
import csv
import logging
import re
from pathlib import Path

import numpy as np

from evaluation.scenarios import Scenario, builtin_scenarios
from pfpeople.cli.support import examples

log = logging.getLogger(__name__)


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "simulate",
        epilog=examples(
            "pfpeople-eval simulate corridor --out frames.npz",
            "pfpeople-eval simulate complementary --csv-dir csv",
        ),
        help="run a scenario (built-in name or TOML file) and dump truth, odometry and detections",
        description=(
            "Simulate a scenario and print a summary. Built-in scenarios: "
            + ", ".join(builtin_scenarios())
            + ". --out writes an .npz; --csv-dir writes truth.csv and detections_<name>.csv (the input of "
            "'pfpeople-eval calibrate --truth ... --detections ...')."
        ),
    )
    p.add_argument("scenario", help="built-in scenario name or path to a scenario TOML file")
    p.add_argument("--seed", type=int, default=None, help="override the scenario's seed")
    p.add_argument("--frames", type=int, default=None, help="override the number of frames")
    p.add_argument("--out", type=Path, default=None, help="write every frame to this .npz file")
    p.add_argument("--csv-dir", type=Path, default=None, help="write truth and detections as CSV files here")
    p.set_defaults(func=run)


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name)


def run(args: argparse.Namespace) -> int:
    scenario = Scenario.from_name(args.scenario, seed=args.seed, n_frames=args.frames)
    cfg = scenario.config
    spec = scenario.spec
    names = [d.name for d in cfg.detectors]
    people_rows: list[tuple[int, int, float, float]] = []
    det_rows: list[list[tuple[int, float, float, int]]] = [[] for _ in names]
    truth = np.zeros((len(scenario), *spec.shape), dtype=bool)
    n_in_grid = 0
    n_occluded = np.zeros(len(names), dtype=int)
    n_in_view = np.zeros(len(names), dtype=int)
    for frame in scenario:
        k = frame.index
        truth[k] = frame.truth_grid
        n_in_grid += int(np.count_nonzero(spec.contains(frame.people[:, 0], frame.people[:, 1])))
        people_rows.extend(
            (k, int(i), float(x), float(y)) for i, (x, y) in zip(frame.person_ids, frame.people, strict=True)
        )
        for d, out in enumerate(frame.outputs):
            det_rows[d].extend(
                (k, float(x), float(y), int(s)) for (x, y), s in zip(out.positions, out.source, strict=True)
            )
            n_occluded[d] += out.occluded_ids.size
            n_in_view[d] += out.in_view_ids.size
    n = len(scenario)
    path_len = float(np.sum(np.abs(scenario.v)) * scenario.dt)
    print(f"scenario {cfg.name!r}: {n} frames of {cfg.dt} s, seed {cfg.seed}, people from {cfg.people}")
    print(
        f"robot: {path_len:.1f} m driven, v in [{scenario.v.min():.2f}, {scenario.v.max():.2f}] m/s, "
        f"|omega| <= {np.abs(scenario.omega).max():.2f} rad/s"
    )
    print(
        f"people: {len(scenario.person_ids)} in total, {n_in_grid / n:.2f} in the grid per frame, "
        f"{truth.sum() / n:.1f} occupied cells per frame"
    )
    for d, name in enumerate(names):
        rows = det_rows[d]
        n_true = sum(1 for r in rows if r[3] >= 0)
        occ = n_occluded[d] / n_in_view[d] if n_in_view[d] else 0.0
        print(
            f"  {name:>16}: {len(rows) / n:.2f} detections per frame, {n_true / max(len(rows), 1):.3f} true, "
            f"{occ:.3f} of people in view occluded"
        )
    if args.out is not None:
        arrays: dict[str, np.ndarray] = {
            "stamp": scenario.times,
            "v": scenario.v,
            "omega": scenario.omega,
            "v_odom": scenario.v_odom,
            "omega_odom": scenario.omega_odom,
            "robot_pose": scenario.robot_poses,
            "truth_grid": truth,
            "people": np.array(people_rows, dtype=float).reshape(-1, 4),
            "detector_names": np.array(names),
            "grid": np.array([spec.nx, spec.ny, spec.resolution, spec.x0, spec.y0], dtype=float),
        }
        for d in range(len(names)):
            arrays[f"detections_{d}"] = np.array(det_rows[d], dtype=float).reshape(-1, 4)
        args.out.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(args.out, **arrays)  # type: ignore[arg-type]
        print(f"wrote {args.out} (people: frame,id,x,y; detections_<i>: frame,x,y,source)")
    if args.csv_dir is not None:
        args.csv_dir.mkdir(parents=True, exist_ok=True)
        with (args.csv_dir / "truth.csv").open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["frame", "person_id", "x_m", "y_m"])
            w.writerows(people_rows)
        for d, name in enumerate(names):
            with (args.csv_dir / f"detections_{_safe(name)}.csv").open("w", newline="") as fh:
                w = csv.writer(fh)
                w.writerow(["frame", "x_m", "y_m", "source"])
                w.writerows(det_rows[d])
        print(f"wrote truth.csv and {len(names)} detections_<name>.csv to {args.csv_dir}")
    return 0
