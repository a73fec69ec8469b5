"""``pfpeople-eval score RUN_DIR --gt GT.csv``: score a run against ground truth, per detector and filter.

Each detector alone (its detections in ``detections.csv``) and the filter output (the classified people in
``people.csv``) are matched one-to-one to the ground truth of every frame with
:func:`evaluation.metrics.detection.match_people` (distance gate ``--gate``, default 0.5 m). Frames where a detector
had no data count for it with no detections. Optional limits, applied to ground truth and detections alike
in the grid frame: a bearing sector ``--sector DEG_MIN DEG_MAX``, a range ``--max-range M``, and ``--in-grid``
(the run's grid, which is all a filter can report: the scoring of ``pfpeople-eval benchmark``).

Metrics: recall = TP / (TP + FN); precision = TP / (TP + FP); FPCPF (filter only) = mean over frames of
the cells classified as people (paper's blob classification of the stored belief) that are free in the
ground truth, where the ground-truth occupancy of a frame is every cell whose centre lies within
``--person-radius`` (default 0.3 m) of a true person or that contains one. With ``--recall-only`` (ground
truth that does not annotate everybody, e.g. passers-by in the leg_tracker person-following bags) precision
and FPCPF are not reported: unannotated people would count as false positives.

Ground-truth frame: a GT file whose columns name a frame (``x_laser_m``) is in that frame, and ``--frame``, if
given, must agree (else an error naming both). For plain ``x``, ``y`` columns: ``--frame grid`` (default) means
the GT is in the run's grid frame; ``--frame laser`` means the frame of the driving sensor; any other name must
be one the run recorded (``frames_in_grid`` in ``run.json``).

Matching: GT rows keyed by ``stamp_ns`` go to the nearest run frame within half the run's median frame period,
rows keyed by ``bag_time_ns`` (a record time) to the latest frame recorded at most one period before them
(:func:`pfpeople.io.ground_truth.match_window_ns`; ``gt_match_window_s`` in the result).

Coverage: the score says how many GT rows fell on no run frame (``gt_rows_unassigned``: before the run's first
frame, between frames further apart than the window, after its last frame, each counted), how many GT frames had
no run frame (``gt_frames_without_run_frame``) and how many lie after the run's last frame
(``gt_frames_beyond_run``: a run stopped early or a ``frames.csv`` cut short); every such row is also logged as a
warning: none is dropped silently.

Stamps: a GT keyed by ``scan_index`` that also has ``stamp_ns`` (or ``bag_time_ns``) is checked against the
run's frames (:func:`evaluation.harness.run_truth.check_gt_stamps`): more than 10 % of the matched rows disagreeing (a
shifted ``scan_index``, the GT of another recording) is an error naming the first such line and the offset;
fewer are counted (``gt_rows_stamp_mismatch``) and logged as a warning.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from evaluation.harness.run_truth import gt_coverage, in_region, truth_and_sources
from evaluation.metrics.detection import DetectionAccumulator
from gridbridge.blobs import classify_blobs
from gridbridge.grid import GridSpec
from pfpeople.cli.support import examples
from pfpeople.io.ground_truth import GroundTruth, read_gt_csv, resolve_gt_frame
from pfpeople.io.jsonio import dumps
from pfpeople.io.run_dir import RunData, load_run

__all__ = ["score_run"]


def _occupancy(
    spec: GridSpec, centres: tuple[NDArray[np.float64], NDArray[np.float64]], people: NDArray[np.float64], radius: float
) -> NDArray[np.bool_]:
    """Ground-truth occupancy: cells whose centre (``spec.cell_centres()``) is within ``radius`` of a person
    or that contain one."""
    gx, gy = centres
    occ = np.zeros(spec.shape, dtype=bool)
    for x, y in people:
        occ |= np.hypot(gx - x, gy - y) <= radius
        if spec.contains(x, y):
            i, j = spec.to_cell(x, y)
            occ[int(i), int(j)] = True
    return occ


def score_run(
    run: RunData,
    gt: GroundTruth,
    *,
    frame: str | None = None,
    sector: tuple[float, float] | None = None,
    max_range: float | None = None,
    gate: float = 0.5,
    recall_only: bool = False,
    person_radius: float = 0.3,
    tolerance_ns: int | None = None,
    in_grid: bool = False,
) -> dict[str, Any]:
    """Score every detector and the filter of ``run`` against ``gt`` (see the module docstring).

    Returns
    -------
    dict
        ``{"frames": F, "gt_rows": R, "gt_rows_unassigned": U, "gt_frames": G, "gt_frames_without_run_frame": M,
        "gt_frames_beyond_run": B, "gt_rows_beyond_run": RB, "gt_rows_before_run": RA, "gt_rows_between_frames": RG,
        "gt_match_window_s": W, "gt_rows_stamp_mismatch": S, "gt_frame": name, "scores": {name: summary}}``
        (see :func:`evaluation.harness.run_truth.gt_coverage`) where ``name`` is each detector and ``"filter"``; a
        summary has frames, tp, fp, fn, recall, mean_match_distance_m and (unless ``recall_only``) precision
        and, for the filter, fpcpf.
    """
    truth, sources, unassigned = truth_and_sources(
        run, gt, frame=frame, sector=sector, max_range=max_range, tolerance_ns=tolerance_ns
    )
    n = run.n_frames
    spec = run.spec
    if in_grid:

        def inside(per_frame: list[NDArray[np.float64]]) -> list[NDArray[np.float64]]:
            return [p[spec.contains(p[:, 0], p[:, 1])] if len(p) else p for p in per_frame]

        truth = inside(truth)
        sources = {name: inside(per_frame) for name, per_frame in sources.items()}
    centres = spec.cell_centres()
    gx, gy = centres
    cell_region = in_region(np.column_stack((gx.ravel(), gy.ravel())), sector, max_range).reshape(spec.shape)
    scores: dict[str, Any] = {}
    for name, per_frame in sources.items():
        acc = DetectionAccumulator(gate=gate)
        for k in range(n):
            d = per_frame[k]
            classified = occupancy = None
            if name == "filter" and not recall_only:
                classified = classify_blobs(np.asarray(run.grids[k], dtype=float), spec=spec).mask & cell_region
                occupancy = _occupancy(spec, centres, truth[k], person_radius)
            acc.add(d, truth[k], classified=classified, occupancy=occupancy)
        summary = acc.summary()
        keep = ["frames", "tp", "fp", "fn", "recall", "mean_match_distance_m"]
        if not recall_only:
            keep += ["precision"] + (["fpcpf"] if name == "filter" else [])
        scores[name] = {k: summary[k] for k in keep}
    return {
        "frames": n,
        "gt_rows": len(gt),
        "gt_rows_unassigned": unassigned,
        **gt_coverage(run, gt, tolerance_ns=tolerance_ns),
        "gt_frame": resolve_gt_frame(gt, frame),
        "scores": scores,
    }


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return "nan" if math.isnan(v) else f"{v:.3f}"
    return str(v)


def _score(args: argparse.Namespace) -> int:
    run = load_run(args.run_dir)
    gt = read_gt_csv(args.gt, frame=args.frame)
    result = score_run(
        run,
        gt,
        frame=args.frame,
        sector=tuple(args.sector) if args.sector else None,
        max_range=args.max_range,
        gate=args.gate,
        recall_only=args.recall_only,
        person_radius=args.person_radius,
        in_grid=args.in_grid,
    )
    status = run.meta.get("status")
    print(
        f"run {args.run_dir} ({status}, {result['frames']} frames) vs {args.gt} ({result['gt_rows']} GT rows, "
        f"{result['gt_rows_unassigned']} on no run frame; GT frame {result['gt_frame']!r})"
    )
    if result["gt_rows_unassigned"]:
        window = result["gt_match_window_s"]
        print(
            f"GT rows on no run frame: {result['gt_rows_before_run']} before its first frame, "
            f"{result['gt_rows_between_frames']} between frames"
            + (f" (further than {window:.3f} s)" if window else "")
            + f", {result['gt_rows_beyond_run']} after its last frame"
        )
    print(
        f"GT frames: {result['gt_frames']}, of which {result['gt_frames_without_run_frame']} had no run frame"
        + (
            f" ({result['gt_frames_beyond_run']} after the run's last frame: stopped early or frames.csv cut short)"
            if result["gt_frames_beyond_run"]
            else ""
        )
    )
    if result["gt_rows_stamp_mismatch"]:
        print(f"GT rows whose stamp disagrees with their run frame's: {result['gt_rows_stamp_mismatch']}")
    cols = ["tp", "fp", "fn", "recall"] + ([] if args.recall_only else ["precision", "fpcpf"])
    print(f"{'source':<18}" + "".join(f"{c:>10}" for c in cols))
    for name, s in result["scores"].items():
        print(f"{name:<18}" + "".join(f"{_fmt(s.get(c, '')):>10}" for c in cols))
    if args.recall_only:
        print("recall only: the ground truth does not annotate everybody (precision/FPCPF not meaningful)")
    if args.json:
        Path(args.json).write_text(dumps(result, default=str) + "\n")
    return 0


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "score",
        epilog=examples(
            "pfpeople-eval score runs/pf1 --gt person_following_outdoor_1_gt.csv --recall-only",
        ),
        help="score a pfpeople run directory against a ground-truth CSV",
    )
    p.add_argument("run_dir", help="run directory written by 'pfpeople run'")
    p.add_argument("--gt", required=True, help="ground-truth CSV (see pfpeople.io.ground_truth)")
    p.add_argument(
        "--frame",
        default=None,
        help="frame of the GT positions: the one its columns name (x_<frame>_m), else grid (default), laser, a name",
    )
    p.add_argument("--sector", nargs=2, type=float, metavar=("DEG_MIN", "DEG_MAX"), help="bearing sector (deg)")
    p.add_argument("--max-range", type=float, help="range limit (m)")
    p.add_argument(
        "--in-grid", action="store_true", help="score only inside the run's grid (as pfpeople-eval benchmark does)"
    )
    p.add_argument("--gate", type=float, default=0.5, help="matching distance (m), default 0.5")
    p.add_argument("--recall-only", action="store_true", help="GT does not annotate everybody: recall only")
    p.add_argument("--person-radius", type=float, default=0.3, help="GT occupancy radius for FPCPF (m)")
    p.add_argument("--json", help="also write the scores to this JSON file")
    p.set_defaults(func=_score)
