"""Tracking one person on the grid by blob centroids (paper Sect. 4): synthetic sequences, one test per rule."""

from __future__ import annotations

import numpy as np
import pytest

from evaluation.metrics.detection import tracking_summary
from gridbridge.blobs import classify_blobs
from gridbridge.grid import GridSpec
from pfpeople.track.blob_tracker import BlobTracker, TrackerParams, TrackingError, track_sequence

SPEC = GridSpec()  # the paper's 30 x 30 grid, 0.3 m cells


def _grid(cells: dict[tuple[int, int], float], background: float = 0.02) -> np.ndarray:
    g = np.full(SPEC.shape, background)
    for (i, j), v in cells.items():
        g[i, j] = v
    return g


def _block(i: int, j: int, value: float) -> dict[tuple[int, int], float]:
    """A 2 x 2 person blob with lower-left cell (i, j)."""
    return {(i + a, j + b): value for a in (0, 1) for b in (0, 1)}


def _block_centre(i: int, j: int) -> np.ndarray:
    x, y = SPEC.cell_centre(i + 0.5, j + 0.5)
    return np.array([float(x), float(y)])


def _classify(cells: dict[tuple[int, int], float]):
    return classify_blobs(_grid(cells), spec=SPEC)


def test_moving_blob_with_fade_and_gap_is_followed():
    # A person walks along +y one cell (0.3 m) per frame; a brighter person stands still far away.
    # Frames 8-10: the blob fades (detectors miss, belief decays); frames 11-12: gone; frame 13: back.
    peaks = [0.9] * 8 + [0.6, 0.5, 0.45] + [None, None] + [0.9] * 5
    js = [4 + k for k in range(11)] + [14, 14] + [15, 16, 17, 18, 19]
    distractor = _block(24, 20, 0.97)
    beliefs, truth = [], []
    for peak, j in zip(peaks, js, strict=True):
        cells = dict(distractor)
        if peak is not None:
            cells.update(_block(8, j, peak))
        beliefs.append(_grid(cells))
        truth.append(_block_centre(8, j))
    params = TrackerParams(start_point=(2.7, -3.0), start_radius=1.0, max_lost_frames=3)
    run = track_sequence(beliefs, spec=SPEC, params=params)
    assert run.rules[0] == "start"
    assert run.rules[11:13] == ["held", "held"]
    assert run.rules[13] == "nearest"
    assert all(r == "nearest" for r in run.rules[1:11] + run.rules[14:])
    assert {f.track_id for f in run.frames} == {0}
    tracked = run.tracked
    assert tracked.sum() == 16 and not tracked[11] and not tracked[12]
    # Every tracked centroid is the person's (never the brighter distractor), with zero error.
    all_missed = np.zeros(len(peaks), dtype=bool)
    all_missed[8:13] = True  # every detector missed: the belief decays, then is gone
    s = tracking_summary(tracked, run.centroids, np.array(truth), all_missed=all_missed, gate=0.3)
    assert s["tracked_fraction"] == pytest.approx(16 / 18)
    assert s["correct_fraction"] == pytest.approx(16 / 18)
    assert s["max_error_m"] == pytest.approx(0.0, abs=1e-9)
    assert s["all_missed_frames"] == 5 and s["held_while_all_missed"] == 3


def test_nearest_rule_prefers_the_highest_probability_among_near_blobs():
    tracker = BlobTracker(SPEC)
    f0 = tracker.update(_classify({(10, 10): 0.9}))
    assert f0.rule == "start"
    # B is nearer (0.3 m) but C (0.42 m, still within the 0.6 m gate) has the higher probability;
    # D is the brightest but outside the gate.
    f1 = tracker.update(_classify({(10, 11): 0.6, (9, 9): 0.95, (20, 20): 0.99}))
    assert f1.rule == "nearest"
    np.testing.assert_allclose(f1.centroid, SPEC.cell_centre(9, 9))
    assert f1.blob is not None and f1.blob.max_probability == pytest.approx(0.95)
    # With a gate that only reaches B, B is chosen.
    tracker = BlobTracker(SPEC, params=TrackerParams(gate=0.35))
    tracker.update(_classify({(10, 10): 0.9}))
    f1 = tracker.update(_classify({(10, 11): 0.6, (9, 9): 0.95, (20, 20): 0.99}))
    np.testing.assert_allclose(f1.centroid, SPEC.cell_centre(10, 11))


def test_overlap_rule_when_no_blob_is_near():
    tracker = BlobTracker(SPEC)
    tracker.update(_classify({(10, 10): 0.9, (10, 11): 0.6, (10, 12): 0.6}))  # centroid at cell (10, 10)
    # New blob: centroid at (10, 14), 1.2 m away, but it shares cell (10, 12) with the previous blob.
    f1 = tracker.update(_classify({(10, 12): 0.6, (10, 13): 0.6, (10, 14): 0.9, (25, 25): 0.99}))
    assert f1.rule == "overlap"
    np.testing.assert_allclose(f1.centroid, SPEC.cell_centre(10, 14))


def test_neighbourhood_rule_as_last_option():
    tracker = BlobTracker(SPEC)
    tracker.update(_classify({(10, 10): 0.9, (10, 11): 0.6, (10, 12): 0.6}))
    # No overlap; cell (11, 13) is a diagonal neighbour of the previous cell (10, 12); centroid 1.53 m away.
    f1 = tracker.update(_classify({(11, 13): 0.6, (11, 14): 0.6, (11, 15): 0.9, (25, 25): 0.99}))
    assert f1.rule == "neighbour"
    np.testing.assert_allclose(f1.centroid, SPEC.cell_centre(11, 15))
    # One cell farther (no contact): lost, held.
    tracker = BlobTracker(SPEC)
    tracker.update(_classify({(10, 10): 0.9, (10, 11): 0.6, (10, 12): 0.6}))
    f1 = tracker.update(_classify({(12, 14): 0.6, (12, 15): 0.6, (12, 16): 0.9}))
    assert f1.rule == "held" and not f1.tracked and np.all(np.isnan(f1.centroid))


def test_lost_track_is_held_then_ended_then_restarted():
    params = TrackerParams(max_lost_frames=2)
    results = [_classify({(10, 10): 0.9})] + [_classify({})] * 3 + [_classify({(20, 5): 0.8})]
    run = track_sequence(results=results, spec=SPEC, params=params)
    assert run.rules == ["start", "held", "held", "ended", "start"]
    assert [f.track_id for f in run.frames] == [0, 0, 0, 0, 1]
    no_restart = track_sequence(results=results, spec=SPEC, params=TrackerParams(max_lost_frames=2, restart=False))
    assert no_restart.rules[-1] == "idle" and no_restart.frames[-1].track_id == -1


def test_start_rules():
    cells = {(5, 5): 0.6, (20, 20): 0.9}
    f = BlobTracker(SPEC).update(_classify(cells))
    np.testing.assert_allclose(f.centroid, SPEC.cell_centre(20, 20))  # highest probability
    start = tuple(float(v) for v in SPEC.cell_centre(5, 5))
    f = BlobTracker(SPEC, params=TrackerParams(start_point=start)).update(_classify(cells))  # type: ignore[arg-type]
    np.testing.assert_allclose(f.centroid, SPEC.cell_centre(5, 5))
    f = BlobTracker(SPEC, params=TrackerParams(start_threshold=0.95)).update(_classify(cells))
    assert f.rule == "idle" and not f.tracked


def test_ego_motion_transform_moves_the_reference():
    # A standing person at cell i = 15 while the robot drives forward 0.3 m per frame: in the sensor frame
    # the person comes one cell closer each frame.
    results = [_classify({(15 - k, 12): 0.9}) for k in range(4)]
    params = TrackerParams(gate=0.2)
    plain = track_sequence(results=results, spec=SPEC, params=params)
    assert plain.rules == ["start", "neighbour", "neighbour", "neighbour"]
    moved = track_sequence(results=results, spec=SPEC, params=params, transforms=[None] + [(0.3, 0.0, 0.0)] * 3)
    assert moved.rules == ["start", "nearest", "nearest", "nearest"]
    # A quarter turn to the left (dtheta = +pi/2, no translation): the point (1.35, 3.15) on the left moves to
    # R(-pi/2) p = (3.15, -1.35), in front: cell (4, 25) -> cell (10, 10).
    first, second = _classify({(4, 25): 0.9}), _classify({(10, 10): 0.9})
    turned = track_sequence(results=[first, second], spec=SPEC, transforms=[None, (0.0, 0.0, np.pi / 2)])
    assert turned.rules == ["start", "nearest"]
    assert track_sequence(results=[first, second], spec=SPEC).rules == ["start", "held"]


def test_bad_input_raises_naming_it():
    with pytest.raises(ValueError, match="gate"):
        TrackerParams(gate=0.0)
    with pytest.raises(ValueError, match="max_lost_frames"):
        TrackerParams(max_lost_frames=-1)
    with pytest.raises(ValueError, match="start_threshold"):
        TrackerParams(start_threshold=1.5)
    with pytest.raises(ValueError, match="start_point"):
        TrackerParams(start_point=(1.0, float("nan")))
    tracker = BlobTracker(SPEC)
    with pytest.raises(ValueError, match="result"):
        tracker.update(np.zeros(SPEC.shape))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="transform"):
        tracker.update(_classify({}), transform=(1.0, 2.0))
    small = classify_blobs(np.zeros((4, 4)), spec=GridSpec(nx=4, ny=4))
    with pytest.raises(ValueError, match="shape"):
        tracker.update(small)
    beliefs = [_grid({}), _grid({}), np.full(SPEC.shape, 2.0)]
    with pytest.raises(TrackingError, match=r"beliefs\[2\]") as info:
        track_sequence(beliefs, spec=SPEC)
    assert info.value.index == 2 and len(info.value.partial.frames) == 2  # the finished frames are kept
    with pytest.raises(ValueError, match="transforms"):
        track_sequence(beliefs, spec=SPEC, transforms=[None])
