"""Re-identification of lost tracks (``TrackerConfig.reid_distance``, step 6b of pfpeople.track.multi_person)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pfpeople.track import MultiPersonTracker, TrackerConfig

DT = 0.1
NONE = np.zeros((0, 2))


def _walk_then_stop(tracker: MultiPersonTracker, hidden: int = 15) -> list[int]:
    """A walker at 1 m/s along x for 1 s, hidden for ``hidden`` frames in which it stops at x = 2 m, then seen
    standing there for 5 frames. Returns the reported ids of the last frame."""
    for k in range(10):
        tracker.update(np.array([[1.0 + 0.1 * k, 0.0]]), DT)
    for _ in range(hidden):
        tracker.update(NONE, DT)
    out = []
    for _ in range(5):
        out = tracker.update(np.array([[2.0, 0.0]]), DT)
    return [t.id for t in out]


def test_lost_walker_takes_its_id_back() -> None:
    """Hidden 1.5 s while stopping: the constant-velocity prediction runs 1.4 m past the person, beyond the
    1 m association gate; the new track confirmed there takes the lost track's id."""
    assert _walk_then_stop(MultiPersonTracker(TrackerConfig(reid_distance=0.0))) == [2]  # without: a new id
    tracker = MultiPersonTracker()  # the default: re-identification within 2.5 m
    assert _walk_then_stop(tracker) == [1]
    assert [t.id for t in tracker.tracks] == [1]  # the lost track is gone, its id lives on
    (t,) = tracker.tracks
    assert t.moved and t.age_s == pytest.approx(2.9, abs=1e-9)  # the person's, from the first birth


def test_reid_distance_bounds_the_pairing() -> None:
    """1.4 m apart: 1.0 m is too short to pair them."""
    assert _walk_then_stop(MultiPersonTracker(TrackerConfig(reid_distance=1.0))) == [2]


def test_two_lost_people_get_their_own_ids() -> None:
    """Two walkers 2 m apart vanish and reappear stopped near where each was going: the assignment pairs each
    new track with its own lost track (either of them lies within 2.5 m of both)."""
    tracker = MultiPersonTracker(TrackerConfig(reid_distance=2.5))
    for k in range(10):
        tracker.update(np.array([[1.0 + 0.1 * k, 0.0], [1.0 + 0.1 * k, 2.0]]), DT)
    first = {round(t.y): t.id for t in tracker.confirmed()}
    for _ in range(15):
        tracker.update(NONE, DT)
    out = []
    for _ in range(5):
        out = tracker.update(np.array([[2.0, 0.3], [2.0, 1.7]]), DT)
    assert {round(t.y): t.id for t in out} == {0: first[0], 2: first[2]}


def test_a_person_seen_beside_the_lost_one_is_someone_else() -> None:
    """A track that had a hit after the new track's birth is not lost for it: two people seen at once keep
    two ids, however near."""
    tracker = MultiPersonTracker(TrackerConfig(reid_distance=3.0))
    for k in range(10):
        z = [[1.0, 0.0]] + ([[1.0, 1.5]] if k >= 8 else [])  # a second person appears at frame 8, 1.5 m away
        tracker.update(np.array(z), DT)
    out = []
    for _ in range(4):  # the first one is hidden from frame 10, the second one stays
        out = tracker.update(np.array([[1.0, 1.5]]), DT)
    assert [t.id for t in out] == [1, 2]  # the first one coasting (0.4 s), the second one confirmed


@pytest.mark.parametrize("value", [-1.0, math.nan, math.inf])
def test_reid_distance_validation(value: float) -> None:
    with pytest.raises(ValueError, match="reid_distance"):
        TrackerConfig(reid_distance=value)


_person = st.tuples(
    st.floats(min_value=-3.0, max_value=3.0),  # start x, y (m)
    st.floats(min_value=-3.0, max_value=3.0),
    st.floats(min_value=-1.5, max_value=1.5),  # velocity (m/s) until it stops
    st.floats(min_value=-1.5, max_value=1.5),
    st.integers(min_value=0, max_value=40),  # frame it stops at
    st.integers(min_value=0, max_value=40),  # first hidden frame
    st.integers(min_value=0, max_value=30),  # frames hidden
)


@settings(max_examples=40, derandomize=True, deadline=None, database=None)
@given(st.lists(_person, min_size=1, max_size=3))
def test_ids_stay_unique_and_come_from_the_counter(
    people: list[tuple[float, float, float, float, int, int, int]],
) -> None:
    """People walking, stopping and hidden at random: the live tracks' ids are distinct in every frame, and an
    id that was not live in the previous frame has never been seen (re-identification passes on only the id of
    a live track)."""
    tracker = MultiPersonTracker()
    seen: set[int] = set()
    for k in range(40):
        z = [
            (x + vx * DT * min(k, stop), y + vy * DT * min(k, stop))
            for x, y, vx, vy, stop, h0, hn in people
            if not h0 <= k < h0 + hn
        ]
        before = {t.id for t in tracker.tracks}
        tracker.update(np.array(z, dtype=float).reshape(-1, 2), DT)
        ids = [t.id for t in tracker.tracks]
        assert len(ids) == len(set(ids))
        for i in set(ids) - before:
            assert i not in seen
        seen |= set(ids)
