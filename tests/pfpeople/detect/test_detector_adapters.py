"""Detector adapters (pfpeople.detect.adapters): one per kind, message -> positions in the detector and grid frames.

Messages are plain namespaces with the fields of the ROS types (no bag needed). Expected grid positions are
computed by hand from the mount ``T = (x 1, y 2, yaw pi/2)``: ``(px, py) -> (1 - py, 2 + px)``.
"""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from gridbridge.params import DetectorModel
from pfpeople.config import DetectorConfig
from pfpeople.detect import BoostedSegmentDetector, HogCameraDetector, LegDetector
from pfpeople.detect.adapters import (
    ADAPTERS,
    BoostedAdapter,
    EmptyInputError,
    HogAdapter,
    LearnedAdapter,
    LegAdapter,
    MotionAdapter,
    SingleLegAdapter,
    TopicAdapter,
    adapter_factory,
    build_detector,
    make_adapter,
)
from pfpeople.detect.synthetic import render_scan
from pfpeople.io.bag.reader import BagMessage, MessageDataError
from pfpeople.sensors import Pose2D

MOUNT = Pose2D(x=1.0, y=2.0, yaw=math.pi / 2)
FIXED = np.array([[1.0, 0.0], [2.0, 1.0]])
FIXED_IN_GRID = np.array([[1.0, 3.0], [0.0, 4.0]])  # (1 - py, 2 + px)


class FixedDetector:
    """Returns FIXED whatever it is given; remembers what it was given."""

    def __init__(self, name: str = "stub") -> None:
        self.model = DetectorModel(name=name, ppv=0.9, fnr=0.2)
        self.seen: list[Any] = []

    def detect(self, data: Any, /) -> np.ndarray:
        self.seen.append(data)
        return FIXED.copy()


def _scan_msg(ranges: Any, *, range_min: float = 0.05, range_max: float = 10.0) -> BagMessage:
    r = np.asarray(ranges, dtype=np.float32)
    inc = math.radians(0.5)
    msg = SimpleNamespace(
        ranges=r,
        angle_min=-math.pi / 2,
        angle_max=-math.pi / 2 + inc * max(r.size - 1, 0),
        angle_increment=inc,
        range_min=range_min,
        range_max=range_max,
    )
    return BagMessage("/scan", "sensor_msgs/msg/LaserScan", 0, 7, 7, "laser", msg)


def _image_msg(height: int, width: int) -> BagMessage:
    msg = SimpleNamespace(
        encoding="mono8", height=height, width=width, step=width, data=np.full(height * width, 90, dtype=np.uint8)
    )
    return BagMessage("/image", "sensor_msgs/msg/Image", 0, 5, 5, "camera", msg)


def _poses_msg(xy: Any) -> BagMessage:
    poses = [SimpleNamespace(position=SimpleNamespace(x=x, y=y, z=0.0)) for x, y in xy]
    return BagMessage("/people", "geometry_msgs/msg/PoseArray", 0, 3, 3, "laser", SimpleNamespace(poses=poses))


def test_registry_has_one_adapter_per_builtin_kind() -> None:
    assert ADAPTERS == {
        "leg": LegAdapter,
        "boosted": BoostedAdapter,
        "single-legs": SingleLegAdapter,
        "learned": LearnedAdapter,
        "motion": MotionAdapter,
        "hog": HogAdapter,
        "topic": TopicAdapter,
    }
    lasers = tuple(a.laser for a in ADAPTERS.values())
    assert lasers == (True, True, True, True, True, False, False)
    assert adapter_factory("leg", {"leg": TopicAdapter}) is TopicAdapter
    registered = r"\['boosted', 'hog', 'learned', 'leg', 'motion', 'single-legs', 'topic'\]"
    with pytest.raises(ValueError, match=r"no detector adapter for kind 'radar'; registered: " + registered):
        adapter_factory("radar")


def test_leg_adapter_finds_a_person_and_maps_it_through_the_mount() -> None:
    cfg = DetectorConfig(name="legs", kind="leg", topic="/scan", model={"ppv": 0.8})
    adapter = make_adapter(cfg, MOUNT)
    assert isinstance(adapter, LegAdapter) and isinstance(adapter.detector, LegDetector)
    m = adapter.model
    assert (m.name, m.ppv, m.mount_x, m.mount_y, m.mount_yaw) == ("legs", 0.8, 1.0, 2.0, math.pi / 2)
    person = (2.0, 0.5)  # laser frame; legs 0.3 m apart across the bearing
    b = math.atan2(person[1], person[0])
    px, py = -math.sin(b) * 0.15, math.cos(b) * 0.15
    legs = [(person[0] + px, person[1] + py, 0.06), (person[0] - px, person[1] - py, 0.06)]
    scan = render_scan(circles=legs, angle_increment=math.radians(0.5))
    out = adapter.detect([_scan_msg(scan.ranges)])
    assert out.sensor.shape == (1, 2) and np.allclose(out.sensor, [person], atol=0.1)
    assert np.allclose(out.grid, MOUNT.apply(out.sensor), atol=1e-12)
    assert out.scan is not None and out.scan.ranges.size == scan.ranges.size


def test_laser_adapter_with_a_given_detector_maps_its_positions_exactly() -> None:
    det = FixedDetector()
    adapter = LegAdapter(DetectorConfig(name="legs", kind="leg", topic="/scan"), MOUNT, det)
    assert adapter.model is det.model
    out = adapter.detect([_scan_msg(np.full(11, 3.0))])
    assert np.array_equal(out.sensor, FIXED) and np.allclose(out.grid, FIXED_IN_GRID, atol=1e-12)
    assert det.seen[0].ranges.tolist() == [3.0] * 11
    # the 11 beams cover 5 deg of the detector's 180: its model in this frame (pfpeople.detect.coverage)
    view = (-math.pi / 2, -math.pi / 2 + math.radians(0.5) * 10.5)
    assert out.field_of_view == pytest.approx(view) and adapter.model.fov_max == pytest.approx(view[1])
    assert replace(adapter.model, fov_max=det.model.fov_max) == det.model


def test_laser_adapter_reports_empty_and_bad_scans_as_data_errors() -> None:
    adapter = LegAdapter(DetectorConfig(name="legs", kind="leg", topic="/scan"), MOUNT, FixedDetector())
    with pytest.raises(EmptyInputError, match="'/scan': empty LaserScan") as info:
        adapter.detect([_scan_msg([])])
    assert (info.value.topic, info.value.stamp_ns) == ("/scan", 7)
    with pytest.raises(MessageDataError, match="all 5 ranges are NaN"):
        adapter.detect([_scan_msg(np.full(5, np.nan))])
    with pytest.raises(MessageDataError, match="range_min"):
        adapter.detect([_scan_msg(np.ones(5), range_min=20.0)])
    assert isinstance(MessageDataError("x"), ValueError)  # callers catching ValueError still catch it


def test_boosted_adapter_builds_the_boosted_detector_and_maps_positions() -> None:
    cfg = DetectorConfig(name="boost", kind="boosted", topic="/scan")
    adapter = make_adapter(cfg, MOUNT)
    assert isinstance(adapter, BoostedAdapter) and isinstance(adapter.detector, BoostedSegmentDetector)
    assert (adapter.model.name, adapter.model.mount_yaw) == ("boost", math.pi / 2)
    given = BoostedAdapter(cfg, MOUNT, FixedDetector())
    assert np.allclose(given.detect([_scan_msg(np.full(11, 3.0))]).grid, FIXED_IN_GRID, atol=1e-12)


def test_hog_adapter_is_self_mounted_and_rejects_images_of_another_size() -> None:
    cfg = DetectorConfig(name="cam", kind="hog", topic="/image")
    adapter = make_adapter(cfg, MOUNT)
    assert isinstance(adapter, HogAdapter) and isinstance(adapter.detector, HogCameraDetector)
    assert adapter.detector.mounting == MOUNT  # the detector places its positions in the grid frame itself
    assert adapter.detect([_image_msg(480, 640)]).grid.shape == (0, 2)  # a grey image: nobody
    with pytest.raises(MessageDataError, match=r"image has shape \(48, 64\) \(H, W\) but the intrinsics are for"):
        adapter.detect([_image_msg(48, 64)])
    stub = HogAdapter(cfg, MOUNT, FixedDetector())  # no intrinsics: any size
    out = stub.detect([_image_msg(48, 64)])
    assert np.array_equal(out.grid, FIXED) and np.array_equal(out.sensor, FIXED)  # not mounted twice


def test_topic_adapter_reads_every_message_and_maps_them() -> None:
    cfg = DetectorConfig(name="bag", kind="topic", topic="/people", assign="preceding", model={"ppv": 0.9, "fnr": 0.2})
    adapter = make_adapter(cfg, MOUNT)
    assert isinstance(adapter, TopicAdapter) and adapter.detector is None and adapter.nobody_when_missing
    assert (adapter.model.ppv, adapter.model.fnr, adapter.model.mount_x) == (0.9, 0.2, 1.0)
    out = adapter.detect([_poses_msg([FIXED[0]]), _poses_msg([FIXED[1]])])
    assert np.array_equal(out.sensor, FIXED) and np.allclose(out.grid, FIXED_IN_GRID, atol=1e-12)
    empty = adapter.detect([_poses_msg([])])
    assert empty.grid.shape == (0, 2)
    bad = BagMessage("/people", "std_msgs/msg/String", 0, 0, 0, "", SimpleNamespace(data="hi"))
    with pytest.raises(MessageDataError, match="'std_msgs/msg/String' holds no positions"):
        adapter.check_first(bad)
    nearest = make_adapter(DetectorConfig(name="n", kind="topic", topic="/p", model={"ppv": 0.9, "fnr": 0.2}), MOUNT)
    assert not nearest.nobody_when_missing


def test_build_detector_keeps_its_public_behaviour() -> None:
    det = build_detector(DetectorConfig(name="legs", kind="leg", topic="/scan"), MOUNT)
    assert isinstance(det, LegDetector) and (det.model.name, det.model.mount_x) == ("legs", 1.0)
    topic = DetectorConfig(name="t", kind="topic", topic="/p", model={"ppv": 0.9, "fnr": 0.2})
    assert build_detector(topic, MOUNT) is None
    with pytest.raises(ValueError, match=r"detector 'legs' \(leg\): LegDetector has no constructor argument 'nope'"):
        build_detector(DetectorConfig(name="legs", kind="leg", topic="/scan", params={"nope": 1}), MOUNT)
