"""Decoders of the two message types a ROS1 bag has most of: ``tf2_msgs/TFMessage`` and ``nav_msgs/Odometry``.

A robot records TF and odometry at 50-100 Hz: each scan frame of a run reads a dozen of them. rosbags decodes a
message field by field with generic generated code; these decoders read the same bytes with a few ``struct`` calls
into the same classes (the reader's typestore's) with the same values.

They serve a connection only when its type and its definition's MD5 sum are the standard ones
(:func:`ros1_decoder` says which); any other type or definition decodes with rosbags. Bad bytes raise rosbags'
error, :class:`rosbags.serde.SerdeError` ("Could not deserialize ...", "ROS1 message size mismatch ...",
"Invalid string length ..."), so the reader's error naming the topic and the bag time keeps its form.
``tests/pfpeople/io/test_ros1_decoders.py`` decodes every such message of the test bags both ways.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray
from rosbags.serde import SerdeError

__all__ = ["Decoder", "ros1_decoder"]

#: A decoder: the raw ROS1 bytes of one message -> the message.
Decoder = Callable[[Any], object]

#: The MD5 sums of the standard definitions (``rosmsg md5``), by type.
STANDARD_MD5 = {
    "tf2_msgs/msg/TFMessage": "94810edda583a504dfda3829e70d7eec",
    "nav_msgs/msg/Odometry": "cd5e73d190d741a2f92e81eda573aca7",
}

_U32 = struct.Struct("<I")
_HEADER = struct.Struct("<IiII")  # seq, stamp.sec, stamp.nanosec, frame_id's length
_F7 = struct.Struct("<7d")  # a Vector3 (or Point) and a Quaternion
_F6 = struct.Struct("<6d")  # two Vector3s
_COV = 36 * 8  # the bytes of a float64[36] covariance


def _string(raw: Any, pos: int, length: int) -> str:
    """The string of ``length`` bytes whose length field is at ``pos`` (rosbags' check and decoding)."""
    end = pos + 4 + length
    if end > len(raw):
        raise SerdeError(f"Invalid string length {length} at offset {pos}.")
    return bytes(raw[pos + 4 : end]).decode()


def _covariance(raw: Any, pos: int) -> NDArray[np.float64]:
    """The float64[36] at ``pos``: a view of ``raw``, as rosbags gives (read-only for bytes)."""
    return np.frombuffer(raw, dtype=np.float64, count=36, offset=pos)


class _Decoders:
    """The decoders, building the classes of a typestore."""

    def __init__(self, typestore: Any) -> None:
        t = typestore.types
        self.time, self.header_type = t["builtin_interfaces/msg/Time"], t["std_msgs/msg/Header"]
        self.vector3, self.quaternion = t["geometry_msgs/msg/Vector3"], t["geometry_msgs/msg/Quaternion"]
        self.point, self.pose = t["geometry_msgs/msg/Point"], t["geometry_msgs/msg/Pose"]
        self.transform, self.stamped = t["geometry_msgs/msg/Transform"], t["geometry_msgs/msg/TransformStamped"]
        self.tf, self.odometry = t["tf2_msgs/msg/TFMessage"], t["nav_msgs/msg/Odometry"]
        self.pose_cov = t["geometry_msgs/msg/PoseWithCovariance"]
        self.twist, self.twist_cov = t["geometry_msgs/msg/Twist"], t["geometry_msgs/msg/TwistWithCovariance"]

    def _header(self, raw: Any, pos: int) -> tuple[Any, int]:
        """A ``std_msgs/Header`` at ``pos`` and the position after it."""
        seq, sec, nanosec, length = _HEADER.unpack_from(raw, pos)
        frame_id = _string(raw, pos + 12, length)
        return self.header_type(seq, self.time(sec, nanosec), frame_id), pos + 16 + length

    def _stamped(self, raw: Any, pos: int) -> tuple[Any, int]:
        """A ``geometry_msgs/TransformStamped`` at ``pos`` and the position after it."""
        header, pos = self._header(raw, pos)
        (length,) = _U32.unpack_from(raw, pos)
        child = _string(raw, pos, length)
        tx, ty, tz, qx, qy, qz, qw = _F7.unpack_from(raw, pos + 4 + length)
        transform = self.transform(self.vector3(tx, ty, tz), self.quaternion(qx, qy, qz, qw))
        return self.stamped(header, child, transform), pos + 60 + length

    def tf_message(self, raw: Any) -> tuple[object, int]:
        """A ``tf2_msgs/TFMessage`` and the position after it."""
        (n,) = _U32.unpack_from(raw, 0)
        pos, out = 4, []
        for _ in range(n):
            stamped, pos = self._stamped(raw, pos)
            out.append(stamped)
        return self.tf(out), pos

    def odometry_message(self, raw: Any) -> tuple[object, int]:
        """A ``nav_msgs/Odometry`` and the position after it."""
        header, pos = self._header(raw, 0)
        (length,) = _U32.unpack_from(raw, pos)
        child = _string(raw, pos, length)
        pos += 4 + length
        px, py, pz, qx, qy, qz, qw = _F7.unpack_from(raw, pos)
        lx, ly, lz, ax, ay, az = _F6.unpack_from(raw, pos + 56 + _COV)
        pose_cov, twist_cov = _covariance(raw, pos + 56), _covariance(raw, pos + 104 + _COV)
        pose = self.pose_cov(self.pose(self.point(px, py, pz), self.quaternion(qx, qy, qz, qw)), pose_cov)
        twist = self.twist_cov(self.twist(self.vector3(lx, ly, lz), self.vector3(ax, ay, az)), twist_cov)
        return self.odometry(header, child, pose, twist), pos + 104 + 2 * _COV


def _checked(decode: Callable[[Any], tuple[object, int]], typename: str) -> Decoder:
    """``decode`` with rosbags' errors: :class:`SerdeError` for bad bytes and for a size mismatch."""

    def decoder(raw: Any) -> object:
        try:
            msg, pos = decode(raw)
        except (struct.error, UnicodeDecodeError, ValueError) as exc:
            raise SerdeError(f"Could not deserialize {typename!r}: {exc}") from exc
        if pos != len(raw):
            raise SerdeError(f"ROS1 message size mismatch for {typename!r}.")
        return msg

    return decoder


def ros1_decoder(msgtype: str, md5sum: str, typestore: Any) -> Decoder | None:
    """The decoder of a ROS1 connection's messages, or None where rosbags decodes (another type or definition).

    Parameters
    ----------
    msgtype : str
        The connection's type in rosbags' spelling (``tf2_msgs/msg/TFMessage``).
    md5sum : str
        The MD5 sum of the connection's message definition (``Connection.digest`` of a ROS1 bag in rosbags).
    typestore : rosbags Typestore
        The reader's typestore, whose classes the messages are.
    """
    if STANDARD_MD5.get(msgtype) != md5sum:
        return None
    try:
        decoders = _Decoders(typestore)
    except KeyError:  # a typestore without the standard classes
        return None
    if msgtype == "tf2_msgs/msg/TFMessage":
        return _checked(decoders.tf_message, msgtype)
    return _checked(decoders.odometry_message, msgtype)
