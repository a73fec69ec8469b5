"""People who walked and stopped (pfpeople.track.stopped_people): anchors, readmission, ego-motion, forgetting."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pfpeople.sensors import Pose2D
from pfpeople.track import MultiPersonTracker, Track
from pfpeople.track.stopped_people import ANCHOR_RADIUS, WALKING_MPS, StoppedPeople


def _track(tid: int, x: float, y: float, speed: float = 0.0, *, confirmed: bool = True, moved: bool = True) -> Track:
    return Track(
        id=tid,
        x=x,
        y=y,
        vx=speed,
        vy=0.0,
        covariance=np.eye(4),
        score=1.0,
        hits=5,
        misses=0,
        age=5,
        confirmed=confirmed,
        moved=moved,
    )


def _near(x: float, y: float) -> np.ndarray:
    return np.array([[x + 0.05, y - 0.05]])


def test_a_walker_that_stops_is_anchored_and_its_static_detections_readmitted() -> None:
    sp = StoppedPeople()
    sp.update([_track(1, 2.0, 1.0, speed=1.2)], _near(2.0, 1.0))  # walks, a let-through detection beside it
    assert len(sp) == 1 and sp.anchors.shape == (0, 2)  # anchored (rule 1), not stopped
    assert not sp.readmit(np.array([[2.0, 1.0]])).any()
    sp.update([_track(1, 2.1, 1.0, speed=0.1)], _near(2.1, 1.0))  # slows 0.1 m on, still let through: stopped
    np.testing.assert_array_equal(sp.anchors, [[2.1, 1.0]])
    sp.update([_track(1, 2.1, 1.0, speed=0.0)], np.zeros((0, 2)))  # the map now calls it static: nothing let through
    np.testing.assert_array_equal(sp.anchors, [[2.1, 1.0]])
    static = np.array([[2.1, 1.0 + ANCHOR_RADIUS - 0.01], [2.1, 1.0 + ANCHOR_RADIUS + 0.01], [5.0, 5.0]])
    assert sp.readmit(static).tolist() == [True, False, False]
    sp.update([_track(1, 2.1, 1.0, speed=1.0)], _near(2.1, 1.0))  # walks off again: no longer stopped
    assert sp.anchors.shape == (0, 2)


@pytest.mark.parametrize(
    ("speed", "confirmed", "moved"),
    [(WALKING_MPS - 0.01, True, True), (1.0, False, True), (1.0, True, False)],
    ids=["too slow", "unconfirmed", "never moved"],
)
def test_a_track_that_does_not_walk_is_never_anchored(speed: float, confirmed: bool, moved: bool) -> None:
    sp = StoppedPeople()
    for _ in range(10):
        sp.update([_track(1, 1.0, 1.0, speed, confirmed=confirmed, moved=moved)], _near(1.0, 1.0))
    sp.update([_track(1, 1.0, 1.0, 0.0)], _near(1.0, 1.0))
    assert len(sp) == 0 and not sp.readmit(np.array([[1.0, 1.0]])).any()


def test_a_walking_track_without_a_let_through_detection_is_not_anchored() -> None:
    sp = StoppedPeople()
    sp.update([_track(1, 1.0, 1.0, speed=1.0)], np.array([[1.0, 1.0 + ANCHOR_RADIUS + 0.05]]))
    assert len(sp) == 0


def test_a_track_handed_over_to_a_pillar_never_stops() -> None:
    """A walker's track that slows down on an object whose detections the map suppresses (none let through) does
    not stop there; one that slows 1 m from its anchor cannot move it."""
    sp = StoppedPeople()
    sp.update([_track(1, 0.0, 0.0, speed=1.0)], _near(0.0, 0.0))
    for _ in range(5):
        sp.update([_track(1, 0.1, 0.0, speed=0.2)], np.zeros((0, 2)))  # on the pillar: its detections are static
    assert len(sp) == 1 and sp.anchors.shape == (0, 2) and not sp.readmit(np.array([[0.1, 0.0]])).any()
    for _ in range(5):
        sp.update([_track(1, 1.0, 0.0, speed=0.2)], _near(1.0, 0.0))
    assert sp.anchors.shape == (0, 2) and not sp.readmit(np.array([[1.0, 0.0], [0.1, 0.0]])).any()


def _stopped(sp: StoppedPeople, tid: int, x: float, y: float) -> None:
    """Walk track ``tid`` to ``(x, y)`` and stop it there."""
    sp.update([_track(tid, x, y, 1.0)], _near(x, y))
    sp.update([_track(tid, x, y, 0.0)], _near(x, y))


def test_anchors_are_forgotten_with_their_track_and_on_reset() -> None:
    sp = StoppedPeople()
    sp.update([_track(1, 0.0, 0.0, 1.0), _track(2, 3.0, 0.0, 1.0)], np.array([[0.0, 0.0], [3.0, 0.0]]))
    sp.update([_track(1, 0.0, 0.0, 0.0), _track(2, 3.0, 0.0, 0.0)], np.array([[0.0, 0.0], [3.0, 0.0]]))
    np.testing.assert_array_equal(sp.anchors, [[0.0, 0.0], [3.0, 0.0]])
    sp.update([_track(2, 3.0, 0.0, 0.0)], np.zeros((0, 2)))  # track 1 gone
    np.testing.assert_array_equal(sp.anchors, [[3.0, 0.0]])
    sp.reset()
    assert len(sp) == 0 and sp.readmit(np.array([[3.0, 0.0]])).tolist() == [False]


def test_anchors_move_with_the_ego_motion_as_the_tracker_moves_its_tracks() -> None:
    """Reference: the multi-person tracker's own ego-motion of a standing track (zero velocity, no prediction)."""
    ego = Pose2D(x=0.4, y=-0.2, yaw=math.radians(25.0))
    tracker = MultiPersonTracker()
    tracker.update(np.array([[2.0, 1.0]]), 0.1)
    tracker.update(np.zeros((0, 2)), 1e-9, ego=ego)  # move it into the new frame (the prediction: 1e-9 s at 0 m/s)
    (moved,) = tracker.tracks
    sp = StoppedPeople()
    _stopped(sp, 7, 2.0, 1.0)
    sp.move(ego)
    np.testing.assert_allclose(sp.anchors, [[moved.x, moved.y]], atol=1e-12)
    c, s = math.cos(ego.yaw), math.sin(ego.yaw)  # by hand: R(-yaw) (p - t)
    np.testing.assert_allclose(sp.anchors, [[c * 1.6 + s * 1.2, -s * 1.6 + c * 1.2]], atol=1e-12)
    sp.move(None)
    np.testing.assert_allclose(sp.anchors, [[moved.x, moved.y]], atol=1e-12)


def test_readmit_of_no_detections_and_without_anchors() -> None:
    sp = StoppedPeople()
    assert sp.readmit(np.zeros((0, 2))).shape == (0,)
    assert sp.readmit(np.array([[0.0, 0.0]])).tolist() == [False]
