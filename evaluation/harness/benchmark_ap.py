"""The benchmark's detection table: every laser detector alone and the fused output, scored as DROW scores
detectors (:mod:`evaluation.harness.detector_ap`), on the scenes ``pfpeople-eval benchmark`` ran.

* scan-level scenes: the built-in detectors, the motion detector and the shipped learned detector (trained on other
  seeds of randomised scenes) on the scene's scans with its odometry, and the pipeline run's reported people (scored
  by their belief), all inside the run's grid;
* ``positive_bags``: leave one bag out, pooled over the six bags: the boosted and single-legs detectors with the
  boosted model the benchmark trained without the bag, the learned detector's fold model that did not see it
  (``evaluation/models/learned_people_without_positive_<k>.npz``, written by ``make model``), the fused output of
  the bag's run; in leg_tracker's labelling box;
* ``negative_2``: false people per scan on each laser: the learned detector's fold models on the laser-halves they
  held out, the others (the shipped boosted model saw all of negative_2) and each laser's run on the whole laser.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

from evaluation.harness.detector_ap import (
    ApRow,
    ap_row,
    builtin_detectors,
    grid_box,
    rows_from_frames,
    run_frames,
)
from gridbridge.params import DetectorModel
from pfpeople.detect import LearnedPeopleDetector, MotionDetector
from pfpeople.detect.learned.model_file import load_model
from pfpeople.detect.learned.recipe import NEGATIVE_TOPICS, POSITIVE_BAGS, folds
from pfpeople.detect.learned.samples import (
    LabelledScan,
    Region,
    negative_scans,
    positive_bag_scans,
    simulated_scans,
    with_scan_matched_motion,
)
from pfpeople.detect.learned.scoring import scored_frames
from pfpeople.detect.precision_recall import ScoredFrame

__all__ = ["fold_model_path", "negative_ap_rows", "positive_ap_rows", "scan_ap_rows"]

#: Threshold of the boosted detector's scored curve at which it reports people (its default, 0).
BOOSTED_THRESHOLD = 0.0


def fold_model_path(held_out: str) -> Path:
    """The learned detector's fold model trained without ``held_out`` (``positive_<k>``)."""
    return Path(str(resources.files("evaluation").joinpath("models", f"learned_people_without_{held_out}.npz")))


def _threshold(name: str) -> float:
    return BOOSTED_THRESHOLD if name == "laser_boosted" else -math.inf


def _learned(path: Path | None = None) -> LearnedPeopleDetector:
    return LearnedPeopleDetector(path, model=DetectorModel(name="laser_learned", ppv=0.5, fnr=0.5))


def scan_ap_rows(scene: str, bag: Path, gt: Path, run_dir: Path) -> list[ApRow]:
    """A scan-level scene's rows (module docstring)."""
    box = grid_box(run_dir)
    scans = [dataclasses.replace(s, region=Region(box=box)) for s in simulated_scans(bag, gt, source=scene)]
    rows = [
        ap_row(scene, name, make(), scans, threshold=_threshold(name)) for name, make in builtin_detectors().items()
    ]
    rows.append(ap_row(scene, "laser_motion", MotionDetector(), scans))
    learned = _learned()
    rows.append(ap_row(scene, "laser_learned", learned, scans, threshold=learned.threshold))
    rows.append(rows_from_frames(scene, "fused (pipeline)", run_frames(run_dir, scans), scans, threshold=-math.inf))
    return rows


def _pooled(
    scene: str, name: str, parts: Sequence[tuple[list[ScoredFrame], list[LabelledScan]]], threshold: float
) -> ApRow:
    frames = [f for fr, _ in parts for f in fr]
    scans = [s for _, sc in parts for s in sc]
    return rows_from_frames(scene, name, frames, scans, threshold=threshold)


def positive_ap_rows(leg: Path, work: Path, present: Sequence[int]) -> list[ApRow]:
    """``positive_bags``, leave one bag out, pooled (module docstring); ``work`` holds the benchmark's boosted fold
    models (``models/without_positive_<k>.yml``) and the bags' runs (``positive_<k>_run``)."""
    parts: dict[str, list[tuple[list[ScoredFrame], list[LabelledScan]]]] = {}
    threshold: dict[str, float] = {}
    for k in present:
        held = f"positive_{k}"
        scans = positive_bag_scans(leg / f"{held}_extracted.bag", source=held)
        boosted = work / "models" / f"without_{held}.yml"
        makers: dict[str, Callable[[], Any]] = dict(builtin_detectors(boosted))
        makers["laser_motion"] = MotionDetector
        fold = fold_model_path(held)
        if fold.is_file():
            makers["laser_learned"] = functools.partial(_learned, fold)
        for name, make in makers.items():
            det = make()
            threshold[name] = (
                getattr(det, "threshold", _threshold(name)) if name == "laser_learned" else _threshold(name)
            )
            parts.setdefault(name, []).append((scored_frames(det, scans), scans))
        run = work / f"{held}_run"
        if (run / "people.csv").is_file():
            parts.setdefault("fused (pipeline)", []).append((run_frames(run, scans), scans))
            threshold["fused (pipeline)"] = -math.inf
    return [_pooled("positive_bags (all)", name, p, threshold[name]) for name, p in parts.items()]


def negative_ap_rows(leg: Path, work: Path) -> list[ApRow]:
    """``negative_2``'s false people per scan on each laser (module docstring)."""
    bag = leg / "negative_2.bag"
    rows: list[ApRow] = []
    by_topic = {t: with_scan_matched_motion(negative_scans(bag, [t], source="negative_2")) for t in NEGATIVE_TOPICS}
    held_halves = _held_halves(by_topic)
    for topic, scans in by_topic.items():
        scene = f"negative_2{topic.replace('/', ':').replace('_scan', '')}"
        for name, make in {**builtin_detectors(), "laser_motion": MotionDetector}.items():
            rows.append(ap_row(scene, name, make(), scans, threshold=_threshold(name)))
        learned = [(scored_frames(_learned(p), part), part) for p, part in held_halves.get(topic, [])]
        if learned:
            thr = load_model(held_halves[topic][0][0]).threshold
            rows.append(_pooled(scene, "laser_learned (held out)", learned, thr))
        run = work / scene.replace(":", "_")
        if (run / "people.csv").is_file():
            rows.append(rows_from_frames(scene, "fused (pipeline)", run_frames(run, scans), scans, threshold=-math.inf))
    return rows


def _held_halves(by_topic: dict[str, list[LabelledScan]]) -> dict[str, list[tuple[Path, list[LabelledScan]]]]:
    """Per laser, the (fold model, held-out half) pairs of the learned detector's folds
    (:func:`pfpeople.detect.learned.recipe.folds`)."""
    from pfpeople.detect.learned.recipe import TrainingData

    data = TrainingData(positives={p: [] for p in POSITIVE_BAGS}, negatives=by_topic)
    out: dict[str, list[tuple[Path, list[LabelledScan]]]] = {}
    for fold in folds(data):
        path = fold_model_path(fold.held_out)
        if not path.is_file() or not fold.test_negative:
            continue
        topic = fold.test_negative[0].source  # "negative_2:<topic>"
        out.setdefault(topic.split(":", 1)[1], []).append((path, fold.test_negative))
    return out
