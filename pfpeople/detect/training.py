"""Training the boosted segment classifier of :mod:`pfpeople.detect.boosted` from labelled scans.

Data (Leigh et al. 2015, github angusleigh/leg_tracker, BSD-3):

* ``positive_*_extracted.bag``: ``/training_scan`` with ``/leg_cluster_positions`` (labelled LEG centres in the
  scan frame; every segment of the jump-distance segmentation inside the box x 0.5-5 m, abs(y) < 0.75 m was
  labelled). A segment whose centroid is within ``match_radius`` (0.15 m) of a label is a **positive**. Segments
  inside the box but not near a label are **ambiguous** and skipped (they are legs the labelling clustered
  differently, or clutter we cannot tell apart); segments outside the box are **unknown** (people may walk
  there) and skipped too. Both are counted in the metrics.
* ``negative_2.bag``: ``/left_scan``, ``/rear_scan``, ``/right_scan`` in rooms without people: every segment
  is a **negative**.

The shipped model trains on every labelled bag (:data:`POSITIVE_BAGS`: positive_1, 2, 3, 4, 6, 7) and all of
``negative_2.bag``. Its quality on bags it has not seen is measured by :func:`leave_one_bag_out`: each positive bag
is held out in turn and the classifier trained on the other five; the negatives are cut into blocks (each topic x
``n_periods`` equal time periods), fold ``i`` tests on block ``i`` and trains only on blocks of the OTHER topics in
the OTHER periods (no scan of the same laser or the same stretch of the recording). A fixed split
(``test_positive`` and the last ``holdout_fraction`` of each negative topic held out) is still available.
Negatives are sub-sampled without replacement to at most ``negatives_per_positive`` times the positives with
``numpy.random.default_rng(seed)``; OpenCV's Boost is deterministic given its data, so the same data and seed give
the same model.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from gridbridge.validation import check_int, check_positive, check_probability
from pfpeople.detect.leg_tracker_bags import LabelledScan, load_labelled_scans, load_scans
from pfpeople.detect.people_bags import PeopleScan, load_people_scans, people_training_set
from pfpeople.detect.segments import (
    FEATURE_NAMES,
    SegmentationParams,
    scan_segments,
)
from pfpeople.sensors import LaserScan

__all__ = [
    "NEGATIVE_TOPICS",
    "POSITIVE_BAGS",
    "BoostTrainingParams",
    "LabelledScan",
    "augmented",
    "build_training_set",
    "label_segments",
    "leave_one_bag_out",
    "load_labelled_scans",
    "load_scans",
    "negative_blocks",
    "noisy_scan",
    "scan_features",
    "segment_metrics",
    "train_boost",
    "train_from_directory",
]

log = logging.getLogger(__name__)

NEGATIVE_TOPICS: tuple[str, ...] = ("/left_scan", "/rear_scan", "/right_scan")
#: Every labelled leg_tracker bag; the shipped model trains on all of them.
POSITIVE_BAGS: tuple[str, ...] = tuple(f"positive_{k}_extracted.bag" for k in (1, 2, 3, 4, 6, 7))
POSITIVE_BOX = (0.5, 5.0, -0.75, 0.75)  # x_min, x_max, y_min, y_max (m) of the labelled area


@dataclass(frozen=True, kw_only=True)
class BoostTrainingParams:
    """Parameters of the boosted classifier and of its training data.

    Parameters
    ----------
    boost_type : {"real", "gentle", "discrete", "logit"}
        OpenCV boosting variant.
    weak_count : int
        Number of weak trees.
    max_depth : int
        Depth of each weak tree.
    weight_trim_rate : float
        OpenCV's weight trimming (0 disables it).
    match_radius : float
        A segment within this distance (m) of a labelled leg is a positive.
    negatives_per_positive : float
        Sub-sample training negatives to at most this many per positive.
    holdout_fraction : float
        Fraction of each negative topic (the latest scans) held out for the fixed-split test metrics (0: train
        on all of it; the leave-one-bag-out evaluation makes its own blocks).
    seed : int
        Seed of the negative sub-sampling (and of the augmentation noise).
    person_radius, clear_radius : float
        Labels of the bags annotated with people's centres (:mod:`pfpeople.detect.people_bags`): a segment
        within ``person_radius`` (m) of a person some beam reached is a positive, one farther than
        ``clear_radius`` from every person a negative, the rest are skipped.
    augment_noise : tuple of float
        Range-noise sds (m): every training scan is also used once per value with that much Gaussian noise added
        to its returns (:func:`noisy_scan`), so the classifier learns legs and clutter as lasers noisier than the
        recordings' (about 3 mm on their walls) see them; common 2-D lasers are specified at 1-3 cm. Test scans
        (held-out bags and blocks) are never augmented.

    Notes
    -----
    Defaults chosen on every labelled bag and every benchmark scene, not on one (``docs/ablations.md``, "The
    boosted classifier's training"): 200 trees of depth 3, since the model learns the simulated scans as well as
    the recordings (100 trees of depth 2 were best on the recordings alone); 3 negatives per positive.
    """

    boost_type: str = "gentle"
    weak_count: int = 200
    max_depth: int = 3
    weight_trim_rate: float = 0.0
    match_radius: float = 0.15
    negatives_per_positive: float = 3.0
    holdout_fraction: float = 0.0
    seed: int = 0
    augment_noise: tuple[float, ...] = (0.01, 0.02, 0.03)
    person_radius: float = 0.3
    clear_radius: float = 1.0

    def __post_init__(self) -> None:
        if self.boost_type not in _BOOST_TYPES:
            raise ValueError(f"BoostTrainingParams.boost_type must be one of {sorted(_BOOST_TYPES)}")
        for name in ("weak_count", "max_depth"):
            check_int(getattr(self, name), f"BoostTrainingParams.{name}", minimum=1)
        check_probability(self.weight_trim_rate, "BoostTrainingParams.weight_trim_rate")
        check_positive(self.match_radius, "BoostTrainingParams.match_radius")
        check_positive(self.negatives_per_positive, "BoostTrainingParams.negatives_per_positive")
        check_probability(self.holdout_fraction, "BoostTrainingParams.holdout_fraction", open_high=True)
        check_int(self.seed, "BoostTrainingParams.seed", minimum=0)
        object.__setattr__(self, "augment_noise", tuple(self.augment_noise))
        for v in self.augment_noise:
            check_positive(v, "BoostTrainingParams.augment_noise")
        check_positive(self.person_radius, "BoostTrainingParams.person_radius")
        check_positive(self.clear_radius, "BoostTrainingParams.clear_radius")
        if self.person_radius >= self.clear_radius:
            raise ValueError("BoostTrainingParams.person_radius must be below clear_radius")


_BOOST_TYPES = {
    "real": cv2.ml.BOOST_REAL,
    "gentle": cv2.ml.BOOST_GENTLE,
    "discrete": cv2.ml.BOOST_DISCRETE,
    "logit": cv2.ml.BOOST_LOGIT,
}


def noisy_scan(scan: LaserScan, sd: float, rng: np.random.Generator) -> LaserScan:
    """``scan`` with Gaussian noise of ``sd`` (m) added to the ranges of its valid returns (invalid beams and
    no-return codes kept as they are)."""
    r = scan.ranges.copy()
    ok = scan.valid
    r[ok] += rng.normal(0.0, sd, size=int(ok.sum()))
    return replace(scan, ranges=r)


def augmented(
    positives: Sequence[LabelledScan], negatives: Sequence[LaserScan], p: BoostTrainingParams
) -> tuple[list[LabelledScan], list[LaserScan]]:
    """The noisy copies of :attr:`BoostTrainingParams.augment_noise` of labelled and people-free scans (the
    labels stay: a few centimetres of noise move a segment's centroid far less than ``match_radius``)."""
    rng = np.random.default_rng([p.seed, 1])
    pos = [replace(item, scan=noisy_scan(item.scan, sd, rng)) for sd in p.augment_noise for item in positives]
    neg = [noisy_scan(scan, sd, rng) for sd in p.augment_noise for scan in negatives]
    return pos, neg


def scan_features(
    scan: LaserScan, *, segmentation: SegmentationParams | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Segment a scan: ``(features (S, F), centroids (S, 2), widths (S,))``."""
    segs, feats = scan_segments(scan, params=segmentation)
    return feats, segs.centroids, feats[:, FEATURE_NAMES.index("width")]


def label_segments(
    centroids: NDArray[np.float64], legs: NDArray[np.float64], *, match_radius: float = 0.15
) -> NDArray[np.int8]:
    """Label segments of a positive scan: 1 positive, 0 ambiguous (in the box), -1 unknown (outside it).

    Parameters
    ----------
    centroids : ndarray, shape (S, 2)
        Segment centroids (m, scan frame).
    legs : ndarray, shape (K, 2)
        Labelled leg positions (m, scan frame).
    """
    c = np.asarray(centroids, dtype=float).reshape(-1, 2)
    lg = np.asarray(legs, dtype=float).reshape(-1, 2)
    out = np.full(c.shape[0], -1, dtype=np.int8)
    x0, x1, y0, y1 = POSITIVE_BOX
    inbox = (c[:, 0] > x0) & (c[:, 0] < x1) & (c[:, 1] > y0) & (c[:, 1] < y1)
    out[inbox] = 0
    if lg.shape[0] and c.shape[0]:
        d = np.hypot(c[:, None, 0] - lg[None, :, 0], c[:, None, 1] - lg[None, :, 1]).min(axis=1)
        out[d <= match_radius] = 1
    return out


@dataclass
class _Set:
    X: list[NDArray[np.float64]]
    y: list[NDArray[np.int32]]

    def arrays(self) -> tuple[NDArray[np.float32], NDArray[np.int32]]:
        if not self.X:
            return np.zeros((0, len(FEATURE_NAMES)), dtype=np.float32), np.zeros(0, dtype=np.int32)
        return np.concatenate(self.X).astype(np.float32), np.concatenate(self.y).astype(np.int32)


def build_training_set(
    positives: Sequence[LabelledScan],
    negatives: Sequence[LaserScan],
    *,
    match_radius: float = 0.15,
    segmentation: SegmentationParams | None = None,
) -> tuple[NDArray[np.float32], NDArray[np.int32], dict[str, int]]:
    """Features and labels (1 leg, 0 not a leg) from labelled positive scans and people-free scans.

    Returns
    -------
    X : ndarray, shape (n, F), float32
    y : ndarray, shape (n,), int32
    counts : dict
        ``positives``, ``negatives``, ``ambiguous`` (skipped, in the box), ``unknown`` (skipped, outside it),
        ``labels`` and ``labels_matched`` (labels with a segment within ``match_radius``).
    """
    s = _Set([], [])
    counts = dict(positives=0, negatives=0, ambiguous=0, unknown=0, labels=0, labels_matched=0)
    for item in positives:
        f, c, _ = scan_features(item.scan, segmentation=segmentation)
        lab = label_segments(c, item.legs, match_radius=match_radius)
        counts["ambiguous"] += int(np.count_nonzero(lab == 0))
        counts["unknown"] += int(np.count_nonzero(lab == -1))
        counts["positives"] += int(np.count_nonzero(lab == 1))
        counts["labels"] += item.legs.shape[0]
        if c.shape[0] and item.legs.shape[0]:
            d = np.hypot(c[None, :, 0] - item.legs[:, None, 0], c[None, :, 1] - item.legs[:, None, 1]).min(axis=1)
            counts["labels_matched"] += int(np.count_nonzero(d <= match_radius))
        s.X.append(f[lab == 1])
        s.y.append(np.ones(int(np.count_nonzero(lab == 1)), dtype=np.int32))
    for scan in negatives:
        f, _, _ = scan_features(scan, segmentation=segmentation)
        counts["negatives"] += f.shape[0]
        s.X.append(f)
        s.y.append(np.zeros(f.shape[0], dtype=np.int32))
    X, y = s.arrays()
    return X, y, counts


def train_boost(
    X: NDArray[np.float32], y: NDArray[np.int32], *, params: BoostTrainingParams | None = None
) -> cv2.ml.Boost:
    """Train ``cv2.ml.Boost`` on features ``X`` (n, F) and labels ``y`` (n,) in {0, 1}.

    Negatives are sub-sampled to ``params.negatives_per_positive`` per positive with
    ``numpy.random.default_rng(params.seed)``; the result is deterministic for the same inputs.
    """
    p = params if params is not None else BoostTrainingParams()
    X = np.asarray(X, dtype=np.float32)
    y = np.asarray(y, dtype=np.int32).reshape(-1)
    if X.ndim != 2 or X.shape[0] != y.size:
        raise ValueError(f"X must be (n, F) with n = len(y); got X {X.shape}, y {y.shape}")
    if not np.all(np.isfinite(X)):
        raise ValueError("X contains NaN or infinite features")
    pos = np.flatnonzero(y == 1)
    neg = np.flatnonzero(y == 0)
    if pos.size == 0 or neg.size == 0:
        raise ValueError(f"y needs both classes, got {pos.size} positives and {neg.size} negatives")
    rng = np.random.default_rng(p.seed)
    n_neg = min(neg.size, math.ceil(p.negatives_per_positive * pos.size))
    neg = np.sort(rng.choice(neg, size=n_neg, replace=False))
    idx = np.concatenate((pos, neg))
    model = cv2.ml.Boost.create()
    model.setBoostType(_BOOST_TYPES[p.boost_type])
    model.setWeakCount(p.weak_count)
    model.setMaxDepth(p.max_depth)
    model.setWeightTrimRate(p.weight_trim_rate)
    model.setUseSurrogates(False)
    cv2.setRNGSeed(p.seed)
    data = cv2.ml.TrainData.create(X[idx], cv2.ml.ROW_SAMPLE, y[idx].reshape(-1, 1))
    if not model.train(data):
        raise RuntimeError("cv2.ml.Boost training failed")
    return model


def boost_scores(model: cv2.ml.Boost, X: NDArray[np.float32]) -> NDArray[np.float64]:
    """Raw boosted score of each row of ``X`` (n, F): the sum of the weak votes; > 0 means leg."""
    X = np.asarray(X, dtype=np.float32).reshape(-1, len(FEATURE_NAMES))
    if X.shape[0] == 0:
        return np.zeros(0)
    # PREDICT_SUM returns the sum of the weak votes, positive towards the second class label (1 = leg).
    _, out = model.predict(X, flags=cv2.ml.DTREES_PREDICT_SUM | cv2.ml.STAT_MODEL_RAW_OUTPUT)
    return np.asarray(out, dtype=np.float64).reshape(-1)


def segment_metrics(scores: NDArray[np.float64], y: NDArray[np.int32], *, threshold: float = 0.0) -> dict[str, float]:
    """Counts, precision, recall, false-positive rate and F1 of ``scores > threshold`` against ``y`` in {0, 1}."""
    pred = np.asarray(scores) > threshold
    y = np.asarray(y).astype(bool)
    tp = int(np.count_nonzero(pred & y))
    fp = int(np.count_nonzero(pred & ~y))
    fn = int(np.count_nonzero(~pred & y))
    tn = int(np.count_nonzero(~pred & ~y))
    return dict(
        tp=tp,
        fp=fp,
        fn=fn,
        tn=tn,
        precision=tp / (tp + fp) if tp + fp else math.nan,
        recall=tp / (tp + fn) if tp + fn else math.nan,
        false_positive_rate=fp / (fp + tn) if fp + tn else math.nan,
        f1=2 * tp / (2 * tp + fp + fn) if tp + fp + fn else math.nan,
    )


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


@dataclass(frozen=True)
class _Block:
    """Features of one group of scans: a positive bag, or one (topic, period) block of the negative bag."""

    name: str
    X: NDArray[np.float32]
    y: NDArray[np.int32]
    counts: dict[str, int]
    n_scans: int
    topic: str = ""
    period: int = 0
    #: Features and labels of the block's noisy copies (:func:`augmented`), used only when it is trained on.
    aug_X: NDArray[np.float32] = field(default_factory=lambda: np.zeros((0, len(FEATURE_NAMES)), dtype=np.float32))
    aug_y: NDArray[np.int32] = field(default_factory=lambda: np.zeros(0, dtype=np.int32))


def _block(
    name: str,
    positives: Sequence[LabelledScan],
    negatives: Sequence[LaserScan],
    p: BoostTrainingParams,
    seg: SegmentationParams,
    **where: Any,
) -> _Block:
    """The features of a block of scans and of their noisy copies."""
    X, y, c = build_training_set(positives, negatives, match_radius=p.match_radius, segmentation=seg)
    ap, an = augmented(positives, negatives, p)
    aX, ay, _ = build_training_set(ap, an, match_radius=p.match_radius, segmentation=seg)
    return _Block(name, X, y, c, len(positives) + len(negatives), aug_X=aX, aug_y=ay, **where)


def _people_block(
    scans: Sequence[PeopleScan], p: BoostTrainingParams, seg: SegmentationParams, real_positives: int
) -> _Block:
    """The labelled segments of scans annotated with people (no noisy copies: they have their own noise), sub-sampled
    (``numpy.random.default_rng([seed, 2])``) to ``real_positives`` positives and the negatives in the same
    proportion, so that they weigh as much as the labelled legs of the recordings (with their noisy copies): in the
    simulated bags a person yields ten times as many segments as a labelled leg_tracker scan, and unweighted they
    took the recordings' leg recall from 0.90 to 0.68 (positive_1, a bag trained on)."""
    X, y, c = people_training_set(
        list(scans), person_radius=p.person_radius, clear_radius=p.clear_radius, segmentation=seg
    )
    pos, neg = np.flatnonzero(y == 1), np.flatnonzero(y == 0)
    if pos.size > real_positives:
        rng = np.random.default_rng([p.seed, 2])
        n_neg = round(neg.size * real_positives / pos.size)
        keep = np.sort(
            np.concatenate((rng.choice(pos, real_positives, replace=False), rng.choice(neg, n_neg, replace=False)))
        )
        X, y = X[keep], y[keep]
        c = {**c, "kept_positives": int(real_positives), "kept_negatives": int(n_neg)}
    return _Block("people bags", X, y, c, len(scans))


def _real_positives(blocks: Sequence[_Block]) -> int:
    """Labelled leg segments of ``blocks``, their noisy copies included."""
    return int(sum(np.count_nonzero(b.y == 1) + np.count_nonzero(b.aug_y == 1) for b in blocks))


def _blocks_positive(
    bags: Mapping[str, Sequence[LabelledScan]], p: BoostTrainingParams, seg: SegmentationParams
) -> list[_Block]:
    return [_block(name, scans, [], p, seg) for name, scans in bags.items()]


def negative_blocks(
    scans: Mapping[str, Sequence[LaserScan]], *, n_periods: int = 2
) -> list[tuple[str, int, list[LaserScan]]]:
    """Cut people-free scans into blocks: every topic x ``n_periods`` consecutive, (nearly) equal time periods.

    Parameters
    ----------
    scans : mapping of str to sequence of LaserScan
        Scans per topic, in time order.
    n_periods : int
        Periods per topic.

    Returns
    -------
    list of (topic, period, scans)
        Period-major order ``(t0, 0), (t1, 0), ..., (t0, 1), ...``, so consecutive folds of
        :func:`leave_one_bag_out` test on different lasers.
    """
    check_int(n_periods, "n_periods", minimum=1)
    out = []
    for period in range(n_periods):
        for topic, seq in scans.items():
            cuts = np.linspace(0, len(seq), n_periods + 1).round().astype(int)
            out.append((topic, period, list(seq[cuts[period] : cuts[period + 1]])))
    return out


def _fold_metrics(scores: NDArray[np.float64], y: NDArray[np.int32], n_negative_scans: int) -> dict[str, float]:
    m = segment_metrics(scores, y)
    m["false_leg_segments_per_negative_scan"] = m["fp"] / n_negative_scans if n_negative_scans else math.nan
    return m


def _pool(folds: Sequence[Mapping[str, Any]], n_negative_scans: int) -> dict[str, float]:
    """Metrics of the summed counts of all folds, and the mean of the folds' F1."""
    tp, fp, fn, tn = (sum(int(f[k]) for f in folds) for k in ("tp", "fp", "fn", "tn"))
    y = np.r_[np.ones(tp + fn), np.zeros(fp + tn)]
    pred = np.r_[np.ones(tp), np.zeros(fn), np.ones(fp), np.zeros(tn)]
    m = segment_metrics(pred, y, threshold=0.5)
    m["false_leg_segments_per_negative_scan"] = fp / n_negative_scans if n_negative_scans else math.nan
    f1s = [float(f["f1"]) for f in folds if not math.isnan(float(f["f1"]))]
    m["mean_f1"] = float(np.mean(f1s)) if f1s else math.nan
    return m


def leave_one_bag_out(
    positives: Mapping[str, Sequence[LabelledScan]],
    negatives: Mapping[str, Sequence[LaserScan]],
    *,
    params: BoostTrainingParams | None = None,
    segmentation: SegmentationParams | None = None,
    n_periods: int = 2,
    people: Sequence[PeopleScan] = (),
) -> dict[str, Any]:
    """Leave-one-bag-out evaluation: the classifier's segment metrics on each positive bag it was not trained on.

    Fold ``i`` holds out positive bag ``i`` and negative block ``i mod B`` of :func:`negative_blocks` (B =
    topics x ``n_periods``); it trains on the other positive bags and on the negative blocks of the other
    topics in the other periods (with one topic: the other periods; with one period: the other topics), so no
    test scan shares a laser and a stretch of time with a training scan.

    Parameters
    ----------
    positives : mapping of str to sequence of LabelledScan
        Labelled scans per bag (at least two bags).
    negatives : mapping of str to sequence of LaserScan
        People-free scans per topic, in time order.
    params : BoostTrainingParams, optional
        Classifier and sampling parameters (``holdout_fraction`` is not used).
    segmentation : SegmentationParams, optional
        Segmentation of every scan.
    n_periods : int
        Time periods per negative topic.
    people : sequence of PeopleScan
        Scans annotated with people (:mod:`pfpeople.detect.people_bags`), in every fold's training set.

    Returns
    -------
    dict
        ``folds``: one dict per held-out bag (``bag``, ``negative_topic``, ``negative_period``, scan counts and
        :func:`segment_metrics` plus ``f1`` and ``false_leg_segments_per_negative_scan``, threshold 0);
        ``pooled``: the summed counts of all folds, their metrics and the mean of the folds' F1; ``scheme``: the
        rule in words.
    """
    p = params if params is not None else BoostTrainingParams()
    seg = segmentation if segmentation is not None else SegmentationParams()
    if len(positives) < 2:
        raise ValueError(f"leave-one-bag-out needs at least two positive bags, got {len(positives)}")
    pos = _blocks_positive(positives, p, seg)
    neg = [
        _block(f"{topic}#{period}", [], scans, p, seg, topic=topic, period=period)
        for topic, period, scans in negative_blocks(negatives, n_periods=n_periods)
    ]
    out = _lobo_blocks(pos, neg, p, [_people_block(people, p, seg, _real_positives(pos))] if people else [])
    return {
        "scheme": (
            f"each positive bag held out in turn; negatives cut into topic x {n_periods} time periods, fold i tests "
            "on block i and trains on the blocks of the other topics in the other periods"
            + (f", and on all {len(people)} scans annotated with people" if people else "")
        ),
        **out,
    }


def _lobo_blocks(
    pos: Sequence[_Block], neg: Sequence[_Block], p: BoostTrainingParams, extra: Sequence[_Block] = ()
) -> dict[str, Any]:
    """The folds of :func:`leave_one_bag_out` on precomputed features; ``extra`` blocks (the bags annotated with
    people) are in every fold's training set and never tested on."""
    if not neg:
        raise ValueError("leave-one-bag-out needs negative scans")
    folds: list[dict[str, Any]] = []
    for i, held in enumerate(pos):
        test_neg = neg[i % len(neg)]
        train_neg = _train_negatives(neg, test_neg)
        model = _train_blocks([b for b in pos if b is not held] + train_neg + list(extra), p)
        Xte = np.concatenate([held.X, test_neg.X])
        yte = np.concatenate([held.y, test_neg.y])
        m = _fold_metrics(boost_scores(model, Xte), yte, test_neg.n_scans)
        folds.append(
            {
                "bag": held.name,
                "positive_scans": held.n_scans,
                "labels": held.counts["labels"],
                "negative_topic": test_neg.topic,
                "negative_period": test_neg.period,
                "negative_scans": test_neg.n_scans,
                "train_negative_blocks": [b.name for b in train_neg],
                **m,
            }
        )
        log.info("leave-one-bag-out %s: %s", held.name, m)
    n_neg_scans = sum(neg[i % len(neg)].n_scans for i in range(len(pos)))
    return {"threshold": 0.0, "folds": folds, "pooled": _pool(folds, n_neg_scans)}


def _train_negatives(blocks: Sequence[_Block], held: _Block) -> list[_Block]:
    """Negative blocks that share neither topic nor period with ``held`` (relaxed when none is left)."""
    for keep in (
        lambda b: b.topic != held.topic and b.period != held.period,
        lambda b: b.period != held.period,
        lambda b: b.topic != held.topic,
    ):
        out = [b for b in blocks if keep(b)]
        if out:
            return out
    raise ValueError("leave-one-bag-out needs negatives of at least two topics or two periods")


def _every(seq: Sequence[Any], step: int) -> list[Any]:
    return list(seq[::step])


def train_from_directory(
    data_dir: str | Path,
    out_dir: str | Path,
    *,
    params: BoostTrainingParams | None = None,
    train_positive: Sequence[str] = POSITIVE_BAGS,
    test_positive: Sequence[str] = (),
    negative: str = "negative_2.bag",
    name: str = "boosted_legs",
    segmentation: SegmentationParams | None = None,
    leave_one_out: bool = True,
    scan_step: int = 1,
    people_bags: Sequence[tuple[str | Path, str | Path]] = (),
    people_topic: str = "/scan",
) -> dict[str, object]:
    """Train on the leg_tracker bags in ``data_dir`` (and bags annotated with people); write ``<name>.yml``
    (OpenCV) and ``<name>.json`` into ``out_dir``.

    Parameters
    ----------
    data_dir, out_dir : str or Path
        Folder of the bags; folder of the model and its sidecar.
    params : BoostTrainingParams, optional
    train_positive, test_positive : sequence of str
        Labelled bags to train on and to test on (default: all of :data:`POSITIVE_BAGS`; none).
    negative : str
        The people-free bag (topics :data:`NEGATIVE_TOPICS`); the last ``params.holdout_fraction`` of each topic
        is held out for the test metrics.
    name : str
        File stem of the model.
    segmentation : SegmentationParams, optional
    leave_one_out : bool
        Also run :func:`leave_one_bag_out` (at least two training bags) and record it in the sidecar.
    scan_step : int
        Use every ``scan_step``-th scan of each bag and topic (1 = all; larger for quick tests).
    people_bags : sequence of (bag, ground-truth CSV)
        Bags annotated with people's centres (:mod:`pfpeople.detect.people_bags`), trained on (in every
        leave-one-bag-out fold too), never tested on; ``people_topic`` is their LaserScan topic.

    Returns
    -------
    dict
        The sidecar: data files with sizes and SHA-256, features, parameters, seed, split, counts, the training
        (and, when something is held out, test) segment metrics and the leave-one-bag-out evaluation.
    """
    p = params if params is not None else BoostTrainingParams()
    seg = segmentation if segmentation is not None else SegmentationParams()
    data_dir, model_path = Path(data_dir), Path(out_dir) / f"{name}.yml"
    files = _check_training_files(data_dir, train_positive, test_positive, negative, scan_step)
    data = _TrainingData.load(data_dir, train_positive, test_positive, negative, scan_step, p.holdout_fraction)
    people = [s for bag, gt in people_bags for s in load_people_scans(bag, gt, topic=people_topic, scan_step=scan_step)]
    model, metrics, counts = _fit(data, people, p, seg)
    lobo = None
    if leave_one_out and len(data.train_bags) >= 2:
        lobo = leave_one_bag_out(data.train_bags, data.neg, params=p, segmentation=seg, people=people)
    split = data.split(train_positive, test_positive, negative, scan_step, p.holdout_fraction, len(people))
    sidecar = _sidecar(model_path, seg, p, data_dir, files, split, counts, metrics, lobo, people_bags)
    _write_model(model, model_path, sidecar)
    return sidecar


def _write_model(model: cv2.ml.Boost, path: Path, sidecar: Mapping[str, object]) -> None:
    """``path`` (the OpenCV model) and its JSON sidecar beside it, the folder made if needed."""
    path.parent.mkdir(parents=True, exist_ok=True)
    model.save(str(path))
    path.with_suffix(".json").write_text(json.dumps(_json_safe(sidecar), indent=2, sort_keys=False) + "\n")


def _fit(
    data: _TrainingData, people: Sequence[PeopleScan], p: BoostTrainingParams, seg: SegmentationParams
) -> tuple[cv2.ml.Boost, dict[str, object], dict[str, object]]:
    """The model trained on the recordings (with their noisy copies) and the people-annotated scans, its segment
    metrics on the recordings' training scans (and on the held-out ones), and the segment counts."""
    log.info("train: %d positive, %d negative, %d people-annotated scans", *data.sizes()[:2], len(people))
    blocks = [_block("train", data.train_pos, data.train_neg, p, seg)]
    blocks += [_people_block(people, p, seg, _real_positives(blocks))] if people else []
    model = _train_blocks(blocks, p)
    metrics: dict[str, object] = {
        "threshold": 0.0,
        "train": segment_metrics(boost_scores(model, blocks[0].X), blocks[0].y),
    }
    counts: dict[str, object] = {"train": blocks[0].counts, **({"people_bags": blocks[1].counts} if people else {})}
    if data.test_pos or data.test_neg:
        metrics["test"], counts["test"] = _test_metrics(model, data.test_pos, data.test_neg, p, seg)
    return model, metrics, counts


def _train_blocks(blocks: Sequence[_Block], p: BoostTrainingParams) -> cv2.ml.Boost:
    """:func:`train_boost` on the features of ``blocks`` and of their noisy copies."""
    X = np.concatenate([b.X for b in blocks] + [b.aug_X for b in blocks])
    y = np.concatenate([b.y for b in blocks] + [b.aug_y for b in blocks])
    return train_boost(X, y, params=p)


@dataclass
class _TrainingData:
    """The leg_tracker scans of one training run: labelled bags, and the people-free bag split for the test."""

    train_bags: dict[str, list[LabelledScan]]
    test_pos: list[LabelledScan]
    neg: dict[str, list[LaserScan]]
    train_neg: list[LaserScan]
    test_neg: list[LaserScan]

    @property
    def train_pos(self) -> list[LabelledScan]:
        return [s for scans in self.train_bags.values() for s in scans]

    @classmethod
    def load(
        cls,
        data_dir: Path,
        train_positive: Sequence[str],
        test_positive: Sequence[str],
        negative: str,
        scan_step: int,
        holdout_fraction: float,
    ) -> _TrainingData:
        train_bags = {f: _every(load_labelled_scans(data_dir / f), scan_step) for f in train_positive}
        test_pos = [s for f in test_positive for s in _every(load_labelled_scans(data_dir / f), scan_step)]
        neg = {t: _every(v, scan_step) for t, v in load_scans(data_dir / negative, NEGATIVE_TOPICS).items()}
        train_neg, test_neg = _split_negatives(neg, holdout_fraction)
        return cls(train_bags, test_pos, neg, train_neg, test_neg)

    def sizes(self) -> tuple[int, int, int, int]:
        """Scans: training positive, training negative, test positive, test negative."""
        return len(self.train_pos), len(self.train_neg), len(self.test_pos), len(self.test_neg)

    def split(
        self,
        train_positive: Sequence[str],
        test_positive: Sequence[str],
        negative: str,
        scan_step: int,
        holdout_fraction: float,
        people_scans: int,
    ) -> dict[str, object]:
        """The sidecar's ``split`` entry."""
        n = self.sizes()
        return {
            "train_positive": list(train_positive),
            "test_positive": list(test_positive),
            "negative": negative,
            "negative_topics": list(NEGATIVE_TOPICS),
            "negative_holdout": f"last {holdout_fraction:g} of each topic",
            "scan_step": scan_step,
            "train_positive_scans": n[0],
            "train_negative_scans": n[1],
            "test_positive_scans": n[2],
            "test_negative_scans": n[3],
            "people_scans": people_scans,
        }


def _split_negatives(
    neg: Mapping[str, Sequence[LaserScan]], holdout_fraction: float
) -> tuple[list[LaserScan], list[LaserScan]]:
    """The people-free scans for training and for the test: the last ``holdout_fraction`` of each topic held out."""
    train_neg: list[LaserScan] = []
    test_neg: list[LaserScan] = []
    for topic in NEGATIVE_TOPICS:
        scans = list(neg[topic])
        cut = len(scans) - round(holdout_fraction * len(scans))
        train_neg += scans[:cut]
        test_neg += scans[cut:]
    return train_neg, test_neg


def _test_metrics(
    model: Any,
    test_pos: Sequence[LabelledScan],
    test_neg: Sequence[LaserScan],
    p: BoostTrainingParams,
    seg: SegmentationParams,
) -> tuple[dict[str, float], object]:
    """The segment metrics of ``model`` on the held-out scans, with false leg segments per negative scan, and
    the held-out segment counts."""
    Xte, yte, cte = build_training_set(test_pos, test_neg, match_radius=p.match_radius, segmentation=seg)
    m_test = segment_metrics(boost_scores(model, Xte), yte)
    m_test["false_leg_segments_per_negative_scan"] = m_test["fp"] / max(len(test_neg), 1)
    return m_test, cte


def _check_training_files(
    data_dir: Path, train_positive: Sequence[str], test_positive: Sequence[str], negative: str, scan_step: int
) -> list[str]:
    """The training bags (train, test, negative), checked: they exist, no bag is in both splits, ``scan_step``
    is a positive integer.

    Raises
    ------
    TypeError, ValueError, FileNotFoundError
        Naming the argument (TypeError: a ``scan_step`` that is not an integer) or the missing file.
    """
    check_int(scan_step, "scan_step", minimum=1)
    if not data_dir.is_dir():
        raise FileNotFoundError(f"data directory not found: {data_dir}")
    if not train_positive:
        raise ValueError("train_positive names no bag")
    overlap = set(train_positive) & set(test_positive)
    if overlap:
        raise ValueError(f"bag(s) {sorted(overlap)} are both in train_positive and test_positive")
    files = [*train_positive, *test_positive, negative]
    for f in files:
        if not (data_dir / f).is_file():
            raise FileNotFoundError(f"training bag not found: {data_dir / f}")
    return files


def _sidecar(
    model_path: Path,
    seg: SegmentationParams,
    p: BoostTrainingParams,
    data_dir: Path,
    files: Sequence[str],
    split: dict[str, object],
    counts: dict[str, object],
    metrics: dict[str, object],
    lobo: object,
    people_bags: Sequence[tuple[str | Path, str | Path]] = (),
) -> dict[str, object]:
    """The model's sidecar: data files with sizes and SHA-256, features, parameters, seed, split, counts and
    metrics, and the people-annotated bags."""
    return {
        "model_file": model_path.name,
        "classifier": "cv2.ml.Boost",
        "opencv_version": cv2.__version__,
        "features": list(FEATURE_NAMES),
        "segmentation": asdict(seg),
        "params": asdict(p),
        "seed": p.seed,
        "data": [{**_file_entry(data_dir / f), "file": f} for f in files],
        "split": split,
        "counts": counts,
        "metrics": metrics,
        "leave_one_bag_out": lobo,
        "people_data": _people_entries(people_bags),
    }


def _file_entry(path: Path) -> dict[str, object]:
    """A data file of the sidecar: its path, size and SHA-256."""
    return {"file": str(path), "bytes": path.stat().st_size, "sha256": _sha256(path)}


def _people_entries(pairs: Sequence[tuple[str | Path, str | Path]]) -> list[dict[str, object]]:
    """The sidecar entries of the people-annotated bags and their ground truth, named relative to the folder
    that holds them all (the model's record does not depend on where that folder was)."""
    files = [Path(f) for pair in pairs for f in pair]
    if not files:
        return []
    root = Path(os.path.commonpath([str(f.parent) for f in files]))
    return [{**_file_entry(f), "file": f.relative_to(root).as_posix()} for f in files]


def _json_safe(value: Any) -> Any:
    """NaN (a metric with nothing to count) as JSON null (an unbounded ``max_range`` stays ``Infinity``)."""
    if isinstance(value, float) and math.isnan(value):
        return None
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_safe(v) for v in value]
    return value
