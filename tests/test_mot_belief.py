"""The tracker's fused-belief inputs (pfpeople.mot): low peaks update but do not start tracks, the belief grid keeps
a coasting track alive (belief_support) or its report (report_belief), fast confirmation (confirm_score); the
pipeline's [tracking] peak_threshold; the MOT scoring helpers (tracks.csv, visibility filter)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from evaluation.mot_eval import _drop_matched, read_tracks_csv
from gridbridge.grid import GridSpec
from pfpeople.bag.config import TrackingConfig, config_from_mapping
from pfpeople.mot import MultiPersonTracker, TrackerConfig

DT = 0.1
SPEC = GridSpec(nx=30, ny=30, resolution=0.3, x0=0.0, y0=-4.5)


def _blob(x: float, y: float, peak: float) -> np.ndarray:
    """A belief grid with one Gaussian blob (sd 0.2 m) of height ``peak`` at (x, y) on 0.01 elsewhere."""
    gx, gy = SPEC.cell_centres()
    return np.maximum(0.01, peak * np.exp(-((gx - x) ** 2 + (gy - y) ** 2) / (2 * 0.2**2)))


def test_low_peaks_update_but_never_start_tracks() -> None:
    """A static weak peak (confidence 0.6 < birth_min_score 0.7) in every frame never becomes a track, while a
    walker whose peak dips to 0.6 for 10 frames keeps one id and is matched in every frame after confirmation."""
    tracker = MultiPersonTracker(TrackerConfig(birth_min_score=0.7))
    ids = set()
    for k in range(40):
        walker = [2.0 + 0.1 * k, 1.0]
        conf = 0.6 if 15 <= k < 25 else 0.9
        out = tracker.update(np.array([walker, [5.0, -2.0]]), DT, scores=np.array([conf, 0.6]))
        if k >= 2:
            assert len(out) == 1
            assert math.hypot(out[0].x - walker[0], out[0].y - walker[1]) < 0.1  # Kalman lag in the first frames
            ids.add(out[0].id)
    assert ids == {1}
    assert all(t.id == 1 for t in tracker.tracks)  # the static weak peak never started even a tentative track


def test_belief_support_keeps_a_coasting_track_alive() -> None:
    """A walker detected for 20 frames then only present in the belief (blob of 0.5 at its position, below the peak
    threshold) for 30 frames: with belief_support = 0.3 the track follows the blob (within half a 0.3 m cell) and is
    reported every frame; without, it stops being reported after report_coast_s = 1 s (10 frames)."""
    for support, reported in ((0.3, 30), (None, 10)):
        tracker = MultiPersonTracker(TrackerConfig(belief_support=support))
        n_rep = 0
        for k in range(50):
            p = (2.0 + 0.05 * k, 0.5)
            if k < 20:
                out = tracker.update(np.array([p]), DT, scores=np.array([0.9]), belief=_blob(*p, 0.9), spec=SPEC)
            else:
                out = tracker.update(np.zeros((0, 2)), DT, belief=_blob(*p, 0.5), spec=SPEC)
                n_rep += len(out)
                if support is not None:
                    (t,) = out
                    assert t.id == 1 and t.misses == 0
                    assert math.hypot(t.x - p[0], t.y - p[1]) < 0.15  # half a 0.3 m cell
        assert n_rep == reported


def test_belief_below_support_and_report_belief() -> None:
    """Belief 0.2 < belief_support 0.3 gives no update (the track coasts); report_belief = 0.3 hides the coasting
    track at once, report_belief = 0.1 reports it up to report_coast_s."""

    def run(cfg: TrackerConfig) -> list[int]:
        tracker = MultiPersonTracker(cfg)
        n = []
        for k in range(25):
            p = (3.0, 0.0)
            if k < 10:
                out = tracker.update(np.array([p]), DT, belief=_blob(*p, 0.9), spec=SPEC)
            else:
                out = tracker.update(np.zeros((0, 2)), DT, belief=_blob(*p, 0.2), spec=SPEC)
                n.append(len(out))
                assert all(t.misses == k - 9 for t in out)
        return n

    assert run(TrackerConfig(belief_support=0.3)) == [1] * 10 + [0] * 5
    assert run(TrackerConfig(report_belief=0.3)) == [0] * 15
    assert run(TrackerConfig(report_belief=0.1)) == [1] * 10 + [0] * 5


def test_belief_needs_its_spec_and_is_ignored_when_off() -> None:
    tracker = MultiPersonTracker(TrackerConfig(belief_support=0.5))
    with pytest.raises(TypeError, match="spec"):
        tracker.update(np.array([[1.0, 0.0]]), DT, belief=_blob(1.0, 0.0, 0.9))
    with pytest.raises(ValueError, match="belief"):
        tracker.update(np.array([[1.0, 0.0]]), DT, belief=np.zeros((3, 3)), spec=SPEC)
    plain = MultiPersonTracker()  # options off: the belief is not even checked
    plain.update(np.array([[1.0, 0.0]]), DT, belief=np.zeros((3, 3)))


def test_confirm_score_confirms_at_birth() -> None:
    tracker = MultiPersonTracker(TrackerConfig(confirm_score=0.9))
    assert [t.id for t in tracker.update(np.array([[2.0, 0.0], [4.0, 1.0]]), DT, scores=np.array([0.95, 0.8]))] == [1]
    out = tracker.update(np.array([[2.0, 0.0], [4.0, 1.0]]), DT, scores=np.array([0.95, 0.92]))
    assert [t.id for t in out] == [1, 2]  # the second confirmed by its 0.92 hit, before 3 of 5


@pytest.mark.parametrize(
    ("field", "value"),
    [("belief_support", 0.0), ("belief_support", 1.5), ("report_belief", -0.1), ("confirm_score", 2)],
)
def test_belief_options_validated(field: str, value: float) -> None:
    with pytest.raises(ValueError, match=field):
        TrackerConfig(**{field: value})


def test_tracking_config_peak_threshold() -> None:
    assert TrackingConfig().peak_threshold == 0.5
    base = {"frames": {"driver": "/scan"}, "detectors": [{"name": "legs", "kind": "leg", "topic": "/scan"}]}
    cfg = config_from_mapping({**base, "tracking": {"peak_threshold": 0.6}})
    assert cfg.tracking.peak_threshold == 0.6
    assert cfg.to_dict()["tracking"]["peak_threshold"] == 0.6
    for bad in (1.0, -0.1, True, "0.5"):
        with pytest.raises(ValueError, match="peak_threshold"):
            TrackingConfig(peak_threshold=bad)  # type: ignore[arg-type]


def test_read_tracks_csv_and_drop_matched(tmp_path: Path) -> None:
    path = tmp_path / "tracks.csv"
    path.write_text("frame,stamp_ns,id,x,y,vx,vy,cov_xx,cov_xy,cov_yy,score\n1,5,3,1.5,-0.5,0,0,0.01,0,0.01,0.9\n")
    hyp = read_tracks_csv(path, 3)
    assert [h[0].tolist() for h in hyp] == [[], [3], []]
    assert hyp[1][1].tolist() == [[1.5, -0.5]]
    with pytest.raises(ValueError, match="outside"):
        read_tracks_csv(path, 1)
    ids = np.array([1, 2, 3])
    pos = np.array([[0.0, 0.0], [1.0, 0.0], [3.0, 0.0]])
    # hidden person at (1.1, 0): hypothesis 2 is don't care; one at (5, 0) matches nothing within 0.75 m
    kid, kpos = _drop_matched(ids, pos, np.array([[1.1, 0.0], [5.0, 0.0]]), 0.75)
    assert kid.tolist() == [1, 3] and kpos.tolist() == [[0.0, 0.0], [3.0, 0.0]]


def test_prefer_confirmed_keeps_the_person_on_its_track() -> None:
    """A confirmed track stands at (2, 0); a clutter point at (2.5, 0) starts a tentative track beside it; then one
    detection at (2.3, 0): it is nearer the tentative track (0.2 m vs 0.3 m, and a lower assignment cost), so
    without prefer_confirmed the clutter track takes it and the person's track misses; with it (the default) the
    person's track keeps it."""
    for prefer, person_hit in ((False, False), (True, True)):
        tracker = MultiPersonTracker(TrackerConfig(prefer_confirmed=prefer))
        for _ in range(20):
            tracker.update(np.array([[2.0, 0.0]]), DT)
        tracker.update(np.array([[2.0, 0.0], [2.5, 0.0]]), DT)
        tracker.update(np.array([[2.3, 0.0]]), DT)
        person, clutter = tracker.tracks
        assert person.confirmed and not clutter.confirmed
        assert (person.misses == 0) is person_hit and (clutter.misses == 0) is (not person_hit)
    with pytest.raises(TypeError, match="prefer_confirmed"):
        TrackerConfig(prefer_confirmed=1)  # type: ignore[arg-type]


def test_tracker_inputs_people_plus_weaker_peaks() -> None:
    """Blobs (on cell centres) of 0.9 at (3.15, 1.05), 0.6 at (6.15, -1.95) and 0.6 at (3.45, 1.05) (within 0.6 m of
    the strong one: no peak of its own): the inputs are the person unchanged plus the one separate weak peak at
    its belief; without a weak blob, the people alone."""
    from gridbridge.classifiers import PeakClassifier
    from pfpeople.mot import tracker_inputs

    high = PeakClassifier(threshold=0.7)
    low = PeakClassifier(threshold=0.5)
    b = np.maximum(_blob(3.15, 1.05, 0.9), _blob(6.15, -1.95, 0.6))
    b = np.maximum(b, _blob(3.45, 1.05, 0.6))
    people = high.classify(b, SPEC)
    pos, sc = tracker_inputs(people, b, SPEC, low=low, high=0.7)
    assert len(people) == 1 and pos.shape == (2, 2)
    assert np.array_equal(pos[0], people.positions[0]) and sc[0] == people.scores[0]
    assert np.hypot(*(pos[1] - [6.15, -1.95])) < 1e-9 and sc[1] == pytest.approx(0.6, abs=1e-12)
    only = _blob(3.15, 1.05, 0.9)
    pos, sc = tracker_inputs(high.classify(only, SPEC), only, SPEC, low=low, high=0.7)
    assert pos.shape == (1, 2) and np.array_equal(pos, high.classify(only, SPEC).positions)
    with pytest.raises(ValueError, match="below"):
        tracker_inputs(people, b, SPEC, low=high, high=0.7)


def test_tracker_inputs_weak_peaks_equal_a_low_threshold_pass() -> None:
    """On 30 random grids (8 blobs each, peaks uniform in [0.4, 0.95], random observed mask) the weak peaks equal the
    peaks of PeakClassifier(threshold=0.5) with belief <= 0.7 (positions to 1e-9 m, scores exactly)."""
    from gridbridge.classifiers import PeakClassifier
    from pfpeople.mot import tracker_inputs

    rng = np.random.default_rng(5)
    high, low = PeakClassifier(threshold=0.7), PeakClassifier(threshold=0.5)
    n_weak = 0
    for _ in range(30):
        b = np.full(SPEC.shape, 0.01)
        for _ in range(8):
            b = np.maximum(b, _blob(rng.uniform(0, 9), rng.uniform(-4.5, 4.5), rng.uniform(0.4, 0.95)))
        obs = rng.random(SPEC.shape) > 0.1
        people = high.classify(b, SPEC, observed=obs)
        pos, sc = tracker_inputs(people, b, SPEC, low=low, high=0.7, observed=obs)
        ref = low.classify(b, SPEC, observed=obs)
        weak = ref.scores <= 0.7
        assert np.array_equal(sc[len(people) :], ref.scores[weak])
        np.testing.assert_allclose(pos[len(people) :], ref.positions[weak], atol=1e-9)
        n_weak += int(weak.sum())
    assert n_weak > 20  # the test exercises weak peaks
