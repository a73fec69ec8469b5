"""A Foxglove layout for a result bag: ``OUT.foxglove-layout.json`` beside ``OUT`` (a ``.bag`` or a folder).

Import it in Foxglove (Layouts -> Import from file) after opening the bag. It has two panels:

- a **3D** panel (``3D!pfpeople``) following the grid frame, with every LaserScan of the bag (points),
  the people and track markers (``/pfpeople/people_markers``, ``/pfpeople/track_markers``: spheres, id
  labels, velocity arrows), the belief grid (``/pfpeople/belief``, as a map) and the TF tree (``/tf``,
  ``/tf_static``: Foxglove reads them without a setting);
- a **Raw Messages** panel on ``/pfpeople/tracks`` (``people_msgs/People``: ids in ``name``, velocities).

The detection PoseArrays are listed but hidden (tick them in the 3D panel's topic list). The file is plain
JSON in the format of Foxglove's "Export layout" (``configById``, ``layout``, ``globalVariables``,
``userNodes``, ``playbackConfig``); a viewer that does not know a setting ignores it.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pfpeople.io.files import replace_text

__all__ = ["layout", "layout_path", "write_layout"]

_SCAN_TYPE = "sensor_msgs/msg/LaserScan"
_MARKERS = ("/pfpeople/people_markers", "/pfpeople/track_markers")


def layout_path(bag_path: str | Path) -> Path:
    """Where the layout of the bag ``bag_path`` goes: ``OUT.foxglove-layout.json`` beside it."""
    p = Path(bag_path)
    return p.parent / f"{p.name}.foxglove-layout.json"


def _topic_settings(topics: Mapping[str, str]) -> dict[str, Any]:
    settings: dict[str, Any] = {}
    for topic, msgtype in topics.items():
        if msgtype == _SCAN_TYPE:
            settings[topic] = {"visible": True, "pointSize": 3, "colorField": "range", "colorMode": "colormap"}
        elif topic in _MARKERS:
            settings[topic] = {"visible": True}
        elif msgtype == "nav_msgs/msg/OccupancyGrid":
            settings[topic] = {"visible": True, "colorMode": "map", "alpha": 0.6}
        elif msgtype == "geometry_msgs/msg/PoseArray":
            settings[topic] = {"visible": False}
    return settings


def layout(topics: Mapping[str, str], frame_id: str) -> dict[str, Any]:
    """The layout (a JSON object) for a bag with ``topics`` (topic -> type), following ``frame_id``."""
    three_d = {
        "followTf": frame_id,
        "followMode": "follow-pose",
        "cameraState": {"distance": 15, "perspective": False, "phi": 0, "thetaOffset": 90},
        "scene": {"transforms": {"showLabel": True}},
        "transforms": {},
        "topics": _topic_settings(topics),
        "layers": {"grid": {"layerId": "foxglove.Grid", "visible": True, "size": 20, "divisions": 20}},
    }
    raw = {"topicPath": "/pfpeople/tracks", "diffEnabled": False, "expansion": "all"}
    return {
        "configById": {"3D!pfpeople": three_d, "RawMessages!pfpeople": raw},
        "globalVariables": {},
        "userNodes": {},
        "playbackConfig": {"speed": 1},
        "layout": {
            "first": "3D!pfpeople",
            "second": "RawMessages!pfpeople",
            "direction": "row",
            "splitPercentage": 70,
        },
    }


def write_layout(bag_path: str | Path, topics: Mapping[str, str], frame_id: str) -> Path:
    """Write :func:`layout` to :func:`layout_path` of ``bag_path`` (replacing an old one); returns the path."""
    out = layout_path(bag_path)
    replace_text(out, json.dumps(layout(topics, frame_id), indent=2) + "\n")  # a link at ``out`` is not followed
    return out
