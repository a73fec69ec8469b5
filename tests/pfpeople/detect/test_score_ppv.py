"""PPV(score): the step function fitted to held-out detections, its card form, and what the learned model ships."""

from __future__ import annotations

import numpy as np
import pytest

from pfpeople.detect.learned.detector import LearnedPeopleDetector
from pfpeople.detect.learned.scoring import calibration, ppv_by_score
from pfpeople.detect.precision_recall import ScoredFrame
from pfpeople.detect.score_ppv import ScorePpv


def test_two_pools_by_hand() -> None:
    scores = np.r_[np.full(200, 0.2), np.full(200, 0.8)]
    true = np.r_[np.arange(200) < 20, np.arange(200) < 180]
    curve = ScorePpv.fit(scores, true, min_count=200)
    np.testing.assert_array_equal(curve.score_from, [0.2, 0.8])
    np.testing.assert_allclose(curve.ppv, [21 / 202, 181 / 202])
    np.testing.assert_array_equal(curve.detections, [200, 200])
    np.testing.assert_allclose(curve([0.0, 0.2, 0.5, 0.8, 1.0]), [21 / 202] * 3 + [181 / 202] * 2)


def test_pools_hold_min_count_and_follow_a_calibrated_score() -> None:
    """Detections whose score is their probability of being a person: the pools' PPV is the score within sampling
    error, non-decreasing, each pool at least ``min_count``."""
    rng = np.random.default_rng(3)
    s = rng.uniform(0.0, 1.0, 20000)
    y = rng.uniform(0.0, 1.0, s.size) < s
    curve = ScorePpv.fit(s, y, min_count=500)
    assert (curve.detections >= 500).all() and curve.detections.sum() == s.size
    assert (np.diff(curve.ppv) >= 0).all()
    for lo, hi, p in zip(curve.score_from, [*curve.score_from[1:], 1.0], curve.ppv, strict=True):
        assert lo - 0.05 <= p <= hi + 0.05


def test_a_tie_never_straddles_two_pools_and_the_beta_prior_keeps_the_order() -> None:
    s = np.r_[np.full(150, 0.3), np.full(300, 0.6), np.full(1000, 0.9)]
    y = np.r_[np.zeros(150), np.ones(300), np.r_[np.ones(999), 0]]  # 300/300 then 999/1000: the prior inverts them
    curve = ScorePpv.fit(s, y, min_count=100)
    assert set(curve.score_from.tolist()) <= {0.3, 0.6, 0.9}
    assert (np.diff(curve.ppv) >= 0).all()
    assert curve(0.3) == pytest.approx(1 / 152)


def test_card_round_trip_and_bad_input_is_named() -> None:
    curve = ScorePpv.fit(np.linspace(0, 1, 400), np.linspace(0, 1, 400) > 0.5, min_count=100)
    again = ScorePpv.from_card(curve.to_card(), "card x")
    np.testing.assert_array_equal(again.ppv, curve.ppv)
    np.testing.assert_array_equal(again.score_from, curve.score_from)
    with pytest.raises(ValueError, match=r"card x: ppv_by_score does not fit"):
        ScorePpv.from_card({"score_from": [0.5, 0.4], "ppv": [0.3, 0.4], "detections": [1, 1]}, "card x")
    with pytest.raises(ValueError, match=r"card x: ppv_by_score does not fit"):
        ScorePpv.from_card({"score_from": [0.5], "ppv": [1.0], "detections": [1]}, "card x")
    with pytest.raises(ValueError, match=r"card x: ppv_by_score does not fit"):
        ScorePpv.from_card({"ppv": [0.5]}, "card x")
    with pytest.raises(ValueError, match=r"at least 200"):
        ScorePpv.fit([0.5] * 10, [1] * 10)


def _frame(rng: np.random.Generator, n_people: int) -> ScoredFrame:
    truth = rng.uniform(-5, 5, (n_people, 2))
    hit = truth + rng.normal(0, 0.1, truth.shape)
    false = rng.uniform(-5, 5, (3, 2))
    scores = np.r_[rng.uniform(0.4, 1.0, n_people), rng.uniform(0.0, 0.7, 3)]
    return ScoredFrame.of(np.r_[hit, false], scores, truth)


def test_ppv_by_score_averages_to_the_pooled_ppv() -> None:
    rng = np.random.default_rng(0)
    scenes = [[_frame(rng, 2) for _ in range(150)], [_frame(rng, 1) for _ in range(150)]]
    negatives = [
        ScoredFrame.of(rng.uniform(-5, 5, (1, 2)), rng.uniform(0, 0.6, 1), np.zeros((0, 2))) for _ in range(99)
    ]
    ppv, _ = calibration(scenes, negatives, 0.5)
    curve = ppv_by_score(scenes, negatives, min_count=100)
    assert curve is not None
    s = np.concatenate([f.scores for sc in scenes for f in sc] + [f.scores for f in negatives])
    assert curve(s[s >= 0.5]).mean() == pytest.approx(ppv, abs=0.02)
    assert ppv_by_score(scenes[:1][:1], [], min_count=10**6) is None


def test_the_shipped_model_fuses_each_person_by_its_score() -> None:
    det = LearnedPeopleDetector()
    curve = det.score_ppv
    assert curve is not None and (np.diff(curve.ppv) >= 0).all()
    assert curve(det.threshold) < det.model.ppv < curve(0.99)  # the one PPV lies inside the curve's range
    assert LearnedPeopleDetector(score_ppv=False).score_ppv is None
    with pytest.raises(TypeError, match="score_ppv"):
        LearnedPeopleDetector(score_ppv="yes")  # type: ignore[arg-type]


def test_a_model_card_measures_ppv_by_score_when_it_can() -> None:
    from pfpeople.detect.learned.build import _measured

    rng = np.random.default_rng(1)
    scenes = [[_frame(rng, 2) for _ in range(100)]]
    cal = _measured(None, scenes, 0.5)["calibration"]
    curve = ScorePpv.from_card(cal["ppv_by_score"], "test")
    assert curve.detections.sum() == 500 and (np.diff(curve.ppv) >= 0).all()
    few = _measured(None, [[_frame(rng, 1) for _ in range(10)]], 0.5)["calibration"]
    assert "ppv_by_score" not in few and 0 < few["ppv"] < 1


def test_a_fold_is_calibrated_without_what_it_holds_out() -> None:
    from pfpeople.detect.learned.build import HeldOut, _calibration

    rng = np.random.default_rng(2)
    by_fold = {b: ([_frame(rng, 2) for _ in range(60)], [_frame(rng, 0) for _ in range(5)]) for b in ("a", "b", "c")}
    held = HeldOut(
        rows=[],
        models={},
        positive=[f for p, _ in by_fold.values() for f in p],
        negative=[f for _, n in by_fold.values() for f in n],
        by_fold=by_fold,
    )
    pos, neg = held.without("b")
    assert pos == [*by_fold["a"][0], *by_fold["c"][0]] and neg == [*by_fold["a"][1], *by_fold["c"][1]]
    cal = _calibration([pos], neg, 0.5, "folds a and c")
    assert (cal["ppv"], cal["fnr"]) == calibration([pos], neg, 0.5)
    assert cal["measured_on"].startswith("folds a and c") and "ppv_by_score" in cal
