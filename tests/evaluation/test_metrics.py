"""Detection, grid and tracking metrics against hand values and brute force."""

from __future__ import annotations

import math

import numpy as np
import pytest

from evaluation.metrics.detection import (
    DetectionAccumulator,
    brier_score,
    false_positive_cells,
    fpcpf,
    log_loss,
    match_people,
    precision,
    recall,
    roc_auc,
    tracking_summary,
)


def _auc_brute_force(scores: np.ndarray, labels: np.ndarray) -> float:
    """Pairwise count: P(score_pos > score_neg) + 0.5 P(equal) (scikit-learn's roc_auc_score value)."""
    pos, neg = scores[labels], scores[~labels]
    total = 0.0
    for p in pos:
        for n in neg:
            total += 1.0 if p > n else 0.5 if p == n else 0.0
    return total / (pos.size * neg.size)


# --- matching ---------------------------------------------------------------------------------------------


def test_match_gate_is_inclusive_and_one_to_one():
    m = match_people([[0.0, 0.0], [0.1, 0.0]], [[0.05, 0.0]])
    assert (m.tp, m.fp, m.fn) == (1, 1, 0)  # one person cannot be found twice
    m = match_people([[0.5, 0.0]], [[0.0, 0.0]], gate=0.5)
    assert (m.tp, m.fp, m.fn) == (1, 0, 0)
    m = match_people([[0.51, 0.0]], [[0.0, 0.0]], gate=0.5)
    assert (m.tp, m.fp, m.fn) == (0, 1, 1)
    m = match_people([[0.51, 0.0]], [[0.0, 0.0]], gate=0.6)
    assert m.tp == 1 and m.distances[0] == pytest.approx(0.51)


def test_match_maximises_the_number_of_pairs():
    # D0 is 0.5 m from both people; D1 is 0.1 m from T0 only. A greedy D0-T0 pairing would leave D1 and T1.
    m = match_people([[0.5, 0.0], [0.1, 0.0]], [[0.0, 0.0], [1.0, 0.0]], gate=0.5)
    assert (m.tp, m.fp, m.fn) == (2, 0, 0)
    assert sorted(map(tuple, m.pairs.tolist())) == [(0, 1), (1, 0)]
    np.testing.assert_allclose(sorted(m.distances), [0.1, 0.5])


def test_match_empty_frames():
    m = match_people(np.zeros((0, 2)), [[1.0, 1.0]])
    assert (m.tp, m.fp, m.fn) == (0, 0, 1)
    m = match_people([[1.0, 1.0], [2.0, 2.0]], [])
    assert (m.tp, m.fp, m.fn) == (0, 2, 0)


def test_match_overlap_rule():
    shape = (6, 6)
    d = np.zeros((2, *shape), dtype=bool)
    t = np.zeros((2, *shape), dtype=bool)
    d[0, 1:3, 1:3] = True  # overlaps person 0 by one cell
    d[1, 4, 4] = True  # overlaps nobody
    t[0, 2:4, 2:4] = True
    t[1, 0, 5] = True
    pos = [[0.0, 0.0], [9.0, 9.0]]  # positions do not matter for the overlap rule
    m = match_people(pos, pos, rule="overlap", detected_masks=d, truth_masks=t)
    assert (m.tp, m.fp, m.fn) == (1, 1, 1) and m.pairs.tolist() == [[0, 0]]
    with pytest.raises(ValueError, match="detected_masks"):
        match_people(pos, pos, rule="overlap", truth_masks=t)


def test_recall_precision_and_zero_counts():
    assert recall(72, 28) == pytest.approx(0.72)
    assert precision(86, 14) == pytest.approx(0.86)
    assert math.isnan(recall(0, 0)) and math.isnan(precision(0, 0))
    assert recall(0, 5) == 0.0
    with pytest.raises(ValueError, match="fn"):
        recall(1, -1)


# --- FPCPF ------------------------------------------------------------------------------------------------


def test_fpcpf_hand_value():
    c = np.zeros((2, 4, 4), dtype=bool)
    t = np.zeros((2, 4, 4), dtype=bool)
    c[0, 0, 0:3] = True  # 3 classified cells
    t[0, 0, 0] = True  # one of them occupied -> 2 false-positive cells
    c[1, 2, 2] = True  # 1 false-positive cell
    t[1, 3, 3] = True  # a missed person is not a false-positive cell
    assert false_positive_cells(c[0], t[0]) == 2
    assert fpcpf(c, t) == pytest.approx(1.5)
    with pytest.raises(ValueError, match="classified"):
        fpcpf(c.astype(float), t)
    with pytest.raises(ValueError, match="truth"):
        fpcpf(c, t[:1])


# --- grid scores ------------------------------------------------------------------------------------------


def test_brier_and_log_loss_hand_values():
    b = np.array([[0.8, 0.3], [0.5, 1.0]])
    t = np.array([[True, False], [True, False]])
    assert brier_score(b, t) == pytest.approx((0.04 + 0.09 + 0.25 + 1.0) / 4)
    eps = 1e-12
    expected = -(math.log(0.8) + math.log(0.7) + math.log(0.5) + math.log(eps)) / 4
    assert log_loss(b, t, eps=eps) == pytest.approx(expected, rel=1e-9)
    mask = np.array([[True, True], [False, False]])
    assert brier_score(b, t, mask=mask) == pytest.approx(0.065)
    assert log_loss(b, t, mask=mask) == pytest.approx(-(math.log(0.8) + math.log(0.7)) / 2)


@pytest.mark.parametrize("seed", range(6))
def test_roc_auc_matches_brute_force_with_ties(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(5, 40))
    scores = np.round(rng.random(n), 1)  # many ties
    labels = rng.random(n) < 0.4
    labels[0], labels[1] = True, False  # both classes present
    assert roc_auc(scores, labels) == pytest.approx(_auc_brute_force(scores, labels), abs=1e-12)


def test_roc_auc_known_values_and_one_class():
    t = np.array([True, True, False, False])
    assert roc_auc(np.array([0.9, 0.8, 0.1, 0.2]), t) == 1.0
    assert roc_auc(np.array([0.1, 0.2, 0.9, 0.8]), t) == 0.0
    assert roc_auc(np.full(4, 0.5), t) == 0.5
    assert math.isnan(roc_auc(np.array([0.1, 0.2]), np.array([False, False])))
    mask = np.array([True, False, True, True])
    assert roc_auc(np.array([0.9, 0.0, 0.1, 0.95]), t, mask=mask) == 0.5


def test_grid_scores_bad_input():
    with pytest.raises(ValueError, match="truth"):
        brier_score(np.zeros((2, 2)), np.zeros((2, 2)))
    with pytest.raises(ValueError, match="belief"):
        roc_auc(np.full((2, 2), 1.5), np.zeros((2, 2), dtype=bool))
    with pytest.raises(ValueError, match="mask"):
        log_loss(np.zeros((2, 2)), np.zeros((2, 2), dtype=bool), mask=np.ones(3, dtype=bool))
    with pytest.raises(ValueError, match="eps"):
        log_loss(np.zeros((2, 2)), np.zeros((2, 2), dtype=bool), eps=0.0)
    with pytest.raises(ValueError, match="detected"):
        match_people(np.zeros((2, 3)), np.zeros((1, 2)))
    with pytest.raises(ValueError, match="gate"):
        match_people(np.zeros((1, 2)), np.zeros((1, 2)), gate=-1.0)


# --- accumulator --------------------------------------------------------------------------------------------


def test_accumulator_sums_frames():
    acc = DetectionAccumulator(gate=0.5)
    occ = np.zeros((3, 3), dtype=bool)
    occ[0, 0] = True
    cls = np.zeros((3, 3), dtype=bool)
    cls[0, 0] = cls[1, 1] = True
    belief = np.where(occ, 0.9, 0.2)
    acc.add([[0.1, 0.0], [3.0, 3.0]], [[0.0, 0.0]], classified=cls, occupancy=occ, belief=belief)
    acc.add(np.zeros((0, 2)), [[1.0, 1.0]], classified=np.zeros((3, 3), dtype=bool), occupancy=occ, belief=belief)
    s = acc.summary()
    assert (s["frames"], s["tp"], s["fp"], s["fn"]) == (2, 1, 1, 1)
    assert s["recall"] == pytest.approx(0.5) and s["precision"] == pytest.approx(0.5)
    assert s["fpcpf"] == pytest.approx(0.5)
    assert s["mean_match_distance_m"] == pytest.approx(0.1)
    stacked_b = np.stack([belief, belief])
    stacked_t = np.stack([occ, occ])
    assert s["brier"] == pytest.approx(brier_score(stacked_b, stacked_t))
    assert s["log_loss"] == pytest.approx(log_loss(stacked_b, stacked_t))
    assert s["auc"] == 1.0
    with pytest.raises(ValueError, match="occupancy"):
        acc.add([], [], belief=belief)
    assert acc.frames == 2  # the failed frame was not counted


def test_empty_accumulator_summary_is_nan():
    s = DetectionAccumulator().summary()
    assert s["frames"] == 0 and all(math.isnan(s[k]) for k in ("recall", "precision", "fpcpf", "auc"))


# --- tracking summary ---------------------------------------------------------------------------------------


def test_tracking_summary_hand_values():
    tracked = np.array([True, True, False, True, True])
    cent = np.array([[0.0, 0.0], [1.0, 0.0], [np.nan, np.nan], [2.0, 0.0], [3.0, 0.0]])
    truth = np.array([[0.0, 0.1], [1.0, 0.3], [2.0, 0.0], [2.0, 0.0], [np.nan, np.nan]])
    missed = np.array([False, True, True, True, False])
    s = tracking_summary(tracked, cent, truth, all_missed=missed, gate=0.2)
    assert s["frames"] == 4
    assert s["tracked_fraction"] == pytest.approx(3 / 4)
    assert s["correct_fraction"] == pytest.approx(2 / 4)  # errors 0.1, 0.3, 0.0 with gate 0.2
    assert s["mean_error_m"] == pytest.approx(0.4 / 3)
    assert s["max_error_m"] == pytest.approx(0.3)
    assert s["all_missed_frames"] == 3 and s["held_while_all_missed"] == 1
    with pytest.raises(ValueError, match="centroids"):
        tracking_summary(tracked, cent[:3], truth)
    with pytest.raises(ValueError, match="tracked"):
        tracking_summary(tracked.astype(int), cent, truth)
    with pytest.raises(ValueError, match="gate"):
        tracking_summary(tracked, cent, truth, gate=float("nan"))  # NaN would silently count nothing correct
