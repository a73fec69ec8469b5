"""The boosted model's trees walked without OpenCV (compiled and numpy) give OpenCV's raw scores, bit for bit."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from gridbridge import jit
from pfpeople.detect import boost_trees as bt
from pfpeople.detect.boosted import BoostedSegmentDetector, _load_boost, default_model_path
from pfpeople.detect.segments import FEATURE_NAMES, scan_segments
from pfpeople.detect.training import BoostTrainingParams, boost_scores, train_boost
from pfpeople.sensors import LaserScan

_F = len(FEATURE_NAMES)


def _opencv(boost: cv2.ml.Boost, X: np.ndarray) -> np.ndarray:
    return boost_scores(boost, X)


def _walks(trees: bt.BoostTrees, X: np.ndarray) -> list[np.ndarray]:
    """The scores of the numpy twin and, with numba, of the compiled walk."""
    out = []
    for on in (False, True) if jit.AVAILABLE else (False,):
        with jit.override(on, "pfpeople"):
            out.append(trees.scores(X))
    return out


def _scan_features(n: int) -> np.ndarray:
    """Float32 features of the segments of ``n`` random cluttered scans."""
    rng = np.random.default_rng(11)
    rows = []
    for _ in range(n):
        r = 6.0 + rng.normal(0, 0.3, 768).cumsum() * 0.02
        for _ in range(rng.integers(2, 15)):
            c, w = int(rng.integers(0, 760)), int(rng.integers(3, 14))
            r[c : c + w] = rng.uniform(0.4, 8.0) + 0.05 * np.sin(np.linspace(0, np.pi, len(r[c : c + w])))
        r[rng.random(768) < 0.03] = np.nan
        scan = LaserScan(ranges=r, angle_min=-2.35, angle_increment=0.00613, range_max=10.0)
        rows.append(scan_segments(scan)[1])
    return np.concatenate(rows).astype(np.float32)


def test_shipped_model_walk_equals_opencv() -> None:
    path = default_model_path()
    boost = _load_boost(path)
    trees = bt.load_trees(path, boost, _F)
    assert trees is not None and trees.var.shape == (200, 7)
    for X in (bt.check_sample(trees, _F, rows=4000), _scan_features(60), np.zeros((0, _F), np.float32)):
        expect = _opencv(boost, X)
        for got in _walks(trees, X):
            assert got.dtype == np.float64 and got.tobytes() == expect.tobytes()


@pytest.mark.parametrize(("boost_type", "depth"), [("gentle", 1), ("gentle", 5), ("real", 3), ("discrete", 2)])
def test_trained_model_walk_equals_opencv(tmp_path: Path, boost_type: str, depth: int) -> None:
    """Models of other depths and boosting types (leaves above the largest depth padded) give OpenCV's scores."""
    rng = np.random.default_rng(depth)
    X = rng.normal(size=(400, _F)).astype(np.float32)
    y = (X[:, 0] + 0.5 * X[:, 3] * X[:, 5] > 0.2).astype(np.int32)
    params = BoostTrainingParams(weak_count=25, max_depth=depth, boost_type=boost_type, negatives_per_positive=3.0)
    path = tmp_path / "m.yml"
    train_boost(X, y, params=params).save(str(path))
    boost = _load_boost(path)
    trees = bt.load_trees(path, boost, _F)
    assert trees is not None
    test = np.concatenate((X, bt.check_sample(trees, _F, rows=1000)))
    for got in _walks(trees, test):
        assert got.tobytes() == _opencv(boost, test).tobytes()


def test_a_walk_that_disagrees_keeps_opencv(tmp_path: Path) -> None:
    """A file whose trees differ from the loaded model (one leaf changed), or that is no Boost model, gives None;
    the detector then scores with OpenCV."""
    text = default_model_path().read_text()
    changed = text.replace("value: -0.71012529630875942", "value: -0.61012529630875942", 1)
    assert changed != text
    path = tmp_path / "changed.yml"
    path.write_text(changed)
    assert bt.load_trees(path, _load_boost(default_model_path()), _F) is None
    other = tmp_path / "other.yml"
    other.write_text("%YAML:1.0\n---\nsomething: 1\n")
    assert bt.load_trees(other, _load_boost(default_model_path()), _F) is None
    det = BoostedSegmentDetector()
    assert det._trees is not None
    X = _scan_features(5).astype(np.float64)
    det._trees = None
    slow = det._scores(X)
    det._trees = bt.load_trees(default_model_path(), det._boost, _F)
    assert slow.tobytes() == det._scores(X).tobytes()
