"""The people a run reports: classified people confirmed by the tracker, and coasting tracks
(pfpeople.track.reported_people)."""

from __future__ import annotations

import numpy as np
import pytest

from gridbridge.classifiers import HysteresisPeaks, PeakClassifier, People, people_cells
from gridbridge.grid import GridSpec
from pfpeople.config import TrackingConfig, config_from_mapping, for_mode
from pfpeople.pipeline.assembly import build_people_tracker
from pfpeople.track import MultiPersonTracker, PeopleTracker, TrackerConfig

SPEC = GridSpec(nx=40, ny=40, resolution=0.25, x0=0.0, y0=-5.0)
DT = 0.1


def people_at(*points: tuple[float, float], score: float = 0.9) -> People:
    """People at ``points``, each with the cells within 0.3 m of it (as a classifier would give)."""
    pos = np.array(points, dtype=float).reshape(-1, 2)
    gx, gy = SPEC.cell_centres()
    mask = np.zeros(SPEC.shape, dtype=bool)
    sizes = []
    for x, y in pos:
        cells = np.hypot(gx - x, gy - y) <= 0.3
        mask |= cells
        sizes.append(int(cells.sum()))
    return People(positions=pos, scores=np.full(len(pos), score), sizes=np.array(sizes, np.int64), mask=mask)


def belief() -> np.ndarray:
    return np.full(SPEC.shape, 0.01)


def make(**kw: object) -> PeopleTracker:
    return PeopleTracker(PeakClassifier(threshold=0.7), **kw)  # type: ignore[arg-type]


def test_track_measurement_is_the_index_of_its_position() -> None:
    t = MultiPersonTracker(TrackerConfig(confirm_hits=1))
    out = t.update(np.array([[1.0, 0.0], [3.0, 1.0]]), DT)
    assert [tr.measurement for tr in out] == [0, 1]  # births
    out = t.update(np.array([[3.0, 1.0], [1.0, 0.0]]), DT)
    assert {tr.id: tr.measurement for tr in out} == {1: 1, 2: 0}
    t.update(np.array([[3.0, 1.0]]), DT)
    assert {tr.id: tr.measurement for tr in t.tracks} == {1: -1, 2: 0}  # track 1 coasts


def test_a_person_is_reported_once_its_track_is_confirmed() -> None:
    pt = make(config=TrackerConfig(confirm_hits=3, confirm_window=5))
    counts = [len(pt.step(people_at((2.0, 0.0)), belief(), SPEC, DT).people) for _ in range(4)]
    assert counts == [0, 0, 1, 1]
    # its cells are in the mask only once it is reported
    pt2 = make()
    first = pt2.step(people_at((2.0, 0.0)), belief(), SPEC, DT).people
    assert not first.mask.any() and first.sizes.shape == (0,)


def test_a_one_frame_false_person_is_never_reported() -> None:
    pt = make()
    reported = 0
    for k in range(8):
        pts = [(2.0, 0.0)] + ([(4.0, 2.0)] if k == 4 else [])
        reported += sum(
            np.hypot(*(p - np.array([4.0, 2.0]))) < 0.5
            for p in pt.step(people_at(*pts), belief(), SPEC, DT).people.positions
        )
    assert reported == 0


def test_a_confirmed_walker_coasts_one_missed_frame_at_its_prediction() -> None:
    pt = make(coast_frames=1)
    for k in range(10):
        out = pt.step(people_at((1.0 + 0.1 * k, 0.0)), belief(), SPEC, DT)
    assert len(out.people) == 1
    miss = pt.step(people_at(), belief(), SPEC, DT)
    assert miss.coasted == 1 and len(miss.people) == 1
    # constant velocity: 1 m/s along x from x = 1.9, within 3 cm (the Kalman velocity after 10 frames)
    np.testing.assert_allclose(miss.people.positions[0], [2.0, 0.0], atol=0.03)
    assert miss.people.sizes[0] == 0 and miss.people.scores[0] == pytest.approx(0.01)
    assert len(pt.step(people_at(), belief(), SPEC, DT).people) == 0  # second miss: not reported
    assert len(pt.tracker.confirmed()) == 1  # but the track lives on (tracks.csv)


def test_coast_frames_two_and_zero() -> None:
    for frames, expected in ((2, [1, 1, 0]), (0, [0, 0, 0])):
        pt = make(coast_frames=frames)
        for k in range(6):
            pt.step(people_at((2.0, 0.1 * k)), belief(), SPEC, DT)
        assert [len(pt.step(people_at(), belief(), SPEC, DT).people) for _ in range(3)] == expected


def test_coasting_only_in_observed_cells_and_apart_from_people() -> None:
    pt = make()
    for _ in range(5):
        pt.step(people_at((2.0, 0.0)), belief(), SPEC, DT)
    unobserved = np.ones(SPEC.shape, dtype=bool)
    unobserved.ravel()[SPEC.flat_index(np.array([2.0]), np.array([0.0]))] = False
    assert len(pt.step(people_at(), belief(), SPEC, DT, observed=unobserved).people) == 0
    pt = make(min_separation=0.6)
    for _ in range(5):
        pt.step(people_at((2.0, 0.0), (2.0, 0.5)), belief(), SPEC, DT)
    out = pt.step(people_at((2.0, 0.0)), belief(), SPEC, DT)
    assert out.coasted == 0 and len(out.people) == 1  # 0.5 m from a reported person: not repeated


def test_classified_reports_the_classifier_people_unchanged() -> None:
    pt = make(people="classified")
    found = people_at((2.0, 0.0), (3.0, 1.0))
    out = pt.step(found, belief(), SPEC, DT)
    assert out.people is found and out.coasted == 0


def test_people_cells_keeps_the_cells_nearest_to_kept_people() -> None:
    found = people_at((2.0, 0.0), (2.5, 0.0))
    kept = people_cells(found.mask, SPEC, found.positions, np.array([True, False]))
    gx, gy = SPEC.cell_centres()
    assert kept.any() and not (kept & ~found.mask).any()
    d_kept = np.hypot(gx - 2.0, gy)[kept]
    d_other = np.hypot(gx - 2.5, gy)[kept]
    assert np.all(d_kept <= d_other)
    assert not people_cells(found.mask, SPEC, found.positions, np.array([False, False])).any()
    with pytest.raises(ValueError, match="keep has 1 entries for 2 people"):
        people_cells(found.mask, SPEC, found.positions, np.array([True]))


def test_a_weak_peak_alone_updates_no_track_and_is_not_reported() -> None:
    cl = HysteresisPeaks(threshold=0.7, keep=0.5)
    pt = build_people_tracker(TrackingConfig(), cl)  # peak_threshold 0.5, tracks start only above 0.7
    grid = belief()
    grid[SPEC.to_cell(np.array([3.0]), np.array([1.0]))] = 0.6
    for _ in range(5):
        found = cl.classify(grid, SPEC)
        assert len(found) == 0 and len(cl.rejected) == 1  # the peak is a weak one...
        out = pt.step(found, grid, SPEC, DT)
    assert not pt.tracker.tracks and len(out.people) == 0  # ...fed to the tracker, which starts nothing from it


@pytest.mark.parametrize(
    ("kw", "msg"),
    [
        ({"people": "all"}, "people must be one of"),
        ({"coast_frames": -1}, "coast_frames must be an integer >= 0"),
        ({"coast_frames": 1.5}, "coast_frames must be an integer, got float"),
        ({"min_separation": -0.1}, "min_separation must be a number >= 0"),
        ({"peak_threshold": 1.0}, r"peak_threshold must be a number in \[0, 1\)"),
    ],
)
def test_people_tracker_rejects_bad_settings(kw: dict[str, object], msg: str) -> None:
    with pytest.raises(ValueError, match=msg):
        make(**kw)


def test_tracking_config_people_and_coast_frames() -> None:
    with pytest.raises(ValueError, match=r"\[tracking\] people: must be 'confirmed' or 'classified', got 'tracks'"):
        TrackingConfig(people="tracks")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"\[tracking\] coast_frames: must be greater than or equal to 0, got -2"):
        TrackingConfig(coast_frames=-2)
    cfg = config_from_mapping(
        {
            "frames": {"driver": "/scan"},
            "detectors": [{"name": "legs", "kind": "leg", "topic": "/scan"}],
            "tracking": {"people": "classified", "coast_frames": 3},
        }
    )
    assert cfg.tracking.people == "classified" and cfg.tracking.coast_frames == 3


def paper_tracking(**given: object) -> TrackingConfig:
    """``[tracking]`` with the paper mode's defaults (:data:`pfpeople.config.PAPER_DEFAULTS`)."""
    return TrackingConfig(**for_mode("paper", "tracking", given))


def test_build_people_tracker_defaults_by_mode() -> None:
    cl = PeakClassifier(threshold=0.7)
    rec = build_people_tracker(TrackingConfig(), cl)
    assert rec is not None and rec.people == "confirmed" and rec.coast_frames == 1
    assert rec.tracker.config.birth_min_score == 0.7  # tracks start only from people
    paper = build_people_tracker(paper_tracking(), cl)
    assert paper is not None and paper.people == "classified"
    assert build_people_tracker(paper_tracking(people="confirmed"), cl).people == "confirmed"  # type: ignore[union-attr]
    assert build_people_tracker(TrackingConfig(enabled=False), cl) is None
    # snapping: the recommended mode's default (the paper mode reports people where they were classified)
    assert rec.snap_radius == 0.3 and paper.snap_radius == 0.0
    assert build_people_tracker(paper_tracking(snap_radius=0.2), cl).snap_radius == 0.2  # type: ignore[union-attr]
    with pytest.raises(ValueError, match=r"\[tracking.params\]"):
        build_people_tracker(TrackingConfig(params={"no_such_field": 1}), cl)


def test_snap_to_detections_by_hand() -> None:
    from pfpeople.track.reported_people import snap_to_detections

    people = np.array([[1.0, 0.0], [3.0, 0.0], [5.0, 5.0]])
    dets = np.array([[1.1, 0.0], [0.9, 0.2], [3.5, 0.0]])
    out = snap_to_detections(people, dets, 0.3)
    np.testing.assert_allclose(out, [[1.0, 0.1], [3.0, 0.0], [5.0, 5.0]])  # mean of the two near the first
    np.testing.assert_allclose(snap_to_detections(people, dets, 0.6)[1], [3.5, 0.0])
    np.testing.assert_allclose(snap_to_detections(people, np.zeros((0, 2)), 0.3), people)


def test_people_tracker_reports_snapped_positions() -> None:
    """A person found by the grid at a cell centre 0.12 m from the laser's detection is reported and tracked at
    the detection with ``snap_radius`` 0.3 m, at the cell centre without."""
    for radius, expect in ((0.3, [2.12, 0.0]), (0.0, [2.0, 0.0])):
        pt = make(snap_radius=radius)
        for _ in range(4):
            out = pt.step(people_at((2.0, 0.0)), belief(), SPEC, DT, detections=np.array([[2.12, 0.0]]))
        np.testing.assert_allclose(out.people.positions, [expect], atol=1e-9)
        assert out.tracks[0].x == pytest.approx(expect[0], abs=1e-6)
    with pytest.raises(ValueError, match="snap_radius"):
        make(snap_radius=-0.1)
    with pytest.raises(ValueError, match="snap_radius"):
        TrackingConfig(snap_radius=float("nan"))
    cfg = config_from_mapping(
        {
            "frames": {"driver": "/scan"},
            "detectors": [{"name": "legs", "kind": "leg", "topic": "/scan"}],
            "tracking": {"snap_radius": 0.5, "single_legs": False},
        }
    )
    assert cfg.tracking.snap_radius == 0.5 and cfg.tracking.single_legs is False
    tracker = build_people_tracker(cfg.tracking, PeakClassifier(threshold=0.7))
    assert tracker.snap_radius == 0.5 and tracker.use_support is False


def test_track_moved_in_the_odometry_frame() -> None:
    """``Track.moved``: 0.3 m from the birth position with the ego-motion taken out. A table leg the robot drives
    towards at 1 m/s (it comes 0.1 m closer per scan in the sensor frame) has not moved; a walker has, for good."""
    from pfpeople.sensors import Pose2D

    table = MultiPersonTracker()
    for k in range(10):
        table.update(np.array([[3.0 - 0.1 * k, 0.5]]), DT, ego=Pose2D(x=0.1, y=0.0, yaw=0.0) if k else None)
    (tr,) = table.tracks
    assert tr.confirmed and not tr.moved and tr.age_s == pytest.approx(0.9)
    walker = MultiPersonTracker()
    moved = []
    for k in range(6):  # 0.1 m per scan; the Kalman position lags: 0.3 m from its birth at the 5th scan
        walker.update(np.array([[2.0 + 0.1 * k, 0.0]]), DT)
        moved.append(walker.tracks[0].moved)
    assert moved == [False, False, False, False, True, True]
    for _ in range(3):  # back where it started: still "moved"
        walker.update(np.array([[2.0, 0.0]]), DT)
    assert walker.tracks[0].moved


def test_a_standing_person_is_reported_after_static_confirm_s() -> None:
    """10 Hz: a walker at 1 m/s is reported once its track has moved 0.3 m (5th scan: the Kalman position lags);
    a person standing still from the scan where their track is 1.0 s old (11th), with ``static_confirm_s`` 1.0.
    With 0 both are reported from their confirmation (3rd scan)."""
    for wait, walker_first, standing_first in ((1.0, 4, 10), (0.0, 2, 2)):
        pt = make(static_confirm_s=wait)
        walker, stander = [], []
        for k in range(14):
            out = pt.step(people_at((1.0 + 0.1 * k, -2.0), (3.0, 2.0)), belief(), SPEC, DT).people.positions
            walker.append(bool(np.any(np.hypot(out[:, 0] - (1.0 + 0.1 * k), out[:, 1] + 2.0) < 0.1)))
            stander.append(bool(np.any(np.hypot(out[:, 0] - 3.0, out[:, 1] - 2.0) < 0.1)))
        assert walker.index(True) == walker_first and all(walker[walker_first:])
        assert stander.index(True) == standing_first and all(stander[standing_first:])
    with pytest.raises(ValueError, match="static_confirm_s must be a number >= 0"):
        make(static_confirm_s=-1.0)
    with pytest.raises(ValueError, match="static_confirm_s"):
        TrackingConfig(static_confirm_s=float("inf"))


@pytest.mark.parametrize("only", [True, False])
def test_coasting_tracks_outside_the_observed_cells_are_not_reported(only: bool) -> None:
    """A walker at 1 m/s along x, detected up to x = 2.9 m; the detectors observe x < 3 m only. Its track coasts
    on to x ~ 3.1 m: with ``observed_tracks_only`` it is left out of the tracks (and stays alive with its id),
    without it it is reported; a track with a hit is reported wherever it is."""
    gx, _ = SPEC.cell_centres()
    observed = gx < 3.0
    pt = make(observed_tracks_only=only)
    for k in range(20):
        out = pt.step(people_at((1.0 + 0.1 * k, 0.0)), belief(), SPEC, DT, observed=observed)
    assert len(out.tracks) == 1
    tid = out.tracks[0].id
    miss = pt.step(people_at(), belief(), SPEC, DT, observed=observed)
    assert [t.id for t in pt.tracker.tracks if t.confirmed] == [tid]  # alive either way
    assert len(miss.tracks) == (0 if only else 1)
    # seen again (a hit) outside the observed cells: reported, with its id
    again = pt.step(people_at((3.15, 0.0)), belief(), SPEC, DT, observed=observed)
    assert [t.id for t in again.tracks] == [tid]
    # without an observed mask nothing is left out
    pt2 = make(observed_tracks_only=only)
    for k in range(20):
        pt2.step(people_at((1.0 + 0.1 * k, 0.0)), belief(), SPEC, DT)
    assert len(pt2.step(people_at(), belief(), SPEC, DT).tracks) == 1


def test_observed_tracks_only_setting() -> None:
    rec = build_people_tracker(TrackingConfig(), PeakClassifier(threshold=0.7))
    paper = build_people_tracker(paper_tracking(), PeakClassifier(threshold=0.7))
    off = build_people_tracker(TrackingConfig(observed_tracks_only=False), PeakClassifier(threshold=0.7))
    assert rec.observed_tracks_only and not paper.observed_tracks_only and not off.observed_tracks_only
    cfg = config_from_mapping(
        {
            "frames": {"driver": "/scan"},
            "tracking": {"observed_tracks_only": False},
            "detectors": [{"name": "a", "kind": "leg", "topic": "/scan"}],
        }
    )
    assert cfg.tracking.observed_tracks_only is False and config_from_mapping(cfg.to_dict()) == cfg
    with pytest.raises(ValueError, match=r"\[tracking\] observed_tracks_only: must be a valid boolean"):
        TrackingConfig(observed_tracks_only="yes")  # type: ignore[arg-type]


def test_in_observed_of_a_few_positions_is_the_grid_lookup() -> None:
    """_in_observed of up to 8 positions (Python floats) against the grid's vectorised lookup of more."""
    from gridbridge.grid import GridSpec
    from pfpeople.track.reported_people import _in_observed

    spec = GridSpec(nx=7, ny=5, resolution=0.3, x0=-1.05, y0=-0.75)
    rng = np.random.default_rng(4)
    edges = [spec.x0, spec.x1, np.nextafter(spec.x1, -np.inf), spec.y0, spec.y1, np.nextafter(spec.y1, -np.inf)]
    for t in range(300):
        observed = rng.random(spec.shape) < 0.5 if t % 4 else None
        pts = rng.uniform(-1.5, 1.5, (9, 2))
        pts[rng.random((9, 2)) < 0.2] = rng.choice(edges)
        want = _in_observed(pts, spec, observed)  # 9: the vectorised lookup
        for k in range(9):
            assert _in_observed(pts[:k], spec, observed).tolist() == want[:k].tolist(), t
