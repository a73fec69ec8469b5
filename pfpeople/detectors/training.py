"""Training the boosted segment classifier of :mod:`pfpeople.detectors.boosted` from labelled scans.

Data (Leigh et al. 2015, github angusleigh/leg_tracker, BSD-3):

* ``positive_*_extracted.bag``: ``/training_scan`` with ``/leg_cluster_positions`` (labelled LEG centres in the
  scan frame; every segment of the jump-distance segmentation inside the box x 0.5-5 m, abs(y) < 0.75 m was
  labelled). A segment whose centroid is within ``match_radius`` (0.15 m) of a label is a **positive**. Segments
  inside the box but not near a label are **ambiguous** and skipped (they are legs the labelling clustered
  differently, or clutter we cannot tell apart); segments outside the box are **unknown** (people may walk
  there) and skipped too. Both are counted in the metrics.
* ``negative_2.bag``: ``/left_scan``, ``/rear_scan``, ``/right_scan`` in rooms without people: every segment
  is a **negative**.

Split (held out, never trained on): ``positive_4_extracted.bag`` and the last ``holdout_fraction`` (30 %) of
each negative topic in time; the rest trains. Negatives are sub-sampled without replacement to at most
``negatives_per_positive`` times the positives with ``numpy.random.default_rng(seed)``; OpenCV's Boost is
deterministic given its data, so the same data and seed give the same model.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from gridbridge.validation import check_positive, check_probability
from pfpeople.detectors._bags import LabelledScan, load_labelled_scans, load_scans
from pfpeople.detectors.segments import FEATURE_NAMES, SegmentationParams, segment_features, segment_scan
from pfpeople.sensors import LaserScan

__all__ = [
    "NEGATIVE_TOPICS",
    "BoostTrainingParams",
    "LabelledScan",
    "build_training_set",
    "label_segments",
    "load_labelled_scans",
    "load_scans",
    "scan_features",
    "segment_metrics",
    "train_boost",
    "train_from_directory",
]

log = logging.getLogger(__name__)

NEGATIVE_TOPICS: tuple[str, ...] = ("/left_scan", "/rear_scan", "/right_scan")
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
        Fraction of each negative topic (the latest scans) held out for testing.
    seed : int
        Seed of the negative sub-sampling.
    """

    boost_type: str = "gentle"
    weak_count: int = 100
    max_depth: int = 2
    weight_trim_rate: float = 0.0
    match_radius: float = 0.15
    negatives_per_positive: float = 3.0
    holdout_fraction: float = 0.3
    seed: int = 0

    def __post_init__(self) -> None:
        if self.boost_type not in _BOOST_TYPES:
            raise ValueError(f"BoostTrainingParams.boost_type must be one of {sorted(_BOOST_TYPES)}")
        for name in ("weak_count", "max_depth"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ValueError(f"BoostTrainingParams.{name} must be a positive integer, got {v!r}")
        check_probability(self.weight_trim_rate, "BoostTrainingParams.weight_trim_rate")
        check_positive(self.match_radius, "BoostTrainingParams.match_radius")
        check_positive(self.negatives_per_positive, "BoostTrainingParams.negatives_per_positive")
        check_probability(self.holdout_fraction, "BoostTrainingParams.holdout_fraction", open_high=True)
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ValueError(f"BoostTrainingParams.seed must be a non-negative integer, got {self.seed!r}")


_BOOST_TYPES = {
    "real": cv2.ml.BOOST_REAL,
    "gentle": cv2.ml.BOOST_GENTLE,
    "discrete": cv2.ml.BOOST_DISCRETE,
    "logit": cv2.ml.BOOST_LOGIT,
}


def scan_features(
    scan: LaserScan, *, segmentation: SegmentationParams | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Segment a scan: ``(features (S, F), centroids (S, 2), widths (S,))``."""
    segs = segment_scan(scan, params=segmentation)
    feats = segment_features(segs)
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
    """Precision, recall and false-positive rate of ``scores > threshold`` against ``y`` in {0, 1}."""
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
    )


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def train_from_directory(
    data_dir: str | Path,
    out_dir: str | Path,
    *,
    params: BoostTrainingParams | None = None,
    train_positive: Sequence[str] = ("positive_1_extracted.bag",),
    test_positive: Sequence[str] = ("positive_4_extracted.bag",),
    negative: str = "negative_2.bag",
    name: str = "boosted_legs",
    segmentation: SegmentationParams | None = None,
) -> dict[str, object]:
    """Train on the leg_tracker bags in ``data_dir``; write ``<name>.yml`` (OpenCV) and ``<name>.json``.

    Returns the sidecar dictionary (data files with sizes and SHA-256, features, parameters, seed and the
    training and held-out segment metrics).
    """
    p = params if params is not None else BoostTrainingParams()
    seg = segmentation if segmentation is not None else SegmentationParams()
    data_dir = Path(data_dir)
    out_dir = Path(out_dir)
    if not data_dir.is_dir():
        raise FileNotFoundError(f"data directory not found: {data_dir}")
    files = [*train_positive, *test_positive, negative]
    for f in files:
        if not (data_dir / f).is_file():
            raise FileNotFoundError(f"training bag not found: {data_dir / f}")
    train_pos = [s for f in train_positive for s in load_labelled_scans(data_dir / f)]
    test_pos = [s for f in test_positive for s in load_labelled_scans(data_dir / f)]
    neg = load_scans(data_dir / negative, NEGATIVE_TOPICS)
    train_neg: list[LaserScan] = []
    test_neg: list[LaserScan] = []
    for topic in NEGATIVE_TOPICS:
        scans = neg[topic]
        cut = len(scans) - round(p.holdout_fraction * len(scans))
        train_neg += scans[:cut]
        test_neg += scans[cut:]
    log.info("train: %d positive scans, %d negative scans", len(train_pos), len(train_neg))
    Xtr, ytr, ctr = build_training_set(train_pos, train_neg, match_radius=p.match_radius, segmentation=seg)
    Xte, yte, cte = build_training_set(test_pos, test_neg, match_radius=p.match_radius, segmentation=seg)
    model = train_boost(Xtr, ytr, params=p)
    m_train = segment_metrics(boost_scores(model, Xtr), ytr)
    m_test = segment_metrics(boost_scores(model, Xte), yte)
    m_test_neg_per_scan = m_test["fp"] / max(len(test_neg), 1)
    out_dir.mkdir(parents=True, exist_ok=True)
    model_path = out_dir / f"{name}.yml"
    model.save(str(model_path))
    sidecar: dict[str, object] = {
        "model_file": model_path.name,
        "classifier": "cv2.ml.Boost",
        "opencv_version": cv2.__version__,
        "features": list(FEATURE_NAMES),
        "segmentation": asdict(seg),
        "params": asdict(p),
        "seed": p.seed,
        "data": [{"file": f, "bytes": (data_dir / f).stat().st_size, "sha256": _sha256(data_dir / f)} for f in files],
        "split": {
            "train_positive": list(train_positive),
            "test_positive": list(test_positive),
            "negative": negative,
            "negative_topics": list(NEGATIVE_TOPICS),
            "negative_holdout": f"last {p.holdout_fraction:g} of each topic",
            "train_negative_scans": len(train_neg),
            "test_negative_scans": len(test_neg),
        },
        "counts": {"train": ctr, "test": cte},
        "metrics": {
            "threshold": 0.0,
            "train": m_train,
            "test": {**m_test, "false_leg_segments_per_negative_scan": m_test_neg_per_scan},
        },
    }
    (out_dir / f"{name}.json").write_text(json.dumps(sidecar, indent=2, sort_keys=False) + "\n")
    return sidecar
