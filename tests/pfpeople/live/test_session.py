"""The live node's transport-free core (pfpeople.live): a bag's ROS 1 bytes through the codec and a LiveSession give
the offline run's frames; set-up from the first messages; dropping the scans a newer one waits behind; the codec.
No ROS install needed: the bytes are read from a bag with rosbags."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rosbags.rosbag1 import Reader

from evaluation.scenarios.scan import SceneBag, write_scene_bag
from pfpeople.config import load_config
from pfpeople.io.bag.writer import output_topics
from pfpeople.live.codec import Ros1Codec, ros1_name
from pfpeople.live.outputs import ResultMessages
from pfpeople.live.session import LiveSession, SetupTimeout
from pfpeople.live.source import BufferedSource
from pfpeople.pipeline.runner import Pipeline

FRAMES = 40


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> SceneBag:
    sb = write_scene_bag("corridor", tmp_path_factory.mktemp("scene"), frames=FRAMES, seed=2)
    sb.run_toml.write_text(sb.run_toml.read_text() + '\n[output]\nframe = "odom"\n')
    return sb


def _raw(bag: Path, topics: list[str]) -> Iterator[tuple[Any, int, bytes]]:
    with Reader(bag) as r:
        conns = [c for c in r.connections if c.topic in set(topics)]
        for c, t, raw in r.messages(connections=conns):
            yield c, t, bytes(raw)


def _session(scene: SceneBag, **kw: Any) -> tuple[LiveSession, Ros1Codec]:
    codec = Ros1Codec()
    return LiveSession(load_config(scene.run_toml), codec.ts, clock=lambda: 0, **kw), codec


def _messages(scene: SceneBag, codec: Ros1Codec, topics: list[str]) -> list[Any]:
    return [
        codec.decode(c.topic, ros1_name(c.msgtype), c.digest, c.msgdef.data, raw, t)
        for c, t, raw in _raw(scene.bag, topics)
    ]


def test_a_bags_messages_through_the_live_core_give_the_offline_runs_frames(scene: SceneBag) -> None:
    session, codec = _session(scene, drop=False)
    outs = []
    for m in _messages(scene, codec, session.topics):
        outs += session.receive(m, newer_driver_waiting=True)  # never dropped with drop=False
    outs += session.finish()
    _, ref = Pipeline(load_config(scene.run_toml), front_process=False).run(scene.bag, None, keep=True)
    assert len(outs) == len(ref) == FRAMES and session.latency.dropped == 0
    for o, r in zip(outs, ref, strict=True):
        assert o.result.frame.stamp_ns == r.frame.stamp_ns
        assert np.array_equal(o.result.belief, r.belief) and np.array_equal(o.result.people, r.people)
        assert o.result.output_pose == r.output_pose
    topics = [t for t, _, _ in outs[-1].messages]
    assert topics[:3] == ["/pfpeople/belief", "/pfpeople/people", "/pfpeople/people_markers"]
    people = next(m for t, _, m in outs[-1].messages if t == "/pfpeople/people")
    assert people.header.frame_id == "odom"
    enc = codec.encode("/pfpeople/people", "people_msgs/msg/People", people)
    back = codec.decode("/x", enc.msgtype, enc.md5, enc.definition, enc.data, 0)
    assert [p.position.x for p in back.msg.people] == [p.position.x for p in people.people]


def test_a_scan_a_newer_one_waits_behind_is_dropped(scene: SceneBag) -> None:
    """Every driving scan buffered before the set-up but the newest, and every later one the transport says a newer
    one waits behind (here: every other one), is dropped and counted; the others make frames."""
    session, codec = _session(scene)
    frames, driver, buffered = 0, 0, None
    for m in _messages(scene, codec, session.topics):
        is_driver = m.topic == "/scan"
        driver += is_driver
        was_ready = session.ready
        frames += len(session.receive(m, newer_driver_waiting=is_driver and driver % 2 == 0 and was_ready))
        if session.ready and buffered is None:
            buffered = driver
    frames += len(session.finish())
    assert buffered is not None and 1 < buffered < FRAMES
    after = FRAMES - buffered
    assert session.latency.dropped == (buffered - 1) + sum(1 for k in range(buffered + 1, FRAMES + 1) if k % 2 == 0)
    assert frames == FRAMES - session.latency.dropped and after > 10


def test_the_set_up_waits_for_every_sensor_topic_then_gives_up_naming_it(scene: SceneBag) -> None:
    session, codec = _session(scene)
    msgs = _messages(scene, codec, ["/odom", "/tf", "/tf_static"])
    for m in msgs:
        assert session.receive(m) == []
    assert not session.ready
    late = msgs[-1]
    with pytest.raises(SetupTimeout, match="/scan"):
        session.receive(type(late)(late.topic, late.msgtype, 0, late.bag_time_ns + 60 * 10**9, 0, "", late.msg))


def test_the_output_topics_are_the_result_bags() -> None:
    names = ["laser-legs", "camera"]
    bag = {t: ty for t, ty in output_topics(names).items() if not t.startswith("/tf")}
    assert ResultMessages.topic_types(names) == bag
    assert set(ResultMessages.topic_types(names, "/robot/people")) == {
        t.replace("/pfpeople", "/robot/people") for t in bag
    }


def test_a_buffered_source_names_a_sensor_topic_without_messages() -> None:
    with pytest.raises(ValueError, match="no message on topic '/scan' in the live topics yet"):
        BufferedSource([]).require(["/scan"], types={"/scan": ("sensor_msgs/msg/LaserScan",)})
    BufferedSource([]).require(["/odom"], types={"/odom": ("nav_msgs/msg/Odometry",)})  # waited for elsewhere


def test_the_codec_knows_the_standard_definitions() -> None:
    codec = Ros1Codec()
    definition, md5 = codec.ts.generate_msgdef("sensor_msgs/msg/LaserScan")
    assert md5 == "90c7ef2dc6895d81024acba2ac42f369"  # rosmsg md5 sensor_msgs/LaserScan
    with pytest.raises(ValueError, match="topic '/scan': cannot decode a sensor_msgs/LaserScan"):
        codec.decode("/scan", "sensor_msgs/LaserScan", md5, definition, b"\x01\x02", 0)
