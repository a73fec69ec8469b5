"""How the shipped learned detector is made: its data, its leave-one-bag-out folds, its threshold and calibration.

Data (:mod:`pfpeople.detect.learned.samples`): leg_tracker's six labelled ``positive_*`` bags, the three lasers of
``negative_2`` (nobody there), ``person_following_outdoor_1``'s followed person, weak labels of the standing
laser's ``demo_stationary_simple_environment`` (:mod:`pfpeople.detect.learned.weak_labels`), and simulated bags
(``--people-bags``: every ``<name>.bag`` with ``<name>_gt.csv``; ``make model`` writes the randomised scenes of
:func:`evaluation.scenarios.scan.training_scenes.learned_training_bags`). The moving lasers' ego-motion comes from
their odometry (simulated bags) or from scan matching (``negative_2``, ``person_following_outdoor_1``), as a run
gets it.

Leave one bag out: fold ``k`` holds out ``positive_<k>`` and one laser-half of ``negative_2`` (the folds take the
six laser-halves in turn), and trains on everything else except the held-out half's other lasers (the same rooms
at the same time). The held-out detections of the six folds, pooled, give the figures a recording the model has not
seen should show: AP, recall at precision 0.90, false people per scan, and at the *operating threshold* (the lowest
score whose pooled held-out precision reaches ``target_precision``) the PPV and FNR the filters fuse the detector
by. The shipped model is then trained on all of it.

The operating threshold (``threshold``: detections scoring less are not reported) is the one the fused pipeline does
best with on the benchmark (``docs/learned_detector.md``); its PPV and FNR are measured as the other detectors'
(:func:`pfpeople.detect.learned.scoring.calibration`): on held-out simulated scenes (``--calibration-bags``, seeds
neither trained on nor benchmarked), the held-out labelled bags and the held-out laser-halves of ``negative_2``.

Source weights: the negatives of a source are kept with probability ``negative_keep`` and weighted back
(:func:`pfpeople.detect.learned.dataset.training_arrays`); ``negative_2``'s returns, the only real clutter seen
from a moving robot, weigh ``real_negative_weight`` times more.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pfpeople.detect.learned.cutouts import CutoutParams
from pfpeople.detect.learned.dataset import TrainingArrays, training_arrays
from pfpeople.detect.learned.model_file import LearnedModel
from pfpeople.detect.learned.samples import (
    LabelledScan,
    Region,
    negative_scans,
    people_bag_scans,
    positive_bag_scans,
    simulated_scans,
    with_scan_matched_motion,
)
from pfpeople.detect.learned.training import FitParams, architecture, fit_network

__all__ = [
    "NEGATIVE_TOPICS",
    "POSITIVE_BAGS",
    "Fold",
    "LearnedRecipe",
    "TrainingData",
    "folds",
    "followed_person_scans",
    "load_training_data",
    "train_model",
]

POSITIVE_BAGS = ("positive_1", "positive_2", "positive_3", "positive_4", "positive_6", "positive_7")
NEGATIVE_TOPICS = ("/left_scan", "/rear_scan", "/right_scan")
#: Returns within this distance (m) of person_following_outdoor_1's followed person are labelled; the rest of its
#: scans (passers-by are not annotated) is masked.
FOLLOWED_RADIUS = 0.7


@dataclass(frozen=True, kw_only=True)
class LearnedRecipe:
    """The learned detector's design and training settings (module docstring; the ablation in
    ``docs/learned_detector.md`` chose the defaults)."""

    cutout: CutoutParams = field(default_factory=CutoutParams)
    architecture: str = "mlp"
    past_scans: int = 0
    past_step: int = 2
    motion_input: bool = False
    negative_keep: float = 0.15
    real_negative_weight: float = 16.0
    scan_step: int = 3
    followed_step: int = 4
    fit: FitParams = field(default_factory=FitParams)
    group_radius: float = 0.4
    min_vote: float = 0.05
    threshold: float = 0.5

    def card(self) -> dict[str, Any]:
        """The recipe as the model card records it."""
        return _json(dataclasses.asdict(self))


def _json(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json(v) for v in value]
    return value


@dataclass(frozen=True, kw_only=True, eq=False)
class TrainingData:
    """Labelled scans by source group (module docstring)."""

    positives: dict[str, list[LabelledScan]]
    negatives: dict[str, list[LabelledScan]]
    followed: list[LabelledScan] = field(default_factory=list)
    weak: list[LabelledScan] = field(default_factory=list)
    simulated: list[LabelledScan] = field(default_factory=list)
    #: People-free recordings of the user's own (``--negative-bags``): trained on in every fold, never tested on.
    extra_negatives: list[LabelledScan] = field(default_factory=list)


@dataclass(frozen=True, kw_only=True, eq=False)
class Fold:
    """One leave-one-bag-out fold: its name, the labelled bag it holds out, what it trains on, and what it tests
    on: the held-out bag's scans and the held-out laser-half of ``negative_2``."""

    name: str
    held_out: str
    train: TrainingData
    test: list[LabelledScan]
    test_negative: list[LabelledScan]


def followed_person_scans(data_dir: Path) -> list[LabelledScan]:
    """person_following_outdoor_1's scans labelled near its followed person (within :data:`FOLLOWED_RADIUS`; the
    rest masked), their ego-motion by scan matching; none when the bag or its ground truth is not in ``data_dir``."""
    from pfpeople.io.bag.reader import open_bag_paths

    zipped = data_dir / "person_following_outdoor_1.bag.zip"
    gt = data_dir / "person_following_outdoor_1_gt.csv"
    if not (zipped.is_file() and gt.is_file()):
        return []
    bag = open_bag_paths(zipped)[0]
    scans = people_bag_scans(
        bag, gt, topic="/scan_base2", region=Region(near_people=FOLLOWED_RADIUS), source="person_following_outdoor_1"
    )
    return with_scan_matched_motion(scans)


def load_training_data(
    data_dir: str | Path,
    *,
    people_bags: Sequence[tuple[str | Path, str | Path]] = (),
    weak: Sequence[LabelledScan] = (),
    negative_bags: Sequence[tuple[str | Path, str]] = (),
) -> TrainingData:
    """Every source (module docstring) from leg_tracker's folder ``data_dir``, simulated ``people_bags``, already
    made ``weak`` labels and people-free recordings ``negative_bags`` ``(bag, LaserScan topic)`` of the user's own
    (their ego-motion by scan matching).

    Raises
    ------
    FileNotFoundError
        If a labelled bag or ``negative_2.bag`` is missing from ``data_dir`` (named).
    """
    d = Path(data_dir)
    for name in (*(f"{p}_extracted.bag" for p in POSITIVE_BAGS), "negative_2.bag"):
        if not (d / name).is_file():
            raise FileNotFoundError(f"training needs {d / name} (leg_tracker's labelled bags)")
    positives = {p: positive_bag_scans(d / f"{p}_extracted.bag", source=p) for p in POSITIVE_BAGS}
    negatives = {
        t: with_scan_matched_motion(negative_scans(d / "negative_2.bag", [t], source="negative_2"))
        for t in NEGATIVE_TOPICS
    }
    sims = [s for bag, gt in people_bags for s in simulated_scans(bag, gt, source=f"sim:{Path(bag).stem}")]
    extra = [
        s
        for bag, topic in negative_bags
        for s in with_scan_matched_motion(negative_scans(bag, [topic], source=f"own:{Path(bag).stem}"))
    ]
    return TrainingData(
        positives=positives,
        negatives=negatives,
        followed=followed_person_scans(d),
        weak=list(weak),
        simulated=sims,
        extra_negatives=extra,
    )


def _half(scans: list[LabelledScan], which: int) -> list[LabelledScan]:
    mid = len(scans) // 2
    return scans[:mid] if which == 0 else scans[mid:]


def folds(data: TrainingData) -> list[Fold]:
    """The six leave-one-bag-out folds (module docstring)."""
    out = []
    topics = list(data.negatives)
    for k, held in enumerate(POSITIVE_BAGS):
        topic, half = topics[k % len(topics)], k // len(topics) % 2
        train_neg = {t: _half(s, 1 - half) for t, s in data.negatives.items() if t != topic}
        train = dataclasses.replace(
            data, positives={p: s for p, s in data.positives.items() if p != held}, negatives=train_neg
        )
        out.append(
            Fold(
                name=f"{held} + negative_2{topic} half {half + 1}",
                held_out=held,
                train=train,
                test=data.positives[held],
                test_negative=_half(data.negatives[topic], half),
            )
        )
    return out


def _arrays(data: TrainingData, r: LearnedRecipe, rng: np.random.Generator) -> TrainingArrays:
    """Training rows of every source group with its negative sampling and weight."""
    groups: list[tuple[list[LabelledScan], float, float, int]] = [
        ([s for v in data.positives.values() for s in v], 1.0, 1.0, 1),
        ([s for v in data.negatives.values() for s in v], 1.0, r.real_negative_weight, 1),
        (data.extra_negatives, 1.0, r.real_negative_weight, 1),
        (data.followed, 1.0, 1.0, r.followed_step),
        (data.weak, 0.5, 1.0, 1),
        (data.simulated, r.negative_keep, 1.0, r.scan_step),
    ]
    parts = []
    for scans, keep, weight, step in groups:
        if not scans:
            continue
        a = training_arrays(
            scans,
            r.cutout,
            past_scans=r.past_scans,
            past_step=r.past_step,
            motion=r.motion_input,
            negative_keep=keep,
            row_step=step,
            rng=rng,
        )
        parts.append(dataclasses.replace(a, weight=np.where(a.label > 0, a.weight, a.weight * weight)))
    return TrainingArrays(
        x=np.concatenate([p.x for p in parts]),
        label=np.concatenate([p.label for p in parts]),
        offset=np.concatenate([p.offset for p in parts]),
        weight=np.concatenate([p.weight for p in parts]).astype(np.float32),
        source=np.zeros(sum(len(p) for p in parts), dtype=np.int64),
        sources=("all",),
    )


def train_model(data: TrainingData, recipe: LearnedRecipe, *, threshold: float = 0.5) -> LearnedModel:
    """A model trained on ``data`` by ``recipe`` (the operating threshold set to ``threshold``)."""
    rng = np.random.default_rng(recipe.fit.seed)
    arrays = _arrays(data, recipe, rng)
    net = fit_network(arrays, architecture(recipe.architecture), depth=recipe.cutout.depth, params=recipe.fit)
    return LearnedModel(
        network=net,
        cutout=recipe.cutout,
        past_scans=recipe.past_scans,
        past_step=recipe.past_step,
        motion_input=recipe.motion_input,
        group_radius=recipe.group_radius,
        min_vote=recipe.min_vote,
        threshold=threshold,
        card={"rows": len(arrays), "positive_rows": int(np.count_nonzero(arrays.label > 0))},
    )
