"""``pfpeople node`` end to end on ROS 1 (Debian's packages; skipped where ROS 1 is not installed): the test's own
``rosmaster`` on a free loopback port, ``rosbag play`` of a generated bag, the node, and a subscriber. The people and
tracks the node publishes equal the offline run's (``pfpeople run`` on the same bag and config).

Sync tolerance: none is needed. Frames are made from the header stamps (``time_source = "header"``), and each topic
of a frame is waited for until a later message arrives, so the node's frames are the offline run's whatever the
delivery's timing; with ``--no-drop`` no scan is dropped, and people and tracks are the same to 1e-9 m (float64
through the ROS 1 serialisation). The node's default mode (drop a scan a newer one waits behind) is tested in
``tests/pfpeople/live/test_session.py``; its latency at 1x and 4x playback is a benchmark
(``python -m evaluation.bench.node``), not a test.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest

from evaluation.scenarios.scan import write_scene_bag
from pfpeople.config import load_config
from pfpeople.pipeline.output_frame import results_in
from pfpeople.pipeline.runner import Pipeline
from pfpeople.ros1.system import RosMissingError, find_ros_python, ros_tool

try:
    find_ros_python()
    _MISSING = "" if ros_tool("rosmaster") and ros_tool("rosbag") else "rosmaster / rosbag not installed"
except RosMissingError as exc:
    _MISSING = str(exc)

pytestmark = pytest.mark.skipif(bool(_MISSING), reason=f"ROS 1 not installed: {_MISSING}")

FRAMES = 60


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A ray-cast corridor (20 Hz laser, odometry, TF) and its config with ``[output] frame = "odom"``."""
    sb = write_scene_bag("corridor", tmp_path_factory.mktemp("scene"), frames=FRAMES, seed=3)
    toml = sb.run_toml.with_name("odom.toml")
    toml.write_text(sb.run_toml.read_text() + '\n[output]\nframe = "odom"\n')
    return sb.bag, toml


def _offline(bag: Path, toml: Path) -> tuple[dict[int, np.ndarray], dict[int, list[tuple[float, ...]]]]:
    """Per frame stamp, the offline run's people and tracks in the output frame."""
    _, results = Pipeline(load_config(toml), front_process=False).run(bag, None, keep=True)
    people, tracks = {}, {}
    for r in results:
        xy, trk = results_in(r, output=True)
        assert xy is not None and trk is not None
        people[r.frame.stamp_ns] = xy
        tracks[r.frame.stamp_ns] = [(t.id, t.x, t.y, t.vx, t.vy) for t in trk]
    return people, tracks


def test_the_node_publishes_the_offline_runs_people_and_tracks(scene: tuple[Path, Path], tmp_path: Path) -> None:
    from evaluation.bench.live_ros import Recorder, ros_world

    bag, toml = scene
    people, tracks = _offline(bag, toml)
    with ros_world(tmp_path / "world") as world:
        node = world.node(toml, "--no-drop", "--stats", str(tmp_path / "stats.json"))
        recorder = Recorder(world, ["/pfpeople/people", "/pfpeople/tracks", "/pfpeople/belief"])
        try:
            connected = recorder.wait_connected(120.0)
            assert all(connected.values()), connected
            assert world.play(bag, rate=1.0).wait(120) == 0
            end = time.monotonic() + 60.0
            while time.monotonic() < end and sum(h["topic"].endswith("belief") for h, _ in recorder.records) < FRAMES:
                time.sleep(0.1)
        finally:
            node.terminate()
            node.wait(30)
            recorder.close()
    got = recorder.decoded()
    stats = json.loads((tmp_path / "stats.json").read_text())
    assert stats["frames"] == FRAMES and stats["dropped"] == 0, (tmp_path / "world" / "node.log").read_text()[-3000:]
    live_people = {_stamp(m): np.array([[q.position.x, q.position.y] for q in m.people]).reshape(-1, 2)
                   for topic, _t, m in got if topic == "/pfpeople/people"}  # fmt: skip
    live_tracks = {_stamp(m): [(int(q.name), q.position.x, q.position.y, q.velocity.x, q.velocity.y) for q in m.people]
                   for topic, _t, m in got if topic == "/pfpeople/tracks"}  # fmt: skip
    assert len(live_people) == FRAMES and {m.header.frame_id for t, _, m in got if t == "/pfpeople/people"} == {"odom"}
    for stamp, xy in live_people.items():
        np.testing.assert_allclose(xy, people[stamp].reshape(-1, 2), rtol=0, atol=1e-9)
    assert sum(len(v) for v in live_tracks.values()) == sum(len(v) for v in tracks.values()) > 0
    for stamp, rows in live_tracks.items():
        want = np.array(tracks[stamp]).reshape(-1, 5)
        np.testing.assert_allclose(np.array(rows).reshape(-1, 5), want, rtol=0, atol=1e-9)


def _stamp(msg: object) -> int:
    s = msg.header.stamp  # type: ignore[attr-defined]
    return int(s.sec) * 1_000_000_000 + int(s.nanosec)
