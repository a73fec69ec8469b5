"""Results as a ROS1 bag (``rosbags.rosbag1.Writer``) that opens in RViz or Foxglove.

Topics (frame: the grid frame; stamps: the frame stamps; record time: the driver's bag time):

- ``/pfpeople/belief`` ``nav_msgs/OccupancyGrid``: belief * 100 rounded to int8 (0..100). OccupancyGrid data
  are row-major with ``width`` along x: ``data[j * nx + i] = belief[i, j]``; the origin is the grid's
  lower corner ``(x0, y0)`` with identity orientation.
- ``/pfpeople/people`` ``geometry_msgs/PoseArray``: classified people.
- ``/pfpeople/detections/<detector>`` ``geometry_msgs/PoseArray``: each detector's detections (none written
  in a frame where the detector had no data).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from rosbags.rosbag1 import Writer
from rosbags.typesys import Stores, get_typestore

from gridbridge.grid import GridSpec

__all__ = ["ResultBagWriter"]


class ResultBagWriter:
    """Write the belief, people and detections of each frame into a ROS1 bag.

    Parameters
    ----------
    path : path
        Output ``.bag`` file (must not exist).
    spec : GridSpec
        The grid.
    frame_id : str
        The grid frame.
    detector_names : sequence of str
        Detector names (one PoseArray topic each).
    """

    def __init__(self, path: str | Path, *, spec: GridSpec, frame_id: str, detector_names: Sequence[str]) -> None:
        self.path = Path(path)
        if self.path.suffix != ".bag":
            raise ValueError(f"bag output {str(self.path)!r} must end in .bag (ROS1)")
        if self.path.exists():
            raise FileExistsError(f"bag output {str(self.path)!r} already exists")
        self.spec = spec
        self.frame_id = frame_id
        self.ts = get_typestore(Stores.ROS1_NOETIC)
        self._writer = Writer(self.path)
        self._writer.open()
        self._grid = self._writer.add_connection("/pfpeople/belief", "nav_msgs/msg/OccupancyGrid", typestore=self.ts)
        self._people = self._writer.add_connection("/pfpeople/people", "geometry_msgs/msg/PoseArray", typestore=self.ts)
        self._dets = [
            self._writer.add_connection(
                f"/pfpeople/detections/{re.sub(r'[^A-Za-z0-9_]', '_', n)}",
                "geometry_msgs/msg/PoseArray",
                typestore=self.ts,
            )
            for n in detector_names
        ]
        self._seq = 0
        self._closed = False

    def _header(self, stamp_ns: int) -> Any:
        T = self.ts.types
        return T["std_msgs/msg/Header"](
            seq=self._seq,
            stamp=T["builtin_interfaces/msg/Time"](sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000),
            frame_id=self.frame_id,
        )

    def _pose_array(self, stamp_ns: int, points: NDArray[np.float64]) -> Any:
        T = self.ts.types
        poses = [
            T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0),
                orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
            )
            for x, y in np.asarray(points, dtype=float).reshape(-1, 2)
        ]
        return T["geometry_msgs/msg/PoseArray"](header=self._header(stamp_ns), poses=poses)

    def write(
        self,
        bag_time_ns: int,
        stamp_ns: int,
        belief: NDArray[np.float64],
        people: NDArray[np.float64],
        detections: Sequence[NDArray[np.float64] | None],
    ) -> None:
        """Write one frame."""
        T = self.ts.types
        s = self.spec
        belief = s.check_grid(belief, "belief")
        header = self._header(stamp_ns)
        info = T["nav_msgs/msg/MapMetaData"](
            map_load_time=header.stamp,
            resolution=float(s.resolution),
            width=s.nx,
            height=s.ny,
            origin=T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](x=float(s.x0), y=float(s.y0), z=0.0),
                orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
            ),
        )
        data = np.rint(belief.T * 100.0).astype(np.int8).ravel()
        grid = T["nav_msgs/msg/OccupancyGrid"](header=header, info=info, data=data)
        w = self._writer
        w.write(self._grid, bag_time_ns, self.ts.serialize_ros1(grid, "nav_msgs/msg/OccupancyGrid"))
        w.write(
            self._people,
            bag_time_ns,
            self.ts.serialize_ros1(self._pose_array(stamp_ns, people), "geometry_msgs/msg/PoseArray"),
        )
        for conn, det in zip(self._dets, detections, strict=True):
            if det is not None:
                w.write(
                    conn,
                    bag_time_ns,
                    self.ts.serialize_ros1(self._pose_array(stamp_ns, det), "geometry_msgs/msg/PoseArray"),
                )
        self._seq += 1

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._writer.close()
