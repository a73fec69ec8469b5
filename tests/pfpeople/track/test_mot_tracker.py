"""The multi-person tracker (pfpeople.track) on hand-made sequences with known answers, and its input checks."""

from __future__ import annotations

import math

import numpy as np
import pytest
from filterpy.common import Q_continuous_white_noise
from filterpy.kalman import KalmanFilter

from pfpeople.sensors import Pose2D
from pfpeople.track import TRACK_COLUMNS, MultiPersonTracker, Track, TrackerConfig, track_rows

DT = 0.1


def _ids_near(tracks: list[Track], points: np.ndarray, radius: float = 0.5) -> list[int | None]:
    """Id of the confirmed track nearest each point (None when none within radius)."""
    out: list[int | None] = []
    for p in points:
        best, best_d = None, radius
        for t in tracks:
            d = math.hypot(t.x - p[0], t.y - p[1])
            if d < best_d:
                best, best_d = t.id, d
        out.append(best)
    return out


def test_single_walker_velocity_and_confirmation() -> None:
    tracker = MultiPersonTracker()
    out = []
    for k in range(30):
        out = tracker.update(np.array([[2.0 + 1.0 * DT * k, 1.0 - 0.5 * DT * k]]), DT)
        if k < 2:
            assert out == []  # tentative: 3 of 5 hits needed
        else:
            assert len(out) == 1
    (t,) = out
    assert t.id == 1 and t.confirmed and t.hits == 30 and t.misses == 0 and t.age == 30
    assert t.vx == pytest.approx(1.0, abs=0.02) and t.vy == pytest.approx(-0.5, abs=0.02)
    assert t.x == pytest.approx(2.0 + 2.9, abs=0.02)
    assert 0.99 < t.score <= 1.0
    assert t.covariance.shape == (4, 4) and np.allclose(t.covariance, t.covariance.T)


def test_equations_match_filterpy() -> None:
    """Predict/update equal filterpy's KalmanFilter with the same F, Q, H, R (Q as Q_continuous_white_noise)."""
    cfg = TrackerConfig(confirm_hits=1, confirm_window=1)
    tracker = MultiPersonTracker(cfg)
    rng = np.random.default_rng(3)
    zs = np.column_stack((np.linspace(1, 3, 12), np.linspace(-1, 0.5, 12))) + rng.normal(0, 0.1, (12, 2))
    dts = rng.uniform(0.03, 0.15, 12)
    kf = KalmanFilter(dim_x=4, dim_z=2)
    kf.x = np.array([zs[0, 0], zs[0, 1], 0.0, 0.0])
    kf.P = np.diag([cfg.measurement_sigma**2] * 2 + [cfg.initial_velocity_sigma**2] * 2)
    kf.H = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]])
    kf.R = cfg.measurement_sigma**2 * np.eye(2)
    tracker.update(zs[:1], DT)
    for z, dt in zip(zs[1:], dts[1:], strict=True):
        kf.F = np.array([[1, 0, dt, 0], [0, 1, 0, dt], [0, 0, 1, 0], [0, 0, 0, 1.0]])
        q1 = Q_continuous_white_noise(dim=2, dt=dt, spectral_density=cfg.process_noise)  # [pos, vel] per axis
        kf.Q = np.kron(q1, np.eye(2))  # -> order (x, y, vx, vy)
        kf.predict()
        kf.update(z)
        (t,) = tracker.update(z[None, :], float(dt))
        np.testing.assert_allclose([t.x, t.y, t.vx, t.vy], kf.x, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(t.covariance, kf.P, rtol=1e-9, atol=1e-12)


def test_two_people_crossing_keep_ids() -> None:
    """Two people walking at 1.2 m/s cross at right angles through the same point; ids stay with people."""
    rng = np.random.default_rng(0)
    tracker = MultiPersonTracker()
    start_ids = None
    for k in range(60):
        t = k * DT
        u = 1.2 * (t - 3.0) / math.sqrt(2)  # both pass (4, 0) at t = 3 s
        a = np.array([4.0 + u, u])
        b = np.array([4.0 + u, -u])
        people = np.array([a, b])
        out = tracker.update(people + rng.normal(0, 0.05, (2, 2)), DT)
        if k == 10:
            start_ids = _ids_near(out, people)
            assert None not in start_ids and start_ids[0] != start_ids[1]
        if k > 10 and np.linalg.norm(a - b) > 0.4:  # not at the crossing point itself
            assert _ids_near(out, people) == start_ids, f"frame {k}"
    assert len({t.id for t in tracker.tracks}) == 2


def test_pair_walking_side_by_side_keeps_ids() -> None:
    """Two people 0.5 m apart walking in parallel at 1.0 m/s with 0.07 m noise keep distinct, stable ids."""
    rng = np.random.default_rng(1)
    tracker = MultiPersonTracker()
    ids = None
    for k in range(80):
        x = 1.0 + 0.08 * k
        people = np.array([[x, 0.25], [x, -0.25]])
        out = tracker.update(people + rng.normal(0, 0.07, (2, 2)), DT)
        if k == 5:
            ids = _ids_near(out, people, radius=0.25)
        elif k > 5:
            assert _ids_near(out, people, radius=0.25) == ids, f"frame {k}"
    assert ids is not None and None not in ids and len(set(ids)) == 2


@pytest.mark.parametrize("hidden", [5, 10])
def test_hidden_person_coasts_and_keeps_id(hidden: int) -> None:
    """A walker unseen for N frames (<= report_coast_s) keeps the id and is reported while coasting."""
    tracker = MultiPersonTracker()
    for k in range(10):
        tracker.update(np.array([[1.0 + 0.1 * k, 0.0]]), DT)
    (first,) = tracker.confirmed()
    for k in range(10, 10 + hidden):
        (t,) = tracker.update(np.zeros((0, 2)), DT)
        assert t.id == first.id and t.misses == k - 9
        assert t.x == pytest.approx(1.0 + 0.1 * k, abs=0.1)  # predicted with its velocity
    scores = [t.score for t in tracker.tracks]
    assert scores[0] < first.score  # confidence decays while coasting
    out = tracker.update(np.array([[1.0 + 0.1 * (10 + hidden), 0.0]]), DT)
    assert [t.id for t in out] == [first.id] and out[0].misses == 0


def test_long_occlusion_keeps_id() -> None:
    """Hidden for 3 s (default max_coast_s 5 s): not reported after 1 s of coasting, same id when seen again."""
    tracker = MultiPersonTracker()
    for k in range(10):
        tracker.update(np.array([[2.0, 0.1 * k]]), DT)
    reported = [len(tracker.update(np.zeros((0, 2)), DT)) for _ in range(30)]
    assert reported == [1] * 10 + [0] * 20
    assert [t.id for t in tracker.update(np.array([[2.0, 1.0 + 0.1 * 31]]), DT)] == [1]


def test_coasting_ends_after_max_coast() -> None:
    cfg = TrackerConfig(max_coast_s=0.5)
    tracker = MultiPersonTracker(cfg)
    for _ in range(5):
        tracker.update(np.array([[2.0, 0.0]]), DT)
    for _ in range(5):  # 0.5 s: still there
        assert len(tracker.update(np.zeros((0, 2)), DT)) == 1
    assert tracker.update(np.zeros((0, 2)), DT) == []  # 0.6 s > max_coast_s
    assert tracker.tracks == []
    out = []
    for _ in range(3):
        out = tracker.update(np.array([[2.0, 0.0]]), DT)
    assert [t.id for t in out] == [2]  # a new id, never reused


def test_static_false_positive_seen_once_never_confirmed() -> None:
    tracker = MultiPersonTracker()
    person = np.array([[3.0, 0.0]])
    confirmed_ids: set[int] = set()
    for k in range(20):
        z = np.vstack([person, [[5.0, 2.0]]]) if k == 7 else person
        confirmed_ids |= {t.id for t in tracker.update(z, DT)}
        if k == 7:
            assert len(tracker.tracks) == 2 and not tracker.tracks[1].confirmed
    assert confirmed_ids == {1}
    assert [t.id for t in tracker.tracks] == [1]  # the tentative one was deleted


def test_clutter_below_birth_score_starts_nothing() -> None:
    tracker = MultiPersonTracker(TrackerConfig(birth_min_score=0.5))
    for _ in range(5):
        tracker.update(np.array([[2.0, 0.0], [4.0, 1.0]]), DT, scores=np.array([0.9, 0.3]))
    assert [(round(t.x, 3), round(t.y, 3)) for t in tracker.confirmed()] == [(2.0, 0.0)]


def test_track_born_at_grid_border() -> None:
    """A person entering the default grid (x in [0, 9], y in [-4.5, 4.5]) at its left border: confirmed after 3
    frames with the right velocity; leaving the region deletes it."""
    tracker = MultiPersonTracker(TrackerConfig(region=(0.0, 9.0, -4.5, 4.5), region_margin=0.3))
    out = []
    for k in range(25):
        out = tracker.update(np.array([[4.0, 4.45 - 0.12 * k]]), DT)
        if k == 2:
            assert len(out) == 1 and out[0].y == pytest.approx(4.45 - 0.24, abs=0.1)
    assert out[0].vy == pytest.approx(-1.2, abs=0.05)
    # walks out at the right border (y = -4.5) and beyond: unseen, coasting out of the region -> deleted
    for k in range(25, 90):
        y = 4.45 - 0.12 * k
        out = tracker.update(np.array([[4.0, y]]) if y > -4.5 else np.zeros((0, 2)), DT)
    assert out == [] and tracker.tracks == []


def test_ego_motion_static_person_turning_robot() -> None:
    """A person standing at (3, 1) in the world, seen from a robot driving a curve: one id, ~zero velocity."""
    rng = np.random.default_rng(5)
    tracker = MultiPersonTracker()
    world = np.array([3.0, 1.0])
    pose = Pose2D()  # robot (sensor) pose in the world
    step = Pose2D(x=0.03, y=0.0, yaw=0.05)  # 0.3 m/s, 0.5 rad/s
    ids = set()
    out: list[Track] = []
    for k in range(50):
        if k:
            pose = pose.compose(step)
        seen = pose.inverse().apply(world[None, :]) + rng.normal(0, 0.03, (1, 2))
        out = tracker.update(seen, DT, ego=step if k else None)
        ids |= {t.id for t in out}
    assert ids == {1}
    (t,) = out
    assert math.hypot(t.vx, t.vy) < 0.15
    truth = pose.inverse().apply(world[None, :])[0]
    assert math.hypot(t.x - truth[0], t.y - truth[1]) < 0.1


def test_ego_motion_rotates_state_and_covariance() -> None:
    tracker = MultiPersonTracker(TrackerConfig(confirm_hits=1, confirm_window=1, process_noise=1e-12))
    tracker.update(np.array([[2.0, 0.0]]), DT)
    tracker._s[0, 2:] = [1.0, 0.0]  # a walker moving along +x
    p_before = tracker._p[0].copy()
    yaw = math.pi / 2
    (t,) = tracker.update(np.zeros((0, 2)), 1e-9, ego=Pose2D(x=1.0, y=0.0, yaw=yaw))
    # new frame: origin at old (1, 0), rotated +90 deg: old (2, 0) -> (0, -1); velocity +x -> -y
    assert (t.x, t.y) == pytest.approx((0.0, -1.0), abs=1e-6)
    assert (t.vx, t.vy) == pytest.approx((0.0, -1.0), abs=1e-6)
    b = np.zeros((4, 4))
    r = np.array([[math.cos(-yaw), -math.sin(-yaw)], [math.sin(-yaw), math.cos(-yaw)]])
    b[:2, :2] = b[2:, 2:] = r
    np.testing.assert_allclose(t.covariance, b @ p_before @ b.T, atol=1e-6)


def test_empty_frames_and_reset() -> None:
    tracker = MultiPersonTracker()
    assert tracker.update(np.zeros((0, 2)), DT) == []
    assert tracker.update([], DT) == []
    for _ in range(3):
        tracker.update([[1.0, 1.0]], DT)
    assert [t.id for t in tracker.confirmed()] == [1]
    tracker.reset()
    assert tracker.tracks == []
    for _ in range(3):
        out = tracker.update([[1.0, 1.0]], DT)
    assert [t.id for t in out] == [2]


@pytest.mark.parametrize(
    ("positions", "match"),
    [
        ([[1.0, math.nan]], "positions"),
        ([[1.0, math.inf]], "positions"),
        ([1.0, 2.0, 3.0], r"positions must have shape \(M, 2\)"),
        ([[1.0, 2.0, 3.0]], r"positions must have shape \(M, 2\)"),
        (np.zeros((2, 2, 2)), r"positions must have shape \(M, 2\)"),
    ],
)
def test_bad_positions(positions: object, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        MultiPersonTracker().update(positions, DT)  # type: ignore[arg-type]


@pytest.mark.parametrize("dt", [0.0, -0.1, math.nan, math.inf])
def test_bad_dt(dt: float) -> None:
    tracker = MultiPersonTracker()
    tracker.update([[1.0, 1.0]], DT)
    with pytest.raises(ValueError, match=r"dt must be (finite|a number > 0)"):
        tracker.update([[1.0, 1.0]], dt)
    assert tracker.tracks[0].age == 1  # nothing changed


def test_bad_scores_and_ego() -> None:
    tracker = MultiPersonTracker()
    with pytest.raises(ValueError, match="scores must have shape"):
        tracker.update([[1.0, 1.0]], DT, scores=[0.5, 0.5])
    with pytest.raises(ValueError, match="scores must be finite and in"):
        tracker.update([[1.0, 1.0]], DT, scores=[1.5])
    with pytest.raises(TypeError, match="ego must be"):
        tracker.update([[1.0, 1.0]], DT, ego=(0.0, 0.0, 0.0))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="ego must be finite"):
        tracker.update([[1.0, 1.0]], DT, ego=Pose2D(x=math.nan))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"process_noise": 0.0}, "process_noise"),
        ({"gate_distance": -1.0}, "gate_distance"),
        ({"max_coast_s": math.nan}, "max_coast_s"),
        ({"confirm_hits": 4, "confirm_window": 3}, "confirm_hits"),
        ({"confirm_hits": 0}, "confirm_hits"),
        ({"delete_score": 1.0}, "delete_score"),
        ({"hit_gain": 0.0}, "hit_gain"),
        ({"region": (1.0, 0.0, -1.0, 1.0)}, "region"),
        ({"report_coast_s": -1.0}, "report_coast_s"),
        ({"revive_after_s": math.inf}, "revive_after_s"),
        ({"contest_gate": -1.0}, "contest_gate"),
        ({"contest_radius": 0.0}, "contest_radius"),
    ],
)
def test_config_validation(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        TrackerConfig(**kwargs)  # type: ignore[arg-type]


def test_config_types() -> None:
    with pytest.raises(TypeError, match="confirm_window"):
        TrackerConfig(confirm_window=2.5)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="config must be a TrackerConfig"):
        MultiPersonTracker({"gate_distance": 1.0})  # type: ignore[arg-type]


def test_track_rows() -> None:
    tracker = MultiPersonTracker(TrackerConfig(confirm_hits=1, confirm_window=1))
    tracks = tracker.update([[1.0, 2.0], [3.0, -1.0]], DT)
    rows = track_rows(7, 123_000_000, tracks)
    assert len(rows) == 2 and all(len(r) == len(TRACK_COLUMNS) for r in rows)
    row = dict(zip(TRACK_COLUMNS, rows[1], strict=True))
    assert row["frame"] == 7 and row["stamp_ns"] == 123_000_000 and row["id"] == 2
    assert (row["x"], row["y"], row["vx"], row["vy"]) == (3.0, -1.0, 0.0, 0.0)
    assert row["cov_xx"] == pytest.approx(0.15**2) and row["cov_xy"] == 0.0
    assert row["score"] == pytest.approx(0.4)
    assert track_rows(0, 0, []) == []


def test_report_coast_hides_long_coasting_but_keeps_id() -> None:
    tracker = MultiPersonTracker(TrackerConfig(max_coast_s=3.0, report_coast_s=0.3))
    for _ in range(5):
        tracker.update([[2.0, 1.0]], DT)
    reported = [len(tracker.update(np.zeros((0, 2)), DT)) for _ in range(10)]
    assert reported == [1, 1, 1] + [0] * 7  # 0.1, 0.2, 0.3 s reported; then alive but hidden
    assert [t.id for t in tracker.tracks] == [1] and tracker.tracks[0].misses == 10
    assert [t.id for t in tracker.update([[2.0, 1.0]], DT)] == [1]


@pytest.mark.parametrize(
    ("coast_frames", "revive_after_s", "reported"),
    [
        (30, 2.5, [False, False, True]),  # lost after 3 s: the weak hits do not show it, a person-grade one does
        (20, 2.5, [True, True, True]),  # 2 s is not lost: any hit shows it again
        (30, None, [True, True, True]),  # None: any hit
    ],
)
def test_lost_track_revived_only_by_a_birth_grade_hit(
    coast_frames: int, revive_after_s: float | None, reported: list[bool]
) -> None:
    """A track coasting longer than revive_after_s is shown again only after a hit of confidence >=
    birth_min_score (0.7 here); hits of 0.6 update it (it keeps its id and position) unreported."""
    cfg = TrackerConfig(birth_min_score=0.7, revive_after_s=revive_after_s, max_coast_s=8.0, delete_score=0.01)
    tracker = MultiPersonTracker(cfg)
    for _ in range(5):
        tracker.update([[2.0, 1.0]], DT, scores=[0.9])
    for _ in range(coast_frames):
        assert len(tracker.update(np.zeros((0, 2)), DT)) <= 1
    shown = [bool(tracker.update([[2.0, 1.1]], DT, scores=[s])) for s in (0.6, 0.6, 0.9)]
    assert shown == reported
    (t,) = tracker.tracks
    assert t.id == 1 and t.misses == 0 and t.hits == 8 and t.y == pytest.approx(1.1, abs=0.05)


@pytest.mark.parametrize(("contest_gate", "hop"), [(0.75, False), (None, True)])
def test_coasting_track_does_not_take_a_contested_detection(contest_gate: float | None, hop: bool) -> None:
    """A (confirmed, standing at (2, 0)) is missed for 0.6 s (its gate has grown past 0.95 m); B appears 1.1 m
    away (outside A's 1 m gate: a tentative track) and steps to 0.95 m from A. With the contest rule A, coasting,
    may not take B's detection (B's own track is 0.15 m from it) and B keeps its track; without it A, a confirmed
    track, takes it from B's tentative track: A's id jumps onto B. (Without re-identification, which would give B
    A's id when B is confirmed: that is a separate rule.)"""
    tracker = MultiPersonTracker(TrackerConfig(contest_gate=contest_gate, reid_distance=0.0))
    for _ in range(5):
        tracker.update([[2.0, 0.0]], DT)
    (a,) = tracker.confirmed()
    for _ in range(5):
        tracker.update(np.zeros((0, 2)), DT)  # A missed
    tracker.update([[2.0, 1.1]], DT)  # A missed; B born (tentative)
    for _ in range(4):
        out = tracker.update([[2.0, 0.95]], DT)  # A missed again; B near its track
    on_b = [t.id for t in tracker.tracks if math.hypot(t.x - 2.0, t.y - 0.95) < 0.2]
    assert (a.id in on_b) is hop
    if not hop:
        (b,) = [t for t in out if t.id != a.id]
        assert b.confirmed and b.hits == 5 and math.hypot(b.x - 2.0, b.y - 0.95) < 0.1


def test_advance_and_one_snapshot_give_update_and_tracks() -> None:
    """advance + confirmed_and_live: the same tracks as update + tracks, frame by frame (confirmed, tentative,
    coasting and deleted tracks, support hits, ego-motion)."""
    cfg = TrackerConfig(report_coast_s=0.25)
    a, b = MultiPersonTracker(cfg), MultiPersonTracker(cfg)
    rng = np.random.default_rng(3)
    for k in range(60):
        z = np.array([[1.0 + 0.1 * k, 0.5], [3.0, -1.0 + 0.05 * k], [5.0 - 0.08 * k, 2.0]])[: 1 + k % 3]
        z = z + rng.normal(0.0, 0.02, z.shape)
        sup = z[:1] + 0.05 if k % 4 == 0 else None
        ego = Pose2D(x=0.02, y=0.0, yaw=0.01) if k % 2 else None
        want = a.update(z, DT, ego=ego, support=sup)
        want_live = a.tracks
        b.advance(z, DT, ego=ego, support=sup)
        got, got_live = b.confirmed_and_live()
        assert len(want_live) >= len(want) and (len(want) > 0 or k < 5)
        for x, y in ((want, got), (want_live, got_live)):
            assert [(t.id, t.x, t.y, t.vx, t.vy, t.score, t.misses) for t in x] == [
                (t.id, t.x, t.y, t.vx, t.vy, t.score, t.misses) for t in y
            ]
            assert all(np.array_equal(s.covariance, t.covariance) for s, t in zip(x, y, strict=True))
        assert all(any(t is u for u in got_live) for t in got)


def _confirmed_at(cfg: TrackerConfig, hits: list[float | None]) -> int | None:
    """The frame (from 0) at which one standing person's track is first confirmed, given each frame's confidence of
    a detection at (2, 0) (None: no detection); None if never."""
    tracker = MultiPersonTracker(cfg)
    for k, c in enumerate(hits):
        z = np.zeros((0, 2)) if c is None else np.array([[2.0, 0.0]])
        out = tracker.update(z, DT, scores=None if c is None else [c])
        if out:
            return k
    return None


def test_confirmation_by_evidence_hand_values() -> None:
    """With ``confirm_evidence`` a track is confirmed when its existence score ``r`` (step 5: ``r0 = g c``, a hit
    ``r += g c (1 - r)``, a miss ``r *= exp(-dt / tau)``) reaches it: two confident hits, three ordinary ones, and a
    person detected every other scan, whom M of N (3 of 5) confirms two frames later."""
    by_score = TrackerConfig(confirm_evidence=0.6)
    m_of_n = TrackerConfig()
    g, decay = by_score.hit_gain, math.exp(-DT / by_score.score_tau)
    r2 = g * 0.99 + g * 0.99 * (1 - g * 0.99)
    assert r2 >= 0.6
    assert _confirmed_at(by_score, [0.99, 0.99, 0.99]) == 1
    assert _confirmed_at(m_of_n, [0.99, 0.99, 0.99]) == 2
    r = g * 0.7
    r += g * 0.7 * (1 - r)
    assert r < 0.6 and r + g * 0.7 * (1 - r) >= 0.6
    assert _confirmed_at(by_score, [0.7, 0.7, 0.7]) == 2
    r = g * 0.99 * decay
    assert r + g * 0.99 * (1 - r) >= 0.6
    every_other = [0.99, None, 0.99, None, 0.99, None, 0.99]
    assert _confirmed_at(by_score, every_other) == 2
    assert _confirmed_at(m_of_n, every_other) == 4
    assert _confirmed_at(by_score, [0.99, None, None, 0.99]) is None  # two misses in a row end a tentative track
    assert _confirmed_at(by_score, [0.99]) is None  # one hit never confirms
    weak = [0.55] * 12  # sustained weak evidence confirms, later than strong
    assert _confirmed_at(by_score, weak) == 3


def test_confirm_evidence_validation() -> None:
    with pytest.raises(ValueError, match=r"confirm_evidence.*exceed hit_gain"):
        TrackerConfig(confirm_evidence=0.4)
    with pytest.raises(ValueError, match="confirm_evidence"):
        TrackerConfig(confirm_evidence=1.0)
    assert TrackerConfig(confirm_evidence=0.6, confirm_hits=1, confirm_window=1).confirm_evidence == 0.6
    tracker = MultiPersonTracker(TrackerConfig(confirm_evidence=0.6, confirm_hits=1, confirm_window=1))
    assert tracker.update(np.array([[2.0, 0.0]]), DT) == []  # M of N is not used: one hit is not enough
