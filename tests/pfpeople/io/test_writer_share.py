"""Result bags that share the results the ROS way (issue 28): one bag with the input and the output.

A source bag (ROS 1 or rosbag2) with ``/scan``, ``/tf`` and ``/tf_static`` whose header stamps are 130 s off
the record times is run with ``time_source = "bag"``; the result bag (ROS 1, rosbag2 sqlite3, rosbag2 MCAP)
is read back with rosbags (and with the ``mcap`` reader when it is installed) and must hold the scans and TF
as recorded, people and tracks as ``people_msgs/People`` with ids and velocities, sphere / text markers, and
output header stamps equal to the source scan's header stamp. Then: ``--no-input``, the rosbag2 metadata
version 5 that ROS 2 Humble reads, detector topic renames in the log and ``run.json``, the Foxglove layout.
"""

from __future__ import annotations

import json
import logging
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore
from ruamel.yaml import YAML

from evaluation.bench.batch import SYNTHETIC_CONFIG, write_synthetic_bag
from pfpeople.io.bag.foxglove import layout_path
from pfpeople.io.bag.reader import BagSource
from pfpeople.io.bag.writer import (
    MARKER_DELETEALL,
    MARKER_SPHERE,
    MARKER_TEXT_VIEW_FACING,
    PEOPLE_MSG_DEFINITIONS,
    TOPIC_BELIEF,
    TOPIC_PEOPLE,
    TOPIC_PEOPLE_MARKERS,
    TOPIC_TRACK_MARKERS,
    TOPIC_TRACKS,
    _convert,
)
from pfpeople.pipeline.runner import Pipeline

OFFSET_NS = 130 * 1_000_000_000  # record time - header stamp of every source message
N_SCANS = 6
TF = "tf2_msgs/msg/TFMessage"
SCAN = "sensor_msgs/msg/LaserScan"


def _tf(ts: Any, stamp_ns: int, parent: str, child: str, x: float) -> Any:
    T = ts.types
    header = {"stamp": T["builtin_interfaces/msg/Time"](sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)}
    if "seq" in {n for n, _ in ts.fielddefs["std_msgs/msg/Header"][1]}:
        header["seq"] = 0
    tr = T["geometry_msgs/msg/Transform"](
        translation=T["geometry_msgs/msg/Vector3"](x=x, y=0.0, z=0.0),
        rotation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
    )
    t = T["geometry_msgs/msg/TransformStamped"](
        header=T["std_msgs/msg/Header"](frame_id=parent, **header), child_frame_id=child, transform=tr
    )
    return T[TF](transforms=[t])


def _source(tmp_path: Path, ros2: bool) -> tuple[Path, list[tuple[str, int, Any]]]:
    """A source bag: the synthetic scans recorded ``OFFSET_NS`` after their header stamps, /tf, /tf_static."""
    plain = write_synthetic_bag(tmp_path / "plain.bag", n_scans=N_SCANS, rng=np.random.default_rng(5))
    ts = get_typestore(Stores.ROS2_HUMBLE if ros2 else Stores.ROS1_NOETIC)
    if TF not in ts.types:
        from rosbags.typesys import get_types_from_msg

        from pfpeople.io.bag.writer import _TF_MSG

        ts.register(get_types_from_msg(_TF_MSG, TF))
    msgs: list[tuple[str, int, Any]] = []
    with BagSource(plain) as src:
        for k, m in enumerate(src.messages(["/scan"])):
            scan = _convert(ts, SCAN, m.msg)
            if k == 0:
                msgs.append(("/tf_static", m.stamp_ns + OFFSET_NS - 1, _tf(ts, m.stamp_ns, "base_link", "laser", 0.2)))
            msgs.append(("/tf", m.stamp_ns + OFFSET_NS, _tf(ts, m.stamp_ns, "odom", "base_link", 0.1 * k)))
            msgs.append(("/scan", m.stamp_ns + OFFSET_NS, scan))
    path = tmp_path / ("src_ros2" if ros2 else "src.bag")
    writer: Any = Writer2(path, version=8) if ros2 else Writer1(path)
    with writer as w:
        conns: dict[str, Any] = {}
        for topic, t, msg in msgs:
            msgtype = SCAN if topic == "/scan" else TF
            if topic not in conns:
                conns[topic] = w.add_connection(topic, msgtype, typestore=ts)
            data = ts.serialize_cdr(msg, msgtype) if ros2 else ts.serialize_ros1(msg, msgtype)
            w.write(conns[topic], t, data)
    return path, msgs


def _read(path: Path) -> dict[str, list[tuple[int, Any]]]:
    out: dict[str, list[tuple[int, Any]]] = {}
    with AnyReader([path]) as r:
        for conn, t, raw in r.messages():
            out.setdefault(conn.topic, []).append((t, r.deserialize(raw, conn.msgtype)))
    return out


def _ns(header: Any) -> int:
    return int(header.stamp.sec) * 10**9 + int(header.stamp.nanosec)


def _run(src: Path, out: Path | None, bag_out: Path, *, name: str | None = None, **kwargs: Any) -> list[Any]:
    config = replace(SYNTHETIC_CONFIG, time_source="bag")
    if name is not None:  # the one detector named so
        config = replace(config, detectors=(replace(config.detectors[0], name=name),))
    with BagSource(src) as bag:
        _, kept = Pipeline(config, front_process=False).run(bag, out, bag_out=bag_out, keep=True, **kwargs)
    return kept


CASES = [(False, "res.bag", None), (True, "res_db", None), (False, "res_mcap", "mcap"), (True, "res2.bag", None)]


@pytest.mark.parametrize(("ros2_source", "name", "fmt"), CASES)
def test_one_bag_holds_input_and_results_with_source_stamps(
    tmp_path: Path, ros2_source: bool, name: str, fmt: str | None
) -> None:
    src, written = _source(tmp_path, ros2_source)
    kept = _run(src, None, tmp_path / name, bag_format=fmt)
    msgs = _read(tmp_path / name)
    assert {"/scan", "/tf", "/tf_static", TOPIC_BELIEF, TOPIC_PEOPLE, TOPIC_TRACKS, TOPIC_TRACK_MARKERS} <= set(msgs)
    # The input, as recorded: record times, header stamps, ranges; TF too.
    scans_in = [(t, m) for topic, t, m in written if topic == "/scan"]
    assert [t for t, _ in msgs["/scan"]] == [t for t, _ in scans_in]
    for (_, got), (_, sent) in zip(msgs["/scan"], scans_in, strict=True):
        assert _ns(got.header) == _ns(sent.header) and got.header.frame_id == "laser"
        np.testing.assert_array_equal(np.asarray(got.ranges), np.asarray(sent.ranges))
    assert [_ns(m.transforms[0].header) for _, m in msgs["/tf"]] == [_ns(m.header) for _, m in scans_in]
    statics = [(tf.header.frame_id, tf.child_frame_id) for _, m in msgs["/tf_static"] for tf in m.transforms]
    assert ("base_link", "laser") in statics and ("laser", "pfpeople_grid_origin") in statics
    # Output header stamps: the source scan's header stamp (not the record time the frames ran on).
    header_of = {t: _ns(m.header) for t, m in scans_in}
    for topic in (TOPIC_BELIEF, TOPIC_PEOPLE, TOPIC_PEOPLE_MARKERS, TOPIC_TRACKS, TOPIC_TRACK_MARKERS):
        headers = [(t, m.markers[0].header if hasattr(m, "markers") else m.header) for t, m in msgs[topic]]
        assert [(t, _ns(h)) for t, h in headers] == [(t, header_of[t]) for t, _ in scans_in], topic
        assert all(header_of[t] == t - OFFSET_NS for t, _ in msgs[topic])
    # Tracks: ids and velocities of the run's tracks; markers spheres and id labels after a DELETEALL.
    assert len(msgs[TOPIC_TRACKS]) == len(kept) == N_SCANS
    for (_, people), r in zip(msgs[TOPIC_TRACKS], kept, strict=True):
        got = [(p.name, p.velocity.x, p.velocity.y, p.reliability) for p in people.people]
        assert got == [(str(t.id), t.vx, t.vy, t.score) for t in r.tracks]
        for p, t in zip(people.people, r.tracks, strict=True):
            assert dict(zip(p.tagnames, map(float, p.tags), strict=True)) == {
                "cov_xx": t.covariance[0, 0],
                "cov_xy": t.covariance[0, 1],
                "cov_yy": t.covariance[1, 1],
            }
    assert any(len(m.people) for _, m in msgs[TOPIC_TRACKS])  # the synthetic people are tracked
    for (_, ma), r in zip(msgs[TOPIC_TRACK_MARKERS], kept, strict=True):
        assert ma.markers[0].action == MARKER_DELETEALL
        assert sorted(m.id for m in ma.markers if m.type == MARKER_SPHERE) == sorted(t.id for t in r.tracks)
        assert sorted(m.text for m in ma.markers if m.type == MARKER_TEXT_VIEW_FACING) == sorted(
            str(t.id) for t in r.tracks
        )
    people_counts = [len(m.people) for _, m in msgs[TOPIC_PEOPLE]]
    assert people_counts == [len(r.people) for r in kept]
    assert [len(m.markers) - 1 for _, m in msgs[TOPIC_PEOPLE_MARKERS]] == people_counts


def test_no_input_copies_neither_scans_nor_tf(tmp_path: Path) -> None:
    src, _ = _source(tmp_path, False)
    _run(src, None, tmp_path / "res.bag", bag_input=False)
    msgs = _read(tmp_path / "res.bag")
    assert "/scan" not in msgs and "/tf" not in msgs
    assert [tf.child_frame_id for _, m in msgs["/tf_static"] for tf in m.transforms] == ["pfpeople_grid_origin"]


def test_run_command_no_input_flag(tmp_path: Path) -> None:
    from pfpeople.cli import main

    src, _ = _source(tmp_path, False)
    base = ["run", str(src), "--driver", "/scan", "--time-source", "bag", "--no-progress", "--one-process"]
    assert main([*base, "--out", str(tmp_path / "a"), "--bag-out", str(tmp_path / "a.bag")]) == 0
    assert main([*base, "--out", str(tmp_path / "b"), "--bag-out", str(tmp_path / "b.bag"), "--no-input"]) == 0
    assert "/scan" in _read(tmp_path / "a.bag") and "/scan" not in _read(tmp_path / "b.bag")


def test_rosbag2_metadata_is_version_5_for_humble(tmp_path: Path) -> None:
    src, _ = _source(tmp_path, False)
    _run(src, None, tmp_path / "res")
    meta = YAML(typ="safe").load((tmp_path / "res" / "metadata.yaml").read_text())
    info = meta["rosbag2_bagfile_information"]
    assert info["version"] == 5 and info["storage_identifier"] == "sqlite3"  # sqlite3 by default
    assert not {"custom_data", "ros_distro"} & set(info)
    assert [p.suffix for p in (tmp_path / "res").iterdir() if p.suffix != ".yaml"] == [".db3"]
    assert info["files"][0]["message_count"] == info["message_count"] > 0
    for entry in info["topics_with_message_count"]:
        topic = entry["topic_metadata"]
        assert set(topic) == {"name", "type", "serialization_format", "offered_qos_profiles"}
        (qos,) = YAML(typ="safe").load(topic["offered_qos_profiles"])  # a string of integer policies (v4-v8)
        assert (qos["history"], qos["reliability"]) == (1, 1)
        assert qos["durability"] == (1 if topic["name"] == "/tf_static" else 2)
    types = {e["topic_metadata"]["name"]: e["topic_metadata"]["type"] for e in info["topics_with_message_count"]}
    assert types[TOPIC_TRACKS] == types[TOPIC_PEOPLE] == "people_msgs/msg/People"
    assert types["/scan"] == "sensor_msgs/msg/LaserScan" and types[TOPIC_TRACK_MARKERS].endswith("MarkerArray")


def test_renamed_detector_topics_are_logged_and_in_run_json(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    src, _ = _source(tmp_path, False)
    with caplog.at_level(logging.WARNING, logger="pfpeople.io.bag.writer"):
        _run(src, tmp_path / "default", tmp_path / "default.bag")
    assert "its detections go to" not in caplog.text  # the default name, laser_legs, is a valid ROS name: kept
    assert json.loads((tmp_path / "default" / "run.json").read_text())["result_bag"]["renamed_topics"] == {}
    with caplog.at_level(logging.WARNING, logger="pfpeople.io.bag.writer"):
        _run(src, tmp_path / "run", tmp_path / "res.bag", name="laser-legs")
    assert "detector 'laser-legs': its detections go to /pfpeople/detections/laser_legs" in caplog.text
    result_bag = json.loads((tmp_path / "run" / "run.json").read_text())["result_bag"]
    assert result_bag["renamed_topics"] == {"laser-legs": "/pfpeople/detections/laser_legs"}
    assert result_bag["format"] == "ros1" and result_bag["input_topics"] == ["/scan", "/tf", "/tf_static"]
    assert result_bag["topics"][TOPIC_TRACKS] == "people_msgs/msg/People"
    assert set(result_bag["topics"]) == set(_read(tmp_path / "res.bag"))


def test_foxglove_layout_beside_the_bag(tmp_path: Path) -> None:
    src, _ = _source(tmp_path, False)
    _run(src, None, tmp_path / "res")
    path = layout_path(tmp_path / "res")
    assert path == tmp_path / "res.foxglove-layout.json"
    doc = json.loads(path.read_text())
    panel = doc["configById"]["3D!pfpeople"]
    assert panel["followTf"] == "laser"
    assert {"/scan", TOPIC_TRACK_MARKERS, TOPIC_PEOPLE_MARKERS, TOPIC_BELIEF} <= {
        t for t, s in panel["topics"].items() if s["visible"]
    }
    assert doc["layout"]["first"] == "3D!pfpeople"


def test_mcap_reader_finds_scans_tf_and_people(tmp_path: Path) -> None:
    reader = pytest.importorskip("mcap.reader")
    src, _ = _source(tmp_path, False)
    _run(src, None, tmp_path / "res_mcap", bag_format="mcap")
    (file,) = (tmp_path / "res_mcap").glob("*.mcap")
    with file.open("rb") as f:
        summary = reader.make_reader(f).get_summary()
    assert summary is not None
    channels = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
    assert channels["/scan"] == "sensor_msgs/msg/LaserScan" and channels["/tf"] == TF
    assert channels[TOPIC_TRACKS] == "people_msgs/msg/People"
    people_schema = next(s for s in summary.schemas.values() if s.name == "people_msgs/msg/People")
    assert b"Person[] people" in people_schema.data


def test_people_msgs_definitions_match_the_ros_people_package() -> None:
    # people_msgs (ROS 1 `people` stack and its ROS 2 port): Person {name, position, velocity, reliability,
    # tagnames, tags}, People {header, people}.
    person = [line.split() for line in PEOPLE_MSG_DEFINITIONS["people_msgs/msg/Person"].splitlines()]
    assert person == [
        ["string", "name"],
        ["geometry_msgs/Point", "position"],
        ["geometry_msgs/Point", "velocity"],
        ["float64", "reliability"],
        ["string[]", "tagnames"],
        ["string[]", "tags"],
    ]
