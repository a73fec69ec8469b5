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
from pfpeople.detect.learned.model_file import LearnedModel, load_model, save_model, sha256_of
from pfpeople.detect.learned.recipe import LearnedRecipe, TrainingData, folds, load_training_data, train_model
from pfpeople.detect.learned.samples import LabelledScan, simulated_scans
from pfpeople.detect.learned.scoring import calibration, detector_scores, ppv_by_score, scored_frames
from pfpeople.detect.learned.weak_labels import weak_labels
from pfpeople.detect.leg_tracker_bags import iter_scans
from pfpeople.detect.precision_recall import ScoredFrame

__all__ = ["load_weak_labels", "recalibrate_learned", "train_learned_from_directory"]


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
    return LearnedPeopleDetector.from_model(model, model=DetectorModel(name="laser_learned", ppv=0.5, fnr=0.5))


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
    """The leave-one-bag-out folds' results: per-fold rows, their models (by held-out bag), the pooled
    held-out frames of the labelled bags and of negative_2, and each fold's own (by held-out bag)."""

    rows: list[dict[str, Any]]
    models: dict[str, LearnedModel]
    positive: list[ScoredFrame]
    negative: list[ScoredFrame]
    by_fold: dict[str, tuple[list[ScoredFrame], list[ScoredFrame]]]

    def without(self, bag: str) -> tuple[list[ScoredFrame], list[ScoredFrame]]:
        """The held-out frames (labelled bags, negative_2) of every fold but the one that holds ``bag`` out."""
        pos = [f for b, (p, _) in self.by_fold.items() if b != bag for f in p]
        neg = [f for b, (_, n) in self.by_fold.items() if b != bag for f in n]
        return pos, neg


def _leave_one_out(data: TrainingData, recipe: LearnedRecipe, say: Callable[[str], object]) -> HeldOut:
    """Train and score every fold."""
    models = {}
    for fold in folds(data):
        say(f"fold {fold.name}: training")
        models[fold.held_out] = train_model(fold.train, recipe)
    return _scored_folds(data, models)


def _scored_folds(data: TrainingData, models: dict[str, LearnedModel]) -> HeldOut:
    """Every fold scored on what it holds out by its model (``models``: by held-out bag)."""
    rows, pos_all, neg_all, by_fold = [], [], [], {}
    for fold in folds(data):
        model = models[fold.held_out]
        pos = scored_frames(_detector(model), fold.test)
        neg = scored_frames(_detector(model), fold.test_negative)
        rows.append(_fold_row(fold.name, pos, neg))
        by_fold[fold.held_out] = (pos, neg)
        pos_all += pos
        neg_all += neg
    return HeldOut(rows=rows, models=models, positive=pos_all, negative=neg_all, by_fold=by_fold)


def _lasers(data: TrainingData) -> list[dict[str, Any]]:
    """The laser geometries (beams, field of view, resolution) of the training sources."""
    seen: dict[tuple[int, float, float], set[str]] = {}
    groups = [
        *data.positives.values(),
        *data.negatives.values(),
        data.followed,
        data.weak,
        data.simulated,
        data.extra_negatives,
    ]
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
    negative_bags: Sequence[tuple[str | Path, str]] = (),
    calibration_bags: Sequence[tuple[str | Path, str | Path]] = (),
    recipe: LearnedRecipe | None = None,
    leave_one_out: bool = True,
    fold_dir: str | Path | None = None,
    say: Callable[[str], object] = lambda _m: None,
) -> dict[str, Any]:
    """Train the learned detector and write ``out`` (``.npz``) with its model card (``.json``); returns the card.

    The recipe's threshold is the operating threshold; its PPV and FNR are measured
    (:func:`pfpeople.detect.learned.scoring.calibration`) on the held-out folds (``leave_one_out``) and the
    ``calibration_bags`` (simulated bags neither trained on nor benchmarked); with neither, the card's calibration
    holds placeholders (0.5 / 0.5), said so under ``calibration.measured_on``. With ``fold_dir`` the six fold models
    are written there too (``<stem>_without_positive_<k>.npz``: the benchmark scores each labelled bag with the model
    that did not see it).
    """
    r = recipe if recipe is not None else LearnedRecipe()
    weak, weak_report = load_weak_labels(weak_bags)
    say("loading the training data")
    data = load_training_data(data_dir, people_bags=people_bags, weak=weak, negative_bags=negative_bags)
    held = _leave_one_out(data, r, say) if leave_one_out else None
    say("training the final model on all the data")
    final = train_model(data, r, threshold=r.threshold)
    calib = _calibration_frames(final, calibration_bags)
    card = _card(final, r, data, weak_report)
    card.update(_measured(held, calib, r.threshold))
    own = [Path(b) for b, _ in (*weak_bags, *negative_bags)]
    card["data"] = _files(Path(data_dir), [*people_bags, *calibration_bags], own)
    save_model(out, final.network, card)
    if fold_dir is not None and held is not None:
        _save_folds(out, fold_dir, held, calib, card)
    return card


def _calibration_frames(
    model: LearnedModel, calibration_bags: Sequence[tuple[str | Path, str | Path]]
) -> list[list[ScoredFrame]]:
    """``model``'s scored frames on each simulated ``(bag, ground truth)`` it was neither trained nor benchmarked on."""
    return [
        scored_frames(_detector(model), simulated_scans(bag, gt, source=f"calibration:{Path(bag).stem}"))
        for bag, gt in calibration_bags
    ]


def _fold_path(out: str | Path, fold_dir: str | Path, bag: str) -> Path:
    return Path(fold_dir) / f"{Path(out).stem}_without_{bag}.npz"


def _save_folds(
    out: str | Path, fold_dir: str | Path, held: HeldOut, calib: list[list[ScoredFrame]], card: dict[str, Any]
) -> None:
    """Write each fold model with the final ``card``, its ``held_out`` bag and its own calibration: measured as the
    card's, less the frames its fold holds out (the benchmark scores those with it)."""
    threshold = float(card["threshold"])
    for bag, model in held.models.items():
        pos, neg = held.without(bag)
        cal = _calibration(
            [*calib, pos], neg, threshold, f"the held-out folds but {bag}'s and {len(calib)} held-out simulated bag(s)"
        )
        save_model(_fold_path(out, fold_dir, bag), model.network, {**card, "held_out": bag, "calibration": cal})


def recalibrate_learned(
    data_dir: str | Path,
    model_path: str | Path,
    *,
    fold_dir: str | Path,
    calibration_bags: Sequence[tuple[str | Path, str | Path]] = (),
    threshold: float | None = None,
    say: Callable[[str], object] = lambda _m: None,
) -> dict[str, Any]:
    """Measure a trained model's calibration (PPV, FNR, ``PPV(score)``) and leave-one-bag-out figures again, from
    its fold models in ``fold_dir`` (as :func:`train_learned_from_directory` wrote them) and the
    ``calibration_bags``, without training (no PyTorch), at the card's operating threshold or a new ``threshold``
    (in [0, 1]); the cards of the model and its folds are rewritten, the weights are not. Returns the card.

    Raises
    ------
    FileNotFoundError
        If the model, a fold model or a labelled bag is missing (named).
    """
    final = load_model(model_path)
    if threshold is not None and not 0.0 <= threshold <= 1.0:
        raise ValueError(f"threshold must be in [0, 1], got {threshold}")
    operating = final.threshold if threshold is None else float(threshold)
    say("loading the labelled bags and negative_2")
    data = load_training_data(data_dir)
    models = {fold.held_out: load_model(_fold_path(model_path, fold_dir, fold.held_out)) for fold in folds(data)}
    say("scoring the folds on what they hold out")
    held = _scored_folds(data, models)
    calib = _calibration_frames(final, calibration_bags)
    card = {k: v for k, v in final.card.items() if k not in ("format", "layers")}
    card["threshold"] = operating
    card.update(_measured(held, calib, operating))
    save_model(model_path, final.network, card)
    _save_folds(model_path, fold_dir, held, calib, card)
    return card


def _calibration(
    scenes: list[list[ScoredFrame]], negatives: list[ScoredFrame], threshold: float, source: str
) -> dict[str, Any]:
    """A card's ``calibration``: PPV, FNR and PPV by score of held-out ``scenes`` (frames with people) and people-free
    ``negatives`` at ``threshold``, said to be measured on ``source``."""
    ppv, fnr = calibration(scenes, negatives, threshold)
    cal: dict[str, Any] = {
        "ppv": ppv,
        "fnr": fnr,
        "measured_on": source + " (0.5 m; PPV pooled, FNR the mean of the scenes' miss rates)",
    }
    curve = ppv_by_score(scenes, negatives)
    if curve is not None:
        cal["ppv_by_score"] = curve.to_card()
    return cal


def _measured(held: HeldOut | None, calib: list[list[ScoredFrame]], threshold: float) -> dict[str, Any]:
    """The card's ``calibration`` and ``leave_one_bag_out`` entries."""
    scenes = [*calib, *([held.positive] if held is not None else [])]
    negatives = held.negative if held is not None else []
    if not scenes:
        on = "not measured (no held-out folds, no calibration bags): placeholders"
        cal: dict[str, Any] = {"ppv": 0.5, "fnr": 0.5, "measured_on": on}
    else:
        parts = ["the held-out folds of the labelled bags and negative_2"] if held is not None else []
        parts += [f"{len(calib)} held-out simulated bag(s)"] if calib else []
        cal = _calibration(scenes, negatives, threshold, " and ".join(parts))
    lobo: dict[str, Any] = {"folds": [], "pooled": {}}
    if held is not None:
        s = detector_scores(held.positive)
        lobo = {
            "folds": held.rows,
            "pooled": {
                "ap_03": s.ap_03,
                "ap_05": s.ap_05,
                "recall_at_p90": s.recall_at_p90,
                "negative_2_false_per_scan": detector_scores(held.negative, threshold=threshold).false_per_scan,
            },
        }
    return {"calibration": cal, "leave_one_bag_out": lobo}


def _card(model: LearnedModel, r: LearnedRecipe, data: TrainingData, weak_report: dict[str, Any]) -> dict[str, Any]:
    """The model card's description of the model and its data (the figures come from :func:`_measured`)."""
    return {
        "cutout": dataclasses.asdict(r.cutout),
        "past_scans": r.past_scans,
        "past_step": r.past_step,
        "motion_input": r.motion_input,
        "group_radius": r.group_radius,
        "min_vote": r.min_vote,
        "threshold": r.threshold,
        "recipe": r.card(),
        "scans": {
            "positive_bags": sum(len(v) for v in data.positives.values()),
            "negative_2": sum(len(v) for v in data.negatives.values()),
            "followed": len(data.followed),
            "weak": len(data.weak),
            "simulated": len(data.simulated),
            "own_negatives": len(data.extra_negatives),
        },
        "weak_labels": weak_report,
        "training_rows": model.card.get("rows"),
        "lasers": _lasers(data),
    }
