"""Boosted segment detector (detector 2): shipped model, training reproducibility, command line."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from gridbridge.params import CALIBRATED_LASER_DETECTORS
from pfpeople.cli import main as pfpeople_main
from pfpeople.detectors.boosted import BoostedSegmentDetector, default_model_path
from pfpeople.detectors.segments import FEATURE_NAMES
from pfpeople.detectors.synthetic import render_scan
from pfpeople.detectors.training import (
    BoostTrainingParams,
    boost_scores,
    build_training_set,
    load_labelled_scans,
    load_scans,
    segment_metrics,
    train_boost,
)
from pfpeople.sensors import LaserScan


def test_shipped_model_loads_with_sidecar() -> None:
    path = default_model_path()
    assert path.is_file() and path.stat().st_size < 500_000
    det = BoostedSegmentDetector()
    side: dict[str, Any] = det.sidecar
    assert side["features"] == list(FEATURE_NAMES)
    files = {d["file"]: d["bytes"] for d in side["data"]}
    assert set(files) == {"positive_1_extracted.bag", "positive_4_extracted.bag", "negative_2.bag"}
    assert all(b > 0 for b in files.values())
    test = side["metrics"]["test"]
    # held-out segment metrics recorded at training time (positive_4 + last 30 % of negative_2)
    assert 0.4 < test["recall"] <= 1.0
    assert 0.1 < test["precision"] <= 1.0
    assert det.model == CALIBRATED_LASER_DETECTORS[1]


def test_empty_and_invalid_scans_give_nothing() -> None:
    det = BoostedSegmentDetector()
    for r in (np.zeros(0), np.full(64, np.nan), np.full(64, np.inf)):
        scan = LaserScan(ranges=r, angle_min=-1.0, angle_increment=0.02)
        assert det.detect(scan).shape == (0, 2)
        assert det.detect_legs(scan).shape == (0, 2)
        c, s = det.segment_scores(scan)
        assert c.shape == (0, 2) and s.shape == (0,)


def test_walls_score_as_not_legs() -> None:
    scan = render_scan(segments=[(3.0, -3.0, 3.0, 1.0), (1.0, 2.0, 2.5, 2.5)])
    c, s = BoostedSegmentDetector().segment_scores(scan)
    assert c.shape[0] == 2 and np.all(s < 0)
    assert BoostedSegmentDetector().detect(scan).shape == (0, 2)


def test_missing_model_file(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"nope\.yml"):
        BoostedSegmentDetector(tmp_path / "nope.yml")


def _synthetic_set(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    from pfpeople.detectors.training import LabelledScan

    pos, neg = [], []
    for _ in range(n):
        px, py = rng.uniform(1.0, 4.0), rng.uniform(-1.5, 1.5)
        legs = [(px, py - 0.15, 0.06), (px, py + 0.15, 0.06)]
        scan = render_scan(circles=legs, noise_sd=0.005, rng=rng, angle_increment=math.radians(0.5))
        pos.append(LabelledScan(scan=scan, legs=np.array([[px - 0.04, py - 0.15], [px - 0.04, py + 0.15]])))
        wx = rng.uniform(2.0, 5.0)
        neg.append(
            render_scan(
                circles=[(rng.uniform(1, 4), rng.uniform(-2, 2), rng.uniform(0.2, 0.5))],
                segments=[(wx, -3.0, wx + rng.uniform(-1, 1), 3.0)],
                noise_sd=0.005,
                rng=rng,
                angle_increment=math.radians(0.5),
            )
        )
    X, y, counts = build_training_set(pos, neg)
    assert counts["labels_matched"] == counts["labels"]  # the labelled legs are found as segments
    return X, y


def test_training_is_reproducible_on_synthetic_data(rng: np.random.Generator) -> None:
    X, y = _synthetic_set(rng, 30)
    params = BoostTrainingParams(weak_count=20, negatives_per_positive=2.0, seed=3)
    a = boost_scores(train_boost(X, y, params=params), X)
    b = boost_scores(train_boost(X, y, params=params), X)
    np.testing.assert_array_equal(a, b)
    m = segment_metrics(a, y)
    assert m["recall"] > 0.9 and m["precision"] > 0.9  # separable toy problem, training-set metrics


def test_train_boost_input_errors() -> None:
    X = np.ones((4, len(FEATURE_NAMES)), dtype=np.float32)
    with pytest.raises(ValueError, match="both classes"):
        train_boost(X, np.ones(4, dtype=np.int32))
    with pytest.raises(ValueError, match="X must be"):
        train_boost(X, np.ones(3, dtype=np.int32))
    with pytest.raises(ValueError, match="boost_type"):
        BoostTrainingParams(boost_type="ada")
    with pytest.raises(ValueError, match="holdout_fraction"):
        BoostTrainingParams(holdout_fraction=1.0)


@pytest.mark.realdata
def test_training_is_reproducible_on_a_real_subset(shared_data: Path) -> None:
    d = shared_data / "leg_tracker"
    pos = load_labelled_scans(d / "positive_1_extracted.bag")[::10]
    neg = load_scans(d / "negative_2.bag", ["/left_scan"])["/left_scan"][::20]
    X, y, _ = build_training_set(pos, neg)
    params = BoostTrainingParams(weak_count=30, seed=7)
    a = boost_scores(train_boost(X, y, params=params), X)
    b = boost_scores(train_boost(X, y, params=params), X)
    np.testing.assert_array_equal(a, b)
    # a different seed draws a different negative sub-sample: the scores change
    c = boost_scores(train_boost(X, y, params=BoostTrainingParams(weak_count=30, seed=8)), X)
    assert not np.array_equal(a, c)


@pytest.mark.realdata
def test_train_detector_command(shared_data: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rc = pfpeople_main(
        [
            "train-detector",
            "--data-dir",
            str(shared_data / "leg_tracker"),
            "--out",
            str(tmp_path),
            "--name",
            "small",
            "--weak-count",
            "20",
        ]
    )
    assert rc == 0
    side = json.loads((tmp_path / "small.json").read_text())
    assert side["params"]["weak_count"] == 20 and side["seed"] == 0
    assert side["split"]["test_positive"] == ["positive_4_extracted.bag"]
    assert side["counts"]["train"]["labels_matched"] == side["counts"]["train"]["labels"]
    assert 0.0 < side["metrics"]["test"]["recall"] <= 1.0
    det = BoostedSegmentDetector(tmp_path / "small.yml")
    assert det.sidecar["model_file"] == "small.yml"
    assert '"metrics"' in capsys.readouterr().out


def test_train_detector_command_missing_dir(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rc = pfpeople_main(["train-detector", "--data-dir", str(tmp_path / "absent"), "--out", str(tmp_path)])
    assert rc == 2
    assert "absent" in capsys.readouterr().err
