"""The tracker's fused-belief inputs (pfpeople.track): low peaks update but do not start tracks; the options that lost
their ablations are gone (the belief grid as a measurement, fast confirmation); the pipeline's [tracking]
peak_threshold; the MOT scoring helpers (tracks.csv, visibility filter)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from evaluation.harness.mot_eval import _drop_matched, read_tracks_csv
from gridbridge.classifiers import PeakClassifier
from gridbridge.grid import GridSpec
from pfpeople.config import TrackingConfig, config_from_mapping
from pfpeople.pipeline.assembly import build_people_tracker
from pfpeople.track import MultiPersonTracker, TrackerConfig

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


@pytest.mark.parametrize("field", ["belief_support", "belief_radius", "report_belief", "confirm_score"])
def test_removed_options_are_refused_by_name(field: str) -> None:
    with pytest.raises(TypeError, match=field):
        TrackerConfig(**{field: 0.5})
    with pytest.raises(ValueError, match=rf"\[tracking.params\].*{field}"):
        build_people_tracker(TrackingConfig(params={field: 0.5}), None)


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
    from pfpeople.track import tracker_inputs

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
    from pfpeople.track import tracker_inputs

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


def _weak_peaks_by_maximum_filter(b: np.ndarray, low: PeakClassifier, high: float) -> tuple[np.ndarray, np.ndarray]:
    """The weaker peaks of the previous tracker_inputs: every cell's maximum filter (peak_maxima), the cells in
    ``(low, high]`` in row-major order, sorted, non-maximum suppression, centroids."""
    from gridbridge.classifiers import peak_maxima
    from pfpeople.track.belief_inputs import _centroids

    is_max, value = peak_maxima(b, SPEC, low.min_separation, low.smooth)
    cand = np.argwhere((value > low.threshold) & (value <= high) & is_max)
    values = value[cand[:, 0], cand[:, 1]]
    sep2 = (low.min_separation / SPEC.resolution) ** 2 - 1e-9
    kept: list[int] = []
    for k in np.lexsort((cand[:, 1], cand[:, 0], -values)).tolist():
        if all((cand[k, 0] - cand[m, 0]) ** 2 + (cand[k, 1] - cand[m, 1]) ** 2 >= sep2 for m in kept):
            kept.append(k)
    x, y = _centroids(b, SPEC, cand[kept], low.centroid_radius, 0.5 * low.threshold)
    return np.column_stack((x, y)), values[kept]


@pytest.mark.parametrize("numba", [True, False])
@pytest.mark.parametrize("smooth", [0.0, 0.8])
def test_tracker_inputs_weak_peaks_bit_for_bit_the_maximum_filter_ones(numba: bool, smooth: float) -> None:
    """The weaker peaks by the classifier's candidates (ordered_candidates) are those of the full-grid maximum
    filter, bit for bit: random grids with plateaus (few belief levels), blobs at the border, compiled or not."""
    from gridbridge import jit
    from gridbridge.classifiers import PeakClassifier
    from pfpeople.track import tracker_inputs

    rng = np.random.default_rng(31)
    low = PeakClassifier(threshold=0.5, smooth=smooth, only_observed=False)
    n_weak = 0
    for _ in range(60):
        b = np.full(SPEC.shape, 0.01)
        for _ in range(int(rng.integers(1, 10))):
            b = np.maximum(b, _blob(rng.uniform(-0.5, 9.5), rng.uniform(-5, 5), rng.uniform(0.4, 0.95)))
        b = np.round(b * 20) / 20 if rng.random() < 0.5 else b
        people = PeakClassifier(threshold=0.7, smooth=smooth).classify(b, SPEC)
        with jit.override(numba):
            pos, sc = tracker_inputs(people, b, SPEC, low=low, high=0.7)
        want_pos, want_sc = _weak_peaks_by_maximum_filter(b, low, 0.7)
        n = len(people)
        assert pos[n:].tobytes() == want_pos.reshape(-1, 2).tobytes() and sc[n:].tobytes() == want_sc.tobytes()
        n_weak += len(want_sc)
    assert n_weak > 20


def test_a_run_confirms_by_evidence_unless_told_otherwise() -> None:
    def evidence(tracking: TrackingConfig) -> float | None:
        built = build_people_tracker(tracking, PeakClassifier(threshold=0.7))
        assert built is not None
        return built.tracker.config.confirm_evidence

    assert evidence(TrackingConfig()) == 0.6
    assert evidence(TrackingConfig(confirm_evidence="off")) is None
    assert evidence(TrackingConfig(params={"confirm_evidence": 0.7})) == 0.7
    base = {"frames": {"driver": "/scan"}, "detectors": [{"name": "legs", "kind": "leg", "topic": "/scan"}]}
    assert config_from_mapping({**base, "tracking": {"confirm_evidence": "off"}}).tracking.confirm_evidence == "off"
    with pytest.raises(ValueError, match="confirm_evidence"):
        config_from_mapping({**base, "tracking": {"confirm_evidence": 1.5}})
