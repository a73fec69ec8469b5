"""The fast ROS1 decoders of TF and odometry (pfpeople.io.bag.ros1_decoders) against rosbags' own decoding."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from bag_fixtures import write_bag
from rosbags.serde import SerdeError

from pfpeople.io.bag.reader import BagReadError, BagSource
from pfpeople.io.bag.ros1_decoders import STANDARD_MD5, ros1_decoder

TYPES = ("tf2_msgs/msg/TFMessage", "nav_msgs/msg/Odometry")


def _same(a: Any, b: Any, where: str = "msg") -> None:
    """``a`` and ``b`` equal field by field: the same classes, values, array bytes, dtypes and writeable flags."""
    assert type(a) is type(b), where
    if hasattr(a, "__dataclass_fields__"):
        for name in a.__dataclass_fields__:
            _same(getattr(a, name), getattr(b, name), f"{where}.{name}")
    elif isinstance(a, np.ndarray):
        assert (a.dtype, a.shape, a.flags.writeable) == (b.dtype, b.shape, b.flags.writeable), where
        assert a.tobytes() == b.tobytes(), where
    elif isinstance(a, list):
        assert len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b, strict=True)):
            _same(x, y, f"{where}[{k}]")
    else:
        assert a == b or (isinstance(a, float) and math.isnan(a) and math.isnan(b)), where


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("decoders") / "scene.bag"
    write_bag(path, n_scans=5)
    return path


def _raw(path: Path) -> tuple[Any, dict[str, list[tuple[Any, Any]]]]:
    src = BagSource(path)
    by_type: dict[str, list[tuple[Any, Any]]] = {}
    for conn, _, raw in src._reader.messages():
        by_type.setdefault(conn.msgtype, []).append((conn, raw))
    return src, by_type


def test_every_tf_and_odometry_message_of_a_bag_decodes_as_rosbags_decodes_it(bag: Path) -> None:
    src, by_type = _raw(bag)
    with src:
        for msgtype in TYPES:
            conn = by_type[msgtype][0][0]
            assert conn.digest == STANDARD_MD5[msgtype]
            decode = ros1_decoder(msgtype, conn.digest, src._reader.typestore)
            assert decode is not None
            for _, raw in by_type[msgtype]:
                _same(decode(raw), src._reader.deserialize(raw, msgtype))
        assert sum(len(by_type[t]) for t in TYPES) == 1 + 36  # /tf_static and 36 odometry messages


def test_several_transforms_odd_frames_and_extreme_values_decode_as_rosbags_decodes_them(bag: Path) -> None:
    with BagSource(bag) as src:
        ts = src._reader.typestore
        T = ts.types
        stamped = [
            T["geometry_msgs/msg/TransformStamped"](
                header=T["std_msgs/msg/Header"](
                    seq=2**32 - 1, stamp=T["builtin_interfaces/msg/Time"](sec=-5, nanosec=999_999_999), frame_id=f
                ),
                child_frame_id=c,
                transform=T["geometry_msgs/msg/Transform"](
                    translation=T["geometry_msgs/msg/Vector3"](x=1e300, y=-0.0, z=math.inf),
                    rotation=T["geometry_msgs/msg/Quaternion"](x=math.nan, y=0.5, z=-0.5, w=1.0),
                ),
            )
            for f, c in (("", "laser"), ("/odom", "bäse_link"), ("map", "x" * 300))
        ]
        for msg in (T["tf2_msgs/msg/TFMessage"](transforms=stamped), T["tf2_msgs/msg/TFMessage"](transforms=[])):
            raw = bytes(ts.serialize_ros1(msg, "tf2_msgs/msg/TFMessage"))
            decode = ros1_decoder("tf2_msgs/msg/TFMessage", STANDARD_MD5["tf2_msgs/msg/TFMessage"], ts)
            assert decode is not None
            _same(decode(raw), ts.deserialize_ros1(raw, "tf2_msgs/msg/TFMessage"))


@pytest.mark.parametrize("msgtype", TYPES)
def test_bad_bytes_raise_rosbags_error(bag: Path, msgtype: str) -> None:
    """Truncated, over-long and broken-string messages raise SerdeError, as rosbags does for them."""
    src, by_type = _raw(bag)
    with src:
        conn, raw = by_type[msgtype][0]
        decode = ros1_decoder(msgtype, conn.digest, src._reader.typestore)
        assert decode is not None
        raw = bytes(raw)
        at = 16 if msgtype.startswith("tf2") else 12  # the header's frame_id length field
        broken_length = raw[:at] + b"\xff\xff\x00\x00" + raw[at + 4 :]
        for bad in (raw[:-1], raw[: len(raw) // 2], raw + b"\x00", broken_length):
            with pytest.raises(SerdeError) as ours:
                decode(bad)
            with pytest.raises(SerdeError):
                src._reader.typestore.deserialize_ros1(bad, msgtype)
            text = str(ours.value)
            assert (
                text.startswith(f"Could not deserialize {msgtype!r}")
                or text.startswith("ROS1 message size mismatch")
                or text.startswith("Invalid string length")
            ), text


def test_other_types_definitions_and_stores_are_left_to_rosbags(bag: Path) -> None:
    with BagSource(bag) as src:
        ts = src._reader.typestore
        assert ros1_decoder("sensor_msgs/msg/LaserScan", "90c7ef2dc6895d81024acba2ac42f369", ts) is None
        assert ros1_decoder("nav_msgs/msg/Odometry", "0" * 32, ts) is None  # another definition of the type
        assert (
            ros1_decoder("nav_msgs/msg/Odometry", STANDARD_MD5["nav_msgs/msg/Odometry"], SimpleNamespace(types={}))
            is None
        )
        assert {c.topic: src._decoder(c) is not None for c in src._reader.connections} == {
            "/tf_static": True,
            "/odom": True,
            "/scan": False,
            "/people": False,
        }


def test_a_corrupt_odometry_message_in_a_bag_is_the_readers_error_naming_topic_and_time(
    bag: Path, tmp_path: Path
) -> None:
    """The reader's BagReadError for a message the fast decoder refuses names the topic and the bag time, and the
    messages before it are kept."""
    data = bag.read_bytes()
    src, by_type = _raw(bag)
    with src:
        first = bytes(by_type["nav_msgs/msg/Odometry"][3][1])
    at = data.index(first)
    header, rest = data[: at - 4], data[at + len(first) :]
    broken = tmp_path / "broken.bag"
    # the record's data length field (4 bytes before the data) is kept; the data's string length is broken
    broken.write_bytes(header + data[at - 4 : at] + first[:12] + b"\xff\xff\x00\x00" + first[16:] + rest)
    got = []
    with BagSource(broken) as src, pytest.raises(BagReadError, match=r"nav_msgs/msg/Odometry message on topic '/odom'"):
        for m in src.messages(["/odom"]):
            got.append(m.index)
    assert got == [0, 1, 2]
