"""ROS 1 messages as bytes <-> the messages pfpeople reads (rosbags' classes, as from a bag).

A live ROS 1 transport hands over each message as its ROS 1 serialisation with its connection's type, MD5 sum and
message definition (what ``rospy.AnyMsg`` gets), as a ROS 1 bag stores it. :class:`Ros1Codec` decodes it with
rosbags into the same :class:`~pfpeople.io.bag.reader.BagMessage` a bag run reads (types unknown to the ROS 1 Noetic
store, e.g. ``people_msgs`` or a robot's own, come from the message definition), TF and odometry by the fast decoders
of :mod:`pfpeople.io.bag.ros1_decoders`; and encodes the results (:mod:`pfpeople.live.outputs`) back to bytes with
their type, MD5 sum and definition, for the transport to publish.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from pfpeople.io.bag.reader import BagMessage, header_stamp_ns
from pfpeople.io.bag.ros1_decoders import Decoder, ros1_decoder
from pfpeople.io.bag.track_messages import SPENCER_MSG_DEFINITIONS
from pfpeople.io.bag.writer import PEOPLE_MSG_DEFINITIONS

__all__ = ["Encoded", "Ros1Codec", "ros1_name", "store_name"]

_TF_MSG = "geometry_msgs/TransformStamped[] transforms\n"


def store_name(ros1_type: str) -> str:
    """``pkg/Name`` (ROS 1) -> ``pkg/msg/Name`` (rosbags)."""
    pkg, _, name = ros1_type.partition("/")
    return ros1_type if "/msg/" in ros1_type else f"{pkg}/msg/{name}"


def ros1_name(typename: str) -> str:
    """``pkg/msg/Name`` (rosbags) -> ``pkg/Name`` (ROS 1)."""
    return typename.replace("/msg/", "/")


@dataclass(frozen=True)
class Encoded:
    """One message to publish: ``topic``, ROS 1 ``msgtype`` (``pkg/Name``), ``md5``, ``definition``, ``data``."""

    topic: str
    msgtype: str
    md5: str
    definition: str
    data: bytes


class Ros1Codec:
    """Decode received ROS 1 messages and encode results (see the module docstring)."""

    def __init__(self) -> None:
        self.ts: Any = get_typestore(Stores.ROS1_NOETIC)
        types: dict[str, Any] = {}
        if "tf2_msgs/msg/TFMessage" not in self.ts.types:
            types.update(get_types_from_msg(_TF_MSG, "tf2_msgs/msg/TFMessage"))
        for name, text in {**PEOPLE_MSG_DEFINITIONS, **SPENCER_MSG_DEFINITIONS}.items():
            types.update(get_types_from_msg(text, name))
        self.ts.register(types)
        self._decoders: dict[tuple[str, str], Decoder | None] = {}
        self._defs: dict[str, tuple[str, str]] = {}
        self._counts: dict[str, int] = {}

    def _decoder(self, typename: str, md5: str, definition: str) -> Decoder | None:
        """The fast decoder of a (type, MD5) pair, registering the type from ``definition`` when the store lacks
        it or has another definition of it."""
        key = (typename, md5)
        if key not in self._decoders:
            known = typename in self.ts.types and self.ts.generate_msgdef(typename)[1] == md5
            if not known and definition:
                self.ts.register(get_types_from_msg(definition, typename))
            self._decoders[key] = ros1_decoder(typename, md5, self.ts)
        return self._decoders[key]

    def decode(self, topic: str, msgtype: str, md5: str, definition: str, data: bytes, received_ns: int) -> BagMessage:
        """The message of a topic's ROS 1 bytes, received at ``received_ns`` (its record time).

        Raises
        ------
        ValueError
            If the bytes do not decode as ``msgtype`` (naming the topic).
        """
        typename = store_name(msgtype)
        decode = self._decoder(typename, md5, definition)
        try:
            msg = self.ts.deserialize_ros1(data, typename) if decode is None else decode(data)
        except Exception as exc:  # rosbags raises several error types for bad bytes
            raise ValueError(
                f"topic {topic!r}: cannot decode a {msgtype} message: {type(exc).__name__}: {exc}"
            ) from None
        index = self._counts.get(topic, 0)
        self._counts[topic] = index + 1
        stamp = header_stamp_ns(msg)
        header = getattr(msg, "header", None)
        frame_id = str(header.frame_id).lstrip("/") if header is not None else ""
        return BagMessage(topic, typename, index, received_ns, received_ns if stamp is None else stamp, frame_id, msg)

    def encode(self, topic: str, typename: str, msg: Any) -> Encoded:
        """``msg`` (a rosbags message of ``typename``) as ROS 1 bytes for ``topic``."""
        if typename not in self._defs:
            self._defs[typename] = self.ts.generate_msgdef(typename)
        definition, md5 = self._defs[typename]
        data = bytes(self.ts.serialize_ros1(msg, typename))
        return Encoded(topic, ros1_name(typename), md5, definition, data)
