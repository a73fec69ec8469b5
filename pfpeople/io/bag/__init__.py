"""Rosbag input and output: configuration, reading, TF, time synchronisation and result bags.

Reading uses ``rosbags.highlevel.AnyReader`` (ROS1 ``.bag`` files, ROS2 folders with sqlite3 or mcap storage);
no ROS installation is needed. See :mod:`pfpeople.config` for the TOML configuration,
:mod:`pfpeople.io.bag.sync` for how frames are assembled, and :mod:`pfpeople.pipeline.runner` for the whole run.
"""

from pfpeople.config import BagConfig, DetectorConfig, FilterConfig, load_config
from pfpeople.io.bag.reader import BagReadError, BagSource, MessageDataError, open_bag_paths
from pfpeople.io.bag.sync import Frame, FrameAssembler
from pfpeople.io.bag.tf import TfBuffer

__all__ = [
    "BagConfig",
    "BagReadError",
    "BagSource",
    "DetectorConfig",
    "FilterConfig",
    "Frame",
    "FrameAssembler",
    "MessageDataError",
    "TfBuffer",
    "load_config",
    "open_bag_paths",
]
