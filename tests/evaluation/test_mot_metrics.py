"""CLEAR-MOT scores (evaluation.metrics.clear_mot) on hand-made sequences whose MOTA / IDSW are counted by hand."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from evaluation.metrics.clear_mot import accumulate, clear_mot, distance_matrix, hota, scores_from_events


def _f(ids: list[int], pos: list[list[float]]) -> tuple[np.ndarray, np.ndarray]:
    return np.array(ids, dtype=np.int64), np.array(pos, dtype=float).reshape(-1, 2)


# Two people A (id 1) and B (id 2); hypotheses h10, h20, h30. By hand (gate 0.75 m):
# frame 0: A-h10 (0.1 m), B-h20 (0.2 m)                    -> 2 matches
# frame 1: A-h10 (0.1), B missed, h30 far from everybody    -> 1 match, 1 miss, 1 FP
# frame 2: A-h10 (0.0), B-h30 (0.1): B was h20 -> switch    -> 2 matches, 1 IDSW
# frame 3: A-h20 (0.3) (A was h10 -> switch), B-h30 (0.2)   -> 2 matches, 1 IDSW
# frame 4: A-h20 (0.5), B nothing within gate (h30 at 1 m)  -> 1 match, 1 miss, 1 FP
# GT = 10, misses = 2, FP = 2, IDSW = 2  -> MOTA = 1 - 6/10 = 0.4
# matches = 8, distances 0.1+0.2+0.1+0+0.1+0.3+0.2+0.5 = 1.5 -> MOTP = 0.1875 m
# A: present 5 frames, matched 5 -> mostly tracked; B: present 5, matched 3 (60 %) -> partially tracked
# fragmentations: B matched, unmatched (frame 1), matched again -> 1; then unmatched at the end (not a fragment)
GT = [
    _f([1, 2], [[1, 0], [3, 0]]),
    _f([1, 2], [[1, 0], [3, 0]]),
    _f([1, 2], [[1, 0], [3, 0]]),
    _f([1, 2], [[1, 0], [3, 0]]),
    _f([1, 2], [[1, 0], [3, 0]]),
]
HYP = [
    _f([10, 20], [[1.1, 0], [3.2, 0]]),
    _f([10, 30], [[1.1, 0], [6, 0]]),
    _f([10, 30], [[1.0, 0], [3.1, 0]]),
    _f([20, 30], [[1.3, 0], [3.2, 0]]),
    _f([20, 30], [[1.5, 0], [4.0, 0]]),
]


def test_hand_counted_sequence() -> None:
    s = clear_mot(GT, HYP, gate=0.75)
    assert s.num_frames == 5 and s.num_gt == 10 and s.num_gt_ids == 2
    assert (s.num_misses, s.num_false_positives, s.id_switches, s.num_matches) == (2, 2, 2, 8)
    assert s.mota == pytest.approx(0.4)
    assert s.motp == pytest.approx(0.1875)
    assert s.recall == pytest.approx(0.8) and s.precision == pytest.approx(0.8)
    assert (s.mostly_tracked, s.mostly_lost) == (1, 0)
    assert s.fragmentations == 1


def test_event_recount_agrees_with_motmetrics() -> None:
    acc = accumulate(GT, HYP, gate=0.75)
    ev = scores_from_events(acc)
    s = clear_mot(GT, HYP, gate=0.75)
    assert ev["mota"] == pytest.approx(s.mota) and ev["motp"] == pytest.approx(s.motp)
    for k in ("id_switches", "num_false_positives", "num_misses", "num_matches", "num_gt"):
        assert ev[k] == getattr(s, k), k


def test_gate_changes_matching() -> None:
    # with a 0.4 m gate frame 4's A-h20 (0.5 m) is a miss and an FP
    s = clear_mot(GT, HYP, gate=0.4)
    assert (s.num_misses, s.num_false_positives, s.num_matches) == (3, 3, 7)
    assert s.mota == pytest.approx(1 - (3 + 3 + 2) / 10)


def test_perfect_tracking_and_empty_frames() -> None:
    gt = [_f([1], [[1, 1]]), _f([], []), _f([1], [[1.2, 1]])]
    s = clear_mot(gt, gt)
    assert s.mota == 1.0 and s.motp == 0.0 and s.id_switches == 0 and s.num_gt == 2
    none = clear_mot([_f([], [])] * 3, [_f([], [])] * 3)
    assert none.num_gt == 0 and math.isnan(none.mota) and math.isnan(none.motp) and math.isnan(none.precision)


def test_region_ignores_outside() -> None:
    gt = [_f([1, 2], [[2, 0], [0, 2]])]  # bearing 0 and +90 deg
    hyp = [_f([5, 6], [[2.1, 0], [8, 8]])]  # the second hyp: 11.3 m away, bearing 45 deg
    s_all = clear_mot(gt, hyp)
    assert (s_all.num_gt, s_all.num_misses, s_all.num_false_positives) == (2, 1, 1)
    s = clear_mot(gt, hyp, sector=(-math.pi / 4 + 0.1, math.pi / 4 + 0.1), max_range=5.0)
    assert (s.num_gt, s.num_misses, s.num_false_positives, s.mota) == (1, 0, 0, 1.0)
    s = clear_mot(gt, hyp, sector=(-0.1, 0.1))
    assert (s.num_gt, s.num_false_positives) == (1, 0)


def test_distance_matrix() -> None:
    d = distance_matrix(np.array([[0.0, 0.0], [1.0, 1.0]]), np.array([[0.0, 0.5], [3.0, 3.0]]), gate=0.75)
    assert d.shape == (2, 2) and d[0, 0] == pytest.approx(0.5)
    assert np.isnan(d[0, 1]) and np.isnan(d[1, 1]) and np.isnan(d[1, 0])  # |(1,1)-(0,0.5)| = 1.118


@pytest.mark.parametrize(
    ("gt", "hyp", "kwargs", "match"),
    [
        ([_f([1], [[0, 0]])], [], {}, "frames"),
        ([(np.array([1]), np.array([[np.nan, 0.0]]))], [_f([], [])], {}, "NaN"),
        ([(np.array([1, 2]), np.array([[0.0, 0.0]]))], [_f([], [])], {}, "ids for"),
        ([(np.array([1, 1]), np.zeros((2, 2)))], [_f([], [])], {}, "unique"),
        ([(np.array([1]), np.zeros((1, 3)))], [_f([], [])], {}, "shape"),
        ([_f([1], [[0, 0]])], [_f([], [])], {"gate": 0.0}, "gate"),
        ([_f([1], [[0, 0]])], [_f([], [])], {"sector": (1.0, -1.0)}, "sector"),
        ([_f([1], [[0, 0]])], [_f([], [])], {"max_range": -2.0}, "max_range"),
    ],
)
def test_bad_input(gt: list, hyp: list, kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        clear_mot(gt, hyp, **kwargs)


# --- HOTA (TrackEval) ---------------------------------------------------------------------------------------


def _one(pos: tuple[float, float], pid: int = 1) -> tuple[np.ndarray, np.ndarray]:
    return np.array([pid]), np.array([pos], dtype=float)


def test_hota_by_hand() -> None:
    """One person for 10 frames. Similarity of a pair: 1 - d / gate (gate 0.75 m), matched at the thresholds
    alpha = 0.05 .. 0.95 up to it. Exact: HOTA 1; 0.375 m off: matched at 10 of the 19 thresholds, 10/19;
    the track's id changes half-way: DetA 1, AssA 5 / (5 + 5) = 0.5, HOTA sqrt(0.5)."""
    gt = [_one((1.0, 0.0)) for _ in range(10)]
    assert hota(gt, gt).hota == pytest.approx(1.0)
    off = hota(gt, [_one((1.375, 0.0), 9) for _ in range(10)])
    assert (off.hota, off.deta, off.assa) == pytest.approx((10 / 19, 10 / 19, 10 / 19))
    switch = hota(gt, [_one((1.0, 0.0), 7 if k < 5 else 8) for k in range(10)])
    assert (switch.hota, switch.deta, switch.assa) == pytest.approx((math.sqrt(0.5), 1.0, 0.5))
    # a false track beside the person halves the detection precision: DetA = 10 / (10 + 10)
    fp = hota(gt, [(np.array([1, 2]), np.array([[1.0, 0.0], [4.0, 0.0]])) for _ in range(10)])
    assert fp.deta == pytest.approx(0.5) and fp.assa == pytest.approx(1.0)


def test_hota_region_and_errors() -> None:
    gt = [(np.array([1, 2]), np.array([[1.0, 0.0], [-1.0, 0.0]])) for _ in range(4)]
    hyp = [_one((1.0, 0.0)) for _ in range(4)]
    assert hota(gt, hyp).deta == pytest.approx(0.5)
    assert hota(gt, hyp, sector=(-1.0, 1.0)).hota == pytest.approx(1.0)  # the person behind is out
    assert math.isnan(hota([_one((1.0, 0.0))][:0], []).hota)
    with pytest.raises(ValueError, match="frames"):
        hota(gt, hyp[:2])
    with pytest.raises(ValueError, match="gate"):
        hota(gt, hyp, gate=0.0)


def test_hota_without_trackeval_is_nan_and_logged(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setitem(sys.modules, "trackeval.metrics", None)  # the import fails
    gt = [_one((1.0, 0.0)) for _ in range(3)]
    assert math.isnan(hota(gt, gt).hota)
    assert "trackeval is not installed" in caplog.text
