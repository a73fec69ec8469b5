"""pfpeople.recommended: the recommended filter, classifier and tracker in one object, as a run builds them."""

from __future__ import annotations

import numpy as np
import pytest

import pfpeople
from gridbridge import GridFilter, GridSpec, Odometry
from gridbridge.classifiers import classify_frame
from gridbridge.ego_motion import odometry_pose
from gridbridge.params import CALIBRATED_LASER_DETECTORS, DetectorModel
from pfpeople.config import ClassifierConfig, FilterConfig, TrackingConfig
from pfpeople.pipeline.assembly import build_classifier, build_filter, build_people_tracker

STANDING = [np.array([[3.0, 0.45]]), np.array([[3.05, 0.4]]), np.zeros((0, 2))]


def test_defaults_are_the_grid_filter_on_the_calibrated_laser_detectors() -> None:
    rec = pfpeople.recommended()
    assert isinstance(rec.filter, GridFilter)
    assert rec.spec == GridSpec()
    assert [m.name for m in rec.filter.detectors] == [m.name for m in CALIBRATED_LASER_DETECTORS]
    assert [m.ppv for m in rec.filter.detectors] == [m.ppv for m in CALIBRATED_LASER_DETECTORS]
    assert isinstance(pfpeople.recommended(kind="particle").filter, pfpeople.ParticleFilter)


@pytest.mark.parametrize("kind", ["grid", "particle"])
def test_step_is_the_runs_filter_classifier_and_tracker(kind: str) -> None:
    """The same stages built by hand from pfpeople.pipeline.assembly give the same belief, people and tracks."""
    rec = pfpeople.recommended(kind=kind, seed=3)
    spec = GridSpec()
    flt = build_filter(FilterConfig(kind=kind, seed=3), spec, CALIBRATED_LASER_DETECTORS)
    cls = build_classifier(ClassifierConfig())
    trk = build_people_tracker(TrackingConfig(), cls)
    assert trk is not None
    odo = Odometry(v=0.3, omega=0.1)
    for k in range(15):
        dets = [d + np.array([-0.03 * k, 0.0]) for d in STANDING]
        frame = rec.step(dets, odo, dt=0.1)
        out = flt.step(dets, odo, 0.1)
        observed = np.asarray(out.covered).any(axis=0)
        ego = odometry_pose(odo, 0.1)
        found = classify_frame(cls, out.posterior, spec, observed=observed, ego=ego)
        tracked = trk.step(found, out.posterior, spec, 0.1, observed=observed, ego=ego)
        np.testing.assert_array_equal(frame.belief, out.posterior)
        np.testing.assert_array_equal(frame.people.positions, tracked.people.positions)
        assert [(t.id, t.x, t.y) for t in frame.tracks] == [(t.id, t.x, t.y) for t in tracked.tracks]


def test_a_standing_person_is_reported_and_tracked_after_a_second() -> None:
    rec = pfpeople.recommended()
    for _ in range(15):
        frame = rec.step(STANDING, None, dt=0.1)
    assert len(frame.people) == 1
    assert np.hypot(*(frame.people.positions[0] - [3.0, 0.45])) < 0.2
    (track,) = frame.tracks
    assert np.hypot(track.vx, track.vy) < 0.2  # m/s: standing
    rec.reset()
    frame = rec.step([np.zeros((0, 2))] * 3, None, dt=0.1)
    assert len(frame.people) == 0 and frame.tracks == []
    assert float(frame.belief.max()) < 0.1


def test_own_detectors_set_the_order_of_the_detections() -> None:
    camera = DetectorModel(name="my-camera", ppv=0.8, fnr=0.4)
    rec = pfpeople.recommended(detectors=[camera])
    for _ in range(15):
        frame = rec.step([np.array([[2.0, -0.5]])], dt=0.1)
    assert len(frame.people) == 1
    with pytest.raises(ValueError, match="one entry per detector"):
        rec.step(STANDING, dt=0.1)


def test_an_unknown_kind_is_refused() -> None:
    with pytest.raises(ValueError, match=r"\[filter\] kind: must be 'grid' or 'particle', got 'kalman'"):
        pfpeople.recommended(kind="kalman")  # type: ignore[arg-type]
