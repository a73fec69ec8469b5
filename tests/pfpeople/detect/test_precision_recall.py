"""Average precision: hand-computed curves, and the incremental matching against a brute force per threshold."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from pfpeople.detect.precision_recall import (
    ScoredFrame,
    average_precision,
    frame_gains,
    pr_curve,
    recall_at_precision,
)


def test_hand_computed_curve() -> None:
    """Two frames: scores 0.9 (hit), 0.8 (false), 0.7 (hit); three true people."""
    f1 = ScoredFrame.of([[0.0, 0.0], [5.0, 5.0]], [0.9, 0.8], [[0.1, 0.0], [3.0, 0.0]])
    f2 = ScoredFrame.of([[1.0, 1.0]], [0.7], [[1.2, 1.0]])
    c = pr_curve([f1, f2], 0.5)
    np.testing.assert_allclose(c.thresholds, [0.9, 0.8, 0.7])
    np.testing.assert_allclose(c.recall, [1 / 3, 1 / 3, 2 / 3])
    np.testing.assert_allclose(c.precision, [1.0, 0.5, 2 / 3])
    assert average_precision(c) == pytest.approx(1 / 3 * 1.0 + 1 / 3 * 2 / 3)
    assert recall_at_precision(c, 0.9) == pytest.approx(1 / 3)


def test_a_scoreless_detector_gets_recall_times_precision() -> None:
    f = ScoredFrame.of([[0, 0], [9, 9]], [1.0, 1.0], [[0.1, 0], [4, 4]])
    c = pr_curve([f], 0.5)
    assert c.thresholds.size == 1
    assert average_precision(c) == pytest.approx(0.5 * 0.5)


def test_ignored_people_are_neither_found_nor_missed() -> None:
    f = ScoredFrame.of([[0, 0], [3, 0]], [0.9, 0.8], [[0, 0.1], [3, 0.1]], ignore=[False, True])
    c = pr_curve([f], 0.5)
    assert c.positives == 1
    np.testing.assert_allclose(c.recall, [1.0, 1.0])
    np.testing.assert_allclose(c.precision, [1.0, 1.0])  # the detection of the ignored person is no false one


def test_matching_prefers_more_pairs() -> None:
    """The best-scoring detection lies between two people; the second is near only one: both are found."""
    f = ScoredFrame.of([[0.5, 0.0], [0.0, 0.0]], [0.9, 0.8], [[0.0, 0.0], [0.9, 0.0]])
    tp, ig = frame_gains(f, 0.5)
    assert list(tp) == [1, 1] and list(ig) == [0, 0]


def _brute_counts(frames: list[ScoredFrame], thr: float, radius: float) -> tuple[int, int]:
    tp = fp = 0
    for f in frames:
        keep = f.scores >= thr
        det = f.detections[keep]
        if not len(det):
            continue
        if not len(f.truth):
            fp += len(det)
            continue
        d = np.linalg.norm(det[:, None] - f.truth[None], axis=-1) <= radius
        r, c = linear_sum_assignment(np.where(d, 0.0, 1.0))
        ok = d[r, c]
        tp += int(ok.sum())
        fp += len(det) - int(ok.sum())
    return tp, fp


def test_incremental_matching_equals_brute_force_per_threshold(rng: np.random.Generator) -> None:
    frames = []
    for _ in range(30):
        nd, nt = rng.integers(0, 6), rng.integers(0, 4)
        frames.append(
            ScoredFrame.of(rng.uniform(0, 3, (nd, 2)), rng.choice([0.2, 0.4, 0.6, 0.8], nd), rng.uniform(0, 3, (nt, 2)))
        )
    c = pr_curve(frames, 0.6)
    for k, thr in enumerate(c.thresholds):
        tp, fp = _brute_counts(frames, float(thr), 0.6)
        assert c.recall[k] * c.positives == pytest.approx(tp)
        assert c.precision[k] == pytest.approx(tp / (tp + fp))


def test_bad_frames_are_refused() -> None:
    with pytest.raises(ValueError, match="scores"):
        ScoredFrame.of([[0, 0]], [0.5, 0.6], [])
    with pytest.raises(ValueError, match="finite"):
        ScoredFrame.of([[np.nan, 0]], [0.5], [])
    with pytest.raises(ValueError, match="radius"):
        pr_curve([], 0.0)
