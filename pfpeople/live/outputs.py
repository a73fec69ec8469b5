"""A frame's results as the messages a live node publishes: the result bag's topics and types.

The same messages as a result bag (:mod:`pfpeople.io.bag.writer`, built by its own code), on the same topics under
a prefix (default ``/pfpeople``):

- ``<prefix>/belief`` ``nav_msgs/OccupancyGrid``: the belief, in the grid frame (robot-centric);
- ``<prefix>/people`` ``people_msgs/People`` and ``<prefix>/people_markers`` ``visualization_msgs/MarkerArray``;
- ``<prefix>/tracks`` ``people_msgs/People`` (a Person per confirmed track: id, position, velocity, score and the
  position covariance), ``<prefix>/tracked_persons`` ``spencer_tracking_msgs/TrackedPersons`` (position and
  velocity covariance, age) and ``<prefix>/track_markers`` (spheres, id labels, velocity arrows);
- ``<prefix>/detections/<detector>`` ``geometry_msgs/PoseArray``: each detector's detections (grid frame).

People, tracks and their markers are in the output frame (``[output] frame``, e.g. ``odom``) when the run has one,
else in the grid frame; in a frame where the output frame's pose is unknown they are not published. Header stamps
are the source scan's.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from gridbridge.grid import GridSpec
from pfpeople.io.bag.reader import header_stamp_ns
from pfpeople.io.bag.track_messages import TRACKED_PERSONS_TYPE, track_table
from pfpeople.io.bag.writer import (
    TOPIC_BELIEF,
    TOPIC_PEOPLE,
    TOPIC_PEOPLE_MARKERS,
    TOPIC_TRACK_MARKERS,
    TOPIC_TRACKED_PERSONS,
    TOPIC_TRACKS,
    ResultBagWriter,
    detector_topics,
)
from pfpeople.pipeline.output_frame import results_in
from pfpeople.run_state import FrameResult

__all__ = ["DEFAULT_PREFIX", "ResultMessages"]

#: The namespace of the result topics (as in a result bag).
DEFAULT_PREFIX = "/pfpeople"

_TYPES = {
    TOPIC_BELIEF: "nav_msgs/msg/OccupancyGrid",
    TOPIC_PEOPLE: "people_msgs/msg/People",
    TOPIC_PEOPLE_MARKERS: "visualization_msgs/msg/MarkerArray",
    TOPIC_TRACKS: "people_msgs/msg/People",
    TOPIC_TRACK_MARKERS: "visualization_msgs/msg/MarkerArray",
    TOPIC_TRACKED_PERSONS: TRACKED_PERSONS_TYPE,
}


class ResultMessages(ResultBagWriter):
    """The result bag's messages of each frame, made by the result bag writer's own builders, for a topic rather
    than a bag (no file is opened: the writer's ``__init__`` is not run).

    Parameters
    ----------
    typestore : rosbags Typestore
        The store the messages are built in (ROS 1 Noetic with ``people_msgs``: :class:`pfpeople.live.codec.
        Ros1Codec`'s).
    spec : GridSpec
        The grid.
    grid_frame : str
        The grid frame (the belief's and the detections' header frame).
    detector_names : sequence of str
        The detectors (one PoseArray topic each).
    output_frame : str, optional
        The frame of the people, tracks and markers (default the grid frame).
    prefix : str
        The topics' namespace (``/pfpeople`` as in a result bag).
    """

    def __init__(  # the bag writer's __init__ opens a bag: only the builders' state is set here
        self,
        typestore: Any,
        *,
        spec: GridSpec,
        grid_frame: str,
        detector_names: Sequence[str],
        output_frame: str | None = None,
        prefix: str = DEFAULT_PREFIX,
    ) -> None:
        self.ts = typestore
        self.ros2 = False
        self.spec = spec
        self.frame_id = grid_frame
        self.results_frame_id = output_frame or grid_frame
        self.output = bool(output_frame) and output_frame != grid_frame
        self.arrow_time_s = 1.0
        self._seq = 0
        self.prefix = prefix.rstrip("/")
        topics, _renamed = detector_topics(detector_names)
        self.detection_topics = [self._topic(t) for t in topics.values()]

    def _topic(self, topic: str) -> str:
        """A result bag topic (``/pfpeople/...``) under this prefix."""
        return self.prefix + topic.removeprefix(DEFAULT_PREFIX)

    @staticmethod
    def topic_types(detector_names: Sequence[str], prefix: str = DEFAULT_PREFIX) -> dict[str, str]:
        """Every output topic and its type (rosbags spelling), known before the first frame."""
        base = prefix.rstrip("/")
        out = {base + t.removeprefix(DEFAULT_PREFIX): typename for t, typename in _TYPES.items()}
        for t in detector_topics(detector_names)[0].values():
            out[base + t.removeprefix(DEFAULT_PREFIX)] = "geometry_msgs/msg/PoseArray"
        return out

    def frame(self, result: FrameResult) -> list[tuple[str, str, Any]]:
        """``(topic, type, message)`` of every message of one frame, in the result bag's order."""
        f = result.frame
        stamp = header_stamp_ns(f.driver.msg) or f.stamp_ns
        people, tracks = results_in(result, output=self.output)
        out: list[tuple[str, Any]] = [(TOPIC_BELIEF, self._grid(stamp, np.asarray(result.belief, dtype=float)))]
        if people is not None:
            reliability = result.people_probability if len(result.people_probability) == len(people) else None
            out.append((TOPIC_PEOPLE, self._people(stamp, people, reliability)))
            out.append((TOPIC_PEOPLE_MARKERS, self._people_markers(stamp, people)))
        msgs = [(self._topic(t), _TYPES[t], m) for t, m in out]
        for topic, det in zip(self.detection_topics, result.detections, strict=True):
            if det is not None:
                msgs.append((topic, "geometry_msgs/msg/PoseArray", self._pose_array(stamp, det)))
        if tracks is not None:
            table = track_table(tracks)
            msgs.append((self._topic(TOPIC_TRACKS), _TYPES[TOPIC_TRACKS], self._tracks(stamp, table)))
            msgs.append((self._topic(TOPIC_TRACK_MARKERS), _TYPES[TOPIC_TRACK_MARKERS], self._markers(stamp, table)))
            persons = self._tracked_persons(stamp, table)
            msgs.append((self._topic(TOPIC_TRACKED_PERSONS), _TYPES[TOPIC_TRACKED_PERSONS], persons))
        self._seq += 1
        return msgs
