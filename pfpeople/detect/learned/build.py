"""``pfpeople train-detector --kind learned``: train, evaluate leave-one-bag-out, calibrate and write a model.

:func:`train_learned_from_directory` runs the recipe of :mod:`pfpeople.detect.learned.recipe`: the six folds
trained and scored on what they hold out, the operating threshold and the PPV / FNR chosen on the pooled held-out
detections, the final model trained on everything, and the model card (data with SHA-256, folds, figures, the
lasers it was trained for) written beside its weights (:mod:`pfpeople.detect.learned.model_file`). The same data
and seed give the same files.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from gridbridge.params import DetectorModel
from pfpeople.detect.learned.detector import LearnedPeopleDetector
from pfpeople.detect.learned.model_file import LearnedModel, save_model, sha256_of
from pfpeople.detect.learned.recipe import LearnedRecipe, TrainingData, folds, load_training_data, train_model
from pfpeople.detect.learned.samples import LabelledScan
from pfpeople.detect.learned.scoring import detector_scores, operating_point, scored_frames
from pfpeople.detect.learned.weak_labels import weak_labels
from pfpeople.detect.leg_tracker_bags import iter_scans
from pfpeople.detect.precision_recall import ScoredFrame

__all__ = ["load_weak_labels", "train_learned_from_directory"]


def load_weak_labels(bags: Sequence[tuple[str | Path, str]]) -> tuple[list[LabelledScan], dict[str, Any]]:
    """Weak labels (:mod:`pfpeople.detect.learned.weak_labels`) of standing lasers' recordings ``(bag, topic)``,
    and per bag what was found."""
    scans, report = [], {}
    for bag, topic in bags:
        raw = [s for _, s in iter_scans(Path(bag), [topic])]
        labelled, rep = weak_labels(raw, source=f"weak:{Path(bag).stem}")
        scans.extend(labelled)
        report[Path(bag).name] = dataclasses.asdict(rep)
    return scans, report


def _detector(model: LearnedModel) -> LearnedPeopleDetector:
    return LearnedPeopleDetector(model, model=DetectorModel(name="laser_learned", ppv=0.5, fnr=0.5))


def _fold_row(name: str, pos: list[ScoredFrame], neg: list[ScoredFrame]) -> dict[str, Any]:
    s = detector_scores(pos)
    return {
        "fold": name,
        "frames": len(pos),
        "ap_03": s.ap_03,
        "ap_05": s.ap_05,
        "recall_at_p90": s.recall_at_p90,
        "negative_frames": len(neg),
    }


@dataclass(frozen=True, kw_only=True, eq=False)
class HeldOut:
    """The leave-one-bag-out folds' results: per-fold rows, their models (by held-out bag), and the pooled
    held-out frames of the labelled bags and of negative_2."""

    rows: list[dict[str, Any]]
    models: dict[str, LearnedModel]
    positive: list[ScoredFrame]
    negative: list[ScoredFrame]


def _leave_one_out(data: TrainingData, recipe: LearnedRecipe, say: Callable[[str], object]) -> HeldOut:
    """Train and score every fold."""
    rows, models, pos_all, neg_all = [], {}, [], []
    for fold in folds(data):
        say(f"fold {fold.name}: training")
        model = train_model(fold.train, recipe)
        pos = scored_frames(_detector(model), fold.test)
        neg = scored_frames(_detector(model), fold.test_negative)
        rows.append(_fold_row(fold.name, pos, neg))
        models[fold.held_out] = model
        pos_all += pos
        neg_all += neg
    return HeldOut(rows=rows, models=models, positive=pos_all, negative=neg_all)


def _lasers(data: TrainingData) -> list[dict[str, Any]]:
    """The laser geometries (beams, field of view, resolution) of the training sources."""
    seen: dict[tuple[int, float, float], set[str]] = {}
    groups = [*data.positives.values(), *data.negatives.values(), data.followed, data.weak, data.simulated]
    for scans in groups:
        for ls in scans:
            s = ls.scan
            key = (
                s.ranges.size,
                round(float(np.degrees(abs(s.angle_increment)) * (s.ranges.size - 1)), 1),
                round(float(np.degrees(abs(s.angle_increment))), 3),
            )
            seen.setdefault(key, set()).add(ls.source.split(":")[0])
    return [
        {"beams": k[0], "fov_deg": k[1], "resolution_deg": k[2], "sources": sorted(v)} for k, v in sorted(seen.items())
    ]


def _files(
    data_dir: Path, people_bags: Sequence[tuple[str | Path, str | Path]], weak_bags: Sequence[Path]
) -> list[dict[str, Any]]:
    paths = sorted(p for p in data_dir.glob("*") if p.suffix in (".bag", ".zip", ".csv"))
    paths += [Path(b) for pair in people_bags for b in pair] + list(weak_bags)
    return [{"file": p.name, "bytes": p.stat().st_size, "sha256": sha256_of(p)} for p in paths if p.is_file()]


def train_learned_from_directory(
    data_dir: str | Path,
    out: str | Path,
    *,
    people_bags: Sequence[tuple[str | Path, str | Path]] = (),
    weak_bags: Sequence[tuple[str | Path, str]] = (),
    recipe: LearnedRecipe | None = None,
    leave_one_out: bool = True,
    fold_dir: str | Path | None = None,
    say: Callable[[str], object] = lambda _m: None,
) -> dict[str, Any]:
    """Train the learned detector and write ``out`` (``.npz``) with its model card (``.json``); returns the card.

    Without ``leave_one_out`` no threshold or calibration can be measured: the card then holds 0.5 as the
    threshold and PPV / FNR of 0.5 / 0.5, said so under ``calibration.measured_on``. With ``fold_dir`` the six fold
    models are written there too (``<stem>_without_positive_<k>.npz``, with the pooled threshold and calibration:
    the benchmark scores each labelled bag with the model that did not see it).
    """
    r = recipe if recipe is not None else LearnedRecipe()
    weak, weak_report = load_weak_labels(weak_bags)
    say("loading the training data")
    data = load_training_data(data_dir, people_bags=people_bags, weak=weak, recipe=r)
    rows: list[dict[str, Any]] = []
    threshold, ppv, fnr, pooled = 0.5, 0.5, 0.5, {}
    held: HeldOut | None = None
    if leave_one_out:
        held = _leave_one_out(data, r, say)
        rows = held.rows
        threshold, ppv, fnr = operating_point(held.positive + held.negative, r.target_precision)
        s = detector_scores(held.positive)
        pooled = {
            "ap_03": s.ap_03,
            "ap_05": s.ap_05,
            "recall_at_p90": s.recall_at_p90,
            "negative_2_false_per_scan": detector_scores(held.negative, threshold=threshold).false_per_scan,
        }
    say("training the final model on all the data")
    final = train_model(data, r, threshold=threshold)
    card = _card(final, r, data, rows, pooled, (threshold, ppv, fnr, leave_one_out), weak_report)
    card["data"] = _files(Path(data_dir), people_bags, [Path(b) for b, _ in weak_bags])
    save_model(out, final.network, card)
    if fold_dir is not None and held is not None:
        for bag, model in held.models.items():
            fold_card = {**card, "held_out": bag, "leave_one_bag_out": {"folds": rows, "pooled": pooled}}
            save_model(Path(fold_dir) / f"{Path(out).stem}_without_{bag}.npz", model.network, fold_card)
    return card


def _card(
    model: LearnedModel,
    r: LearnedRecipe,
    data: TrainingData,
    rows: list[dict[str, Any]],
    pooled: dict[str, Any],
    op: tuple[float, float, float, bool],
    weak_report: dict[str, Any],
) -> dict[str, Any]:
    threshold, ppv, fnr, measured = op
    return {
        "cutout": dataclasses.asdict(r.cutout),
        "past_scans": r.past_scans,
        "past_step": r.past_step,
        "motion_input": r.motion_input,
        "group_radius": r.group_radius,
        "min_vote": r.min_vote,
        "threshold": threshold,
        "calibration": {
            "ppv": ppv,
            "fnr": fnr,
            "measured_on": "leave-one-bag-out held-out scans of the labelled bags and negative_2 (0.5 m)"
            if measured
            else "not measured (trained without --leave-one-out): placeholders",
        },
        "recipe": r.card(),
        "scans": {
            "positive_bags": sum(len(v) for v in data.positives.values()),
            "negative_2": sum(len(v) for v in data.negatives.values()),
            "followed": len(data.followed),
            "weak": len(data.weak),
            "simulated": len(data.simulated),
        },
        "weak_labels": weak_report,
        "training_rows": model.card.get("rows"),
        "lasers": _lasers(data),
        "leave_one_bag_out": {"folds": rows, "pooled": pooled},
    }
