"""Result bags a ROS user opens as they are: every laser placed by TF, every input message, tracks with their
covariance (SPENCER's ``TrackedPersons``) and markers in per-track colours.

The synthetic run: ``bag_fixtures.write_lasers_bag`` without TF (three lasers, no /tf_static), configured with
the lasers' true mounts in ``[mounts]`` (front_laser at (0.3, 0, 0), rear_laser at (-0.3, 0, pi), side_laser at
(0, 0.2, pi/2) in base_link); the side laser's last scan is recorded 30 ms after the driver's (front) last.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from bag_fixtures import LASERS, write_lasers_bag
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from gridbridge.geometry import Pose2D
from pfpeople.cli import main
from pfpeople.io.bag.reader import BagSource
from pfpeople.io.bag.tf import TfBuffer, TfLink
from pfpeople.io.bag.track_messages import (
    LARGE_VARIANCE,
    SPENCER_MD5,
    SPENCER_MSG_DEFINITIONS,
    TRACKED_PERSONS_TYPE,
    track_colour,
    track_table,
)
from pfpeople.io.bag.writer import (
    GRID_ORIGIN_FRAME,
    MARKER_ARROW,
    MARKER_SPHERE,
    TOPIC_TRACK_MARKERS,
    TOPIC_TRACKED_PERSONS,
    ResultBagWriter,
)
from pfpeople.track.multi_person import Track

SCAN = "sensor_msgs/msg/LaserScan"
T0 = 1_700_000_000_000_000_000


def _messages(path: Path) -> tuple[dict[str, list[Any]], dict[str, Any]]:
    out: dict[str, list[Any]] = {}
    with AnyReader([path]) as r:
        conns = {c.topic: c for c in r.connections}
        for conn, t, raw in r.messages():
            out.setdefault(conn.topic, []).append((t, r.deserialize(raw, conn.msgtype)))
    return out, conns


def _config(path: Path, *, mounts: bool = True) -> Path:
    lines = ['[frames]\ndriver = "/front_scan"\nsync_tolerance_s = 0.05\n\n[mounts]']
    for frame, m, _ in LASERS.values():
        lines.append(f'"{frame}" = [{m.x}, {m.y}, {m.yaw}]' if mounts else "")
    for topic in LASERS:
        lines.append(f'\n[[detectors]]\nname = "legs_{topic[1:]}"\nkind = "leg"\ntopic = "{topic}"')
    path.write_text("\n".join(lines) + "\n")
    return path


def _tf_of(msgs: dict[str, list[Any]]) -> TfBuffer:
    tf = TfBuffer()
    for _, m in msgs.get("/tf_static", []):
        tf.add_message(m, topic="/tf_static")
    return tf


@pytest.mark.parametrize("name", ["out.bag", "out_db"])
def test_every_laser_is_placed_by_tf_and_every_input_message_is_copied(tmp_path: Path, name: str) -> None:
    bag = tmp_path / "lasers.bag"
    write_lasers_bag(bag, tf_for=())
    out = tmp_path / name
    args = ["run", str(bag), "--config", str(_config(tmp_path / "c.toml")), "--out", str(tmp_path / "run")]
    assert main([*args, "--bag-out", str(out), "--no-progress"]) == 0
    msgs, _ = _messages(out)
    with BagSource(bag) as src:
        want = src.message_counts
        last = {t: max(m.bag_time_ns for m in src.messages([t])) for t in LASERS}
    assert last["/side_scan"] > last["/front_scan"]  # recorded after the driver's last scan: it was left out
    assert {t: len(msgs[t]) for t in LASERS} == {t: want[t] for t in LASERS}
    # /tf_static places every laser: the [mounts] the run used, base_link -> laser, beside the grid origin
    tf = _tf_of(msgs)
    for frame, mount, _ in LASERS.values():
        got = tf.lookup("base_link", frame)
        assert (got.x, got.y, math.remainder(got.yaw - mount.yaw, 2 * math.pi)) == pytest.approx(
            (mount.x, mount.y, 0.0), abs=1e-9
        )
        assert tf.can_transform("front_laser", frame)  # the grid frame: every scan shows in RViz
    assert tf.parent_of(GRID_ORIGIN_FRAME) == "front_laser"


def test_a_run_stopped_early_copies_the_input_of_its_frames(tmp_path: Path) -> None:
    bag = tmp_path / "lasers.bag"
    write_lasers_bag(bag, tf_for=())
    out = tmp_path / "out.bag"
    args = ["run", str(bag), "--config", str(_config(tmp_path / "c.toml")), "--out", str(tmp_path / "run")]
    assert main([*args, "--bag-out", str(out), "--no-progress", "--max-frames", "3"]) == 0
    msgs, _ = _messages(out)
    # three frames, each with the rear and side scans 10 and 30 ms after the front's: three of each, no more
    assert {t: len(msgs[t]) for t in LASERS} == dict.fromkeys(LASERS, 3)


def test_lasers_with_tf_get_no_second_parent(tmp_path: Path) -> None:
    """With the bag's /tf_static for every laser, the result bag adds no transform but the grid origin's."""
    bag = tmp_path / "lasers.bag"
    write_lasers_bag(bag)
    out = tmp_path / "out.bag"
    args = ["run", str(bag), "--config", str(_config(tmp_path / "c.toml", mounts=False)), "--out", str(tmp_path / "r")]
    assert main([*args, "--bag-out", str(out), "--no-progress"]) == 0
    msgs, _ = _messages(out)
    ours = [m for t, m in msgs["/tf_static"] if any(x.child_frame_id == GRID_ORIGIN_FRAME for x in m.transforms)]
    assert [[x.child_frame_id for x in m.transforms] for m in ours] == [[GRID_ORIGIN_FRAME]]
    tf = _tf_of(msgs)
    assert all(tf.parent_of(frame) == "base_link" for frame, _, _ in LASERS.values())


def test_fallback_links_are_the_mounts_tf_lacks() -> None:
    tf = TfBuffer(fallback_parent="base_link", fallback={"a": (1.0, 0.0, 0.0), "b": (0.0, 2.0, 0.5), "c": (0, 0, 0)})
    tf.set_transform("base_link", "b", Pose2D(x=0.0, y=3.0, yaw=0.0))  # TF replaces b's fallback
    tf.set_transform("a", "cam", Pose2D(x=0.1, y=0.0, yaw=0.0))
    links = tf.fallback_links(["cam", "b", "a", "base_link"])
    assert links == [TfLink("base_link", "a", Pose2D(x=1.0, y=0.0, yaw=0.0), "")]  # c places no frame asked for


def _track(tid: int, x: float, y: float, cov: np.ndarray, *, measurement: int, age_s: float) -> Track:
    return Track(
        id=tid, x=x, y=y, vx=0.5, vy=-0.2, covariance=cov, score=0.8, hits=3, misses=0, age=4, confirmed=True,
        measurement=measurement, age_s=age_s,
    )  # fmt: skip


@pytest.mark.parametrize("name", ["out.bag", "out_db", "out_mcap"])
def test_tracked_persons_carry_the_covariance(tmp_path: Path, name: str) -> None:
    cov = np.array(
        [[0.04, 0.01, 0.002, 0.0], [0.01, 0.09, 0.0, 0.003], [0.002, 0.0, 0.25, 0.05], [0, 0.003, 0.05, 0.36]]
    )
    frames = [
        [_track(3, 1.0, 2.0, cov, measurement=1, age_s=2.5), _track(8, -1.0, 0.5, 2 * cov, measurement=-1, age_s=0.1)],
        np.array([[8, -0.9, 0.4, 0.5, -0.2, 0.1, 0.0, 0.2, 0.7]]),  # rows: the position covariance only
    ]
    path = tmp_path / name
    fmt = "mcap" if name == "out_mcap" else None
    with ResultBagWriter(path, spec=_spec(), frame_id="laser", detector_names=[], bag_format=fmt) as w:
        for k, tracks in enumerate(frames):
            w.write(T0 + k * 10**8, T0 + k * 10**8, np.zeros(_spec().shape), np.zeros((0, 2)), [], tracks)
    msgs, conns = _messages(path)
    if name.endswith(".bag"):  # SPENCER's own definitions: rosbag play feeds its nodes
        assert conns[TOPIC_TRACKED_PERSONS].digest == SPENCER_MD5[TRACKED_PERSONS_TYPE]
    (_, first), (_, second) = msgs[TOPIC_TRACKED_PERSONS]
    a, b = first.tracks
    assert (a.track_id, a.is_matched, a.is_occluded, a.detection_id) == (3, True, False, 1)
    assert (b.track_id, b.is_matched, b.is_occluded) == (8, False, True)
    assert (a.age.sec, a.age.nanosec) == (2, 500_000_000)
    assert (a.pose.pose.position.x, a.pose.pose.position.y, a.twist.twist.linear.x) == (1.0, 2.0, 0.5)
    pose, twist = np.asarray(a.pose.covariance).reshape(6, 6), np.asarray(a.twist.covariance).reshape(6, 6)
    np.testing.assert_array_equal(pose[:2, :2], cov[:2, :2])
    np.testing.assert_array_equal(twist[:2, :2], cov[2:, 2:])
    for m in (pose, twist):  # z and the rotations are not estimated: "not set" in SPENCER's convention
        assert np.all(np.diag(m)[2:] == LARGE_VARIANCE) and np.count_nonzero(m) == 4 + 4
    np.testing.assert_array_equal(np.asarray(b.pose.covariance).reshape(6, 6)[:2, :2], 2 * cov[:2, :2])
    (c,) = second.tracks
    got = np.asarray(c.pose.covariance).reshape(6, 6)
    assert (got[0, 0], got[0, 1], got[1, 1]) == (0.1, 0.0, 0.2)
    assert np.asarray(c.twist.covariance)[0] == LARGE_VARIANCE  # velocity covariance not given


def _spec() -> Any:
    from gridbridge.grid import GridSpec

    return GridSpec(nx=10, ny=10, resolution=0.5, x0=0.0, y0=-2.5)


def test_track_markers_have_the_colour_of_their_track(tmp_path: Path) -> None:
    path = tmp_path / "out.bag"
    frames = [np.array([[3, 1.0, 1.0, 0.5, 0.0], [4, 2.0, 0.0, 0.0, 0.5]]), np.array([[4, 2.1, 0.1, 0.0, 0.5]])]
    with ResultBagWriter(path, spec=_spec(), frame_id="laser", detector_names=[]) as w:
        for k, tracks in enumerate(frames):
            w.write(T0 + k * 10**8, T0 + k * 10**8, np.zeros(_spec().shape), np.zeros((0, 2)), [], tracks)
    msgs, _ = _messages(path)
    seen: dict[int, set[tuple[float, float, float]]] = {}
    for _, array in msgs[TOPIC_TRACK_MARKERS]:
        for m in array.markers:
            if m.type in (MARKER_SPHERE, MARKER_ARROW) and m.action == 0:  # not the DELETEALL
                seen.setdefault(m.id, set()).add(tuple(round(v, 3) for v in (m.color.r, m.color.g, m.color.b)))
    assert seen == {3: {track_colour(3)}, 4: {track_colour(4)}}  # one colour per track, kept over frames
    assert track_colour(3) != track_colour(4)
    assert len({track_colour(i) for i in range(8)}) == 8


def test_spencer_definitions_have_spencers_md5() -> None:
    """The ROS 1 MD5 sums of the definitions equal spencer_tracking_msgs' (its rosserial headers:
    TrackedPerson 28bdd0d6..., TrackedPersons 21c0b1a5...)."""
    ts = get_typestore(Stores.ROS1_NOETIC)
    types: dict[str, Any] = {}
    for name, text in SPENCER_MSG_DEFINITIONS.items():
        types.update(get_types_from_msg(text, name))
    ts.register(types)
    assert {name: ts.generate_msgdef(name)[1] for name in SPENCER_MSG_DEFINITIONS} == SPENCER_MD5


def test_track_table_checks_its_input() -> None:
    with pytest.raises(ValueError, match=r"shape \(K, 5\)"):
        track_table(np.zeros((2, 4)))
    with pytest.raises(ValueError, match="unique"):
        track_table(np.array([[1, 0, 0, 0, 0], [1, 1, 1, 0, 0]]))
    assert len(track_table([])) == 0


@pytest.mark.realdata
def test_negative_2_result_bag_places_every_laser_and_holds_every_scan(shared_data: Path, tmp_path: Path) -> None:
    """leg_tracker's negative_2 (three lasers, no TF) configured by ``pfpeople inspect --write-config``: the
    result bag places /rear_scan and /right_scan by TF and holds all of their messages (435, 435, 434)."""
    bag = shared_data / "leg_tracker" / "negative_2.bag"
    if not bag.is_file():
        pytest.skip(f"{bag} is absent")
    config, out = tmp_path / "negative_2.toml", tmp_path / "results.bag"
    assert main(["inspect", str(bag), "--write-config", str(config)]) == 0
    args = ["run", str(bag), "--config", str(config), "--out", str(tmp_path / "run"), "--bag-out", str(out)]
    assert main([*args, "--no-progress", "--no-scans"]) == 0
    msgs, _ = _messages(out)
    with BagSource(bag) as src:
        want = {t: src.message_counts[t] for t in ("/left_scan", "/rear_scan", "/right_scan")}
    assert {t: len(msgs[t]) for t in want} == want == {"/left_scan": 435, "/rear_scan": 435, "/right_scan": 434}
    tf = _tf_of(msgs)
    frames = {m.frame_id for t in want for _, m in [(0, msgs[t][0][1].header)]}
    assert frames == {"left_laser", "rear_laser", "right_laser"}
    assert all(tf.can_transform("left_laser", f) for f in frames)
