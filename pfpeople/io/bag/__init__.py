"""Rosbag input and output: reading, inspection, TF, time synchronisation and result bags.

Reading uses ``rosbags.highlevel.AnyReader`` (ROS1 ``.bag`` files, ROS2 folders with sqlite3 or mcap storage);
no ROS installation is needed. See :mod:`pfpeople.config` for the TOML configuration,
:mod:`pfpeople.io.bag.sync` for how frames are assembled, and :mod:`pfpeople.pipeline.runner` for the whole run.
"""

from pfpeople.io.bag.reader import BagReadError, BagSource, MessageDataError, open_bag_paths
from pfpeople.io.bag.sync import Frame, FrameAssembler
from pfpeople.io.bag.tf import TfBuffer

__all__ = [
    "BagReadError",
    "BagSource",
    "Frame",
    "FrameAssembler",
    "MessageDataError",
    "TfBuffer",
    "open_bag_paths",
]
