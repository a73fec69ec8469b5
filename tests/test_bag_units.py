"""Units of the bag package: frame synchronisation, 2-D TF, configuration, run output, GT CSV, ego-motion."""

from __future__ import annotations

import math
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from evaluation.gt_csv import read_gt_csv
from evaluation.run_truth import gt_to_grid
from gridbridge.ego_motion import velocity_displacement
from gridbridge.grid import GridSpec
from pfpeople.bag.config import BagConfig, DetectorConfig, builtin_config_path, config_from_mapping, load_config
from pfpeople.bag.reader import BagMessage
from pfpeople.bag.sync import FrameAssembler
from pfpeople.bag.tf import TfBuffer, TfLookupError, yaw_from_quaternion
from pfpeople.output import RunData, RunWriter, load_run
from pfpeople.pipeline import odometry_between
from pfpeople.sensors import Pose2D

MS = 1_000_000


def msg(topic: str, stamp_ms: float, index: int = 0) -> BagMessage:
    t = round(stamp_ms * MS)
    return BagMessage(topic, "x/msg/Y", index, t, t, "f", None)


def run_sync(asm: FrameAssembler, stream: list[BagMessage]) -> list:
    frames = []
    for m in stream:
        frames += asm.push(m)
    return frames + asm.finish()


# -- sync ------------------------------------------------------------------------------------------------------


def test_nearest_within_tolerance_else_no_data() -> None:
    asm = FrameAssembler("/scan", {"/cam": "nearest"}, tolerance_ns=30 * MS)
    stream = [msg("/scan", 0), msg("/cam", 20), msg("/cam", 45), msg("/scan", 100), msg("/cam", 140), msg("/scan", 200)]
    frames = run_sync(asm, stream)
    assert [f.stamp_ns for f in frames] == [0, 100 * MS, 200 * MS]
    assert [m.stamp_ns for m in frames[0].inputs["/cam"]] == [20 * MS]  # 20 ms beats 45 ms
    assert frames[1].inputs["/cam"] == []  # nearest is 40 ms away > 30 ms tolerance
    assert frames[2].inputs["/cam"] == []
    assert asm.stats["frames"]["emitted"] == 3


def test_nearest_waits_for_a_later_closer_message() -> None:
    asm = FrameAssembler("/scan", {"/cam": "nearest"}, tolerance_ns=50 * MS)
    assert asm.push(msg("/cam", 80)) == []
    assert asm.push(msg("/scan", 100)) == []  # a closer /cam may still come
    out = asm.push(msg("/cam", 105))
    assert len(out) == 1 and out[0].inputs["/cam"][0].stamp_ns == 105 * MS


def test_preceding_takes_the_messages_up_to_the_next_frame() -> None:
    asm = FrameAssembler("/scan", {"/people": "preceding"}, tolerance_ns=50 * MS)
    stream = [
        msg("/scan", 0),
        msg("/people", 20),
        msg("/people", 20),
        msg("/scan", 100),
        msg("/scan", 200),
        msg("/people", 220),
    ]
    frames = run_sync(asm, stream)
    assert [len(f.inputs["/people"]) for f in frames] == [2, 0, 1]


def test_interpolate_brackets_the_frame_stamp() -> None:
    asm = FrameAssembler("/scan", {"/odom": "interpolate"}, tolerance_ns=20 * MS)
    stream = [msg("/odom", 0), msg("/odom", 30), msg("/scan", 40), msg("/odom", 60), msg("/scan", 200)]
    frames = run_sync(asm, stream)
    assert [m.stamp_ns for m in frames[0].inputs["/odom"]] == [30 * MS, 60 * MS]
    assert frames[1].inputs["/odom"] == []  # 140 ms after the last odometry: beyond the tolerance


def test_non_monotonic_messages_are_skipped_and_counted(caplog: pytest.LogCaptureFixture) -> None:
    asm = FrameAssembler("/scan", {"/cam": "nearest"}, tolerance_ns=30 * MS)
    stream = [
        msg("/scan", 0),
        msg("/scan", 100),
        msg("/scan", 50),
        msg("/scan", 100),
        msg("/cam", 90),
        msg("/cam", 80),
        msg("/scan", 200),
    ]
    frames = run_sync(asm, stream)
    assert [f.stamp_ns // MS for f in frames] == [0, 100, 200]
    assert asm.stats["non_monotonic"] == {"/scan": 2, "/cam": 1}
    assert caplog.text.count("is not after the previous one") == 2  # once per topic


def test_silent_topic_forces_frames_after_max_pending() -> None:
    asm = FrameAssembler("/scan", {"/people": "preceding"}, tolerance_ns=0, max_pending=3)
    frames = []
    for k in range(10):
        frames += asm.push(msg("/scan", 100 * k))
    # The driver is more than two tolerances past each bound: frames go out without waiting.
    assert len(frames) >= 7
    asm2 = FrameAssembler("/scan", {"/cam": "nearest"}, tolerance_ns=10**12, max_pending=3)
    out = []
    for k in range(10):
        out += asm2.push(msg("/scan", 100 * k))
    assert len(out) == 7 and all(f.forced for f in out) and asm2.stats["frames"]["forced"] == 7  # 3 still wait


def test_memory_does_not_grow_with_the_stream() -> None:
    asm = FrameAssembler("/scan", {"/cam": "nearest", "/odom": "interpolate"}, tolerance_ns=30 * MS)

    def feed(k0: int, n: int) -> None:
        for k in range(k0, k0 + n):
            asm.push(msg("/odom", 100 * k - 5))
            asm.push(msg("/cam", 100 * k + 3))
            asm.push(msg("/scan", 100 * k))

    feed(0, 2000)
    tracemalloc.start()
    before = tracemalloc.take_snapshot()
    feed(2000, 20000)
    after = tracemalloc.take_snapshot()
    tracemalloc.stop()
    grown = sum(s.size_diff for s in after.compare_to(before, "filename") if "sync.py" in str(s.traceback))
    assert grown < 20_000  # bytes; 20000 more frames, so < 1 byte per frame
    assert len(asm._pending) <= 2 and all(len(t.buffer) <= 3 for t in asm._topics.values())


def test_sync_rejects_bad_arguments() -> None:
    with pytest.raises(ValueError, match="sync policy of topic '/x'"):
        FrameAssembler("/scan", {"/x": "closest"}, tolerance_ns=0)
    with pytest.raises(ValueError, match="both the driver and a secondary"):
        FrameAssembler("/scan", {"/scan": "nearest"}, tolerance_ns=0)
    asm = FrameAssembler("/scan", {}, tolerance_ns=0)
    with pytest.raises(ValueError, match="topic '/other'"):
        asm.push(msg("/other", 0))


# -- TF --------------------------------------------------------------------------------------------------------


def test_tf_composes_mounts_along_the_tree() -> None:
    tf = TfBuffer(fallback_parent="base_link", fallback={"camera": (0.5, 0.0, 0.0)})
    tf.set_transform("base_link", "laser", Pose2D(x=0.2, y=0.1, yaw=math.pi / 2))
    tf.set_transform("/laser", "/laser_child", Pose2D(x=1.0, y=0.0, yaw=0.0))
    p = tf.lookup("base_link", "laser_child")  # 1 m along the laser's x = +y of base_link
    assert (p.x, p.y, p.yaw) == pytest.approx((0.2, 1.1, math.pi / 2))
    q = tf.lookup("laser", "camera")  # camera at (0.5, 0) in base_link, seen from the rotated laser
    np.testing.assert_allclose(q.apply(np.zeros((1, 2))), [[-0.1, -0.3]], atol=1e-12)
    np.testing.assert_allclose(tf.lookup("camera", "laser").compose(q).yaw, 0.0, atol=1e-12)
    with pytest.raises(TfLookupError, match=r"no transform from frame 'map' to frame 'laser'; known frames: \["):
        tf.lookup("laser", "map")
    assert yaw_from_quaternion(0.0, 0.0, math.sin(0.35), math.cos(0.35)) == pytest.approx(0.7)


# -- config ----------------------------------------------------------------------------------------------------


def test_config_round_trip_and_errors(tmp_path: Path) -> None:
    cfg = load_config(builtin_config_path("person_following_outdoor_1"))
    assert cfg.driver == "/scan_base2" and cfg.time_source == "bag"
    assert [d.kind for d in cfg.detectors] == ["leg", "boosted"]
    assert config_from_mapping(cfg.to_dict()) == cfg
    with pytest.raises(ValueError, match=r"unknown keys \['drivr'\] in \[frames\]"):
        config_from_mapping({"frames": {"drivr": "/scan"}})
    with pytest.raises(ValueError, match=r"driver .* is required"):
        config_from_mapping({"frames": {}})
    with pytest.raises(ValueError, match="sync_tolerance_s must be a finite non-negative"):
        BagConfig(driver="/s", detectors=(DetectorConfig(name="a", kind="leg", topic="/s"),), sync_tolerance_s=-1)
    with pytest.raises(ValueError, match=r"DetectorConfig\(p\).model must give ppv and fnr"):
        DetectorConfig(name="p", kind="topic", topic="/p")
    with pytest.raises(ValueError, match=r"model has unknown fields \['pvv'\]"):
        DetectorConfig(name="p", kind="leg", topic="/p", model={"pvv": 0.3})
    with pytest.raises(ValueError, match="names must be unique"):
        BagConfig(driver="/s", detectors=(DetectorConfig(name="a", kind="leg", topic="/s"),) * 2)
    bad = tmp_path / "bad.toml"
    bad.write_text("[frames\n")
    with pytest.raises(ValueError, match=r"bad.toml' is not valid TOML"):
        load_config(bad)
    with pytest.raises(FileNotFoundError, match=r"available: \['person_following_outdoor_1'"):
        builtin_config_path("nope")
    with pytest.raises(ValueError, match=r"\[tf\] topics must be an array"):  # not the characters of "/tf"
        config_from_mapping({"frames": {"driver": "/s"}, "tf": {"topics": "/tf"}})


# -- output ----------------------------------------------------------------------------------------------------


def test_run_output_is_readable_while_written_and_after_a_crash(tmp_path: Path) -> None:
    spec = GridSpec(nx=4, ny=3)
    w = RunWriter(tmp_path / "run", spec=spec, detector_names=["a", "b"], metadata={"x": 1})
    for k in range(3):
        w.write_frame(
            frame=k,
            driver_index=10 + k,
            stamp_ns=k * 100,
            bag_time_ns=k * 100 + 1,
            dt_s=0.1,
            odometry=(0.5, 0.1),
            forced=False,
            belief=np.full(spec.shape, 0.1 * k),
            people=np.array([[1.0, 0.5]]) if k else np.zeros((0, 2)),
            people_size=[2] if k else [],
            people_probability=[0.8] if k else [],
            detections=[np.array([[1.0, 0.4], [2.0, 0.0]]), None],
        )
        run = load_run(tmp_path / "run")  # the process could die here: everything written so far is readable
        assert run.n_frames == k + 1 and run.meta["status"] == "running"
    np.testing.assert_allclose(run.grids[2], 0.2, rtol=1e-6)
    assert list(run.frames["driver_index"]) == [10, 11, 12] and list(run.frames["no_data"]) == ["b"] * 3
    assert list(run.people["frame"]) == [1, 2] and run.people["x_m"][0] == 1.0
    assert list(run.detections["detector"]) == ["a"] * 6
    w.close(status="complete")
    assert load_run(tmp_path / "run").meta["status"] == "complete"
    with pytest.raises(FileExistsError, match="already holds a run"):
        RunWriter(tmp_path / "run", spec=spec, detector_names=["a"])
    with pytest.raises(FileNotFoundError, match="not a run directory"):
        load_run(tmp_path)


# -- ground truth ------------------------------------------------------------------------------------------------


def test_gt_csv_reading_and_frame_assignment(tmp_path: Path) -> None:
    p = tmp_path / "gt.csv"
    p.write_text(
        "scan_index,bag_time_ns,person_id,x_laser_m,y_laser_m\n0,150,2,1.0,0.5\n2,350,2,1.5,0.25\n9,999,2,1,1\n"
    )
    gt = read_gt_csv(p)
    assert gt.key == "scan_index" and gt.frame == "laser" and gt.xy.shape == (3, 2)
    frame_of, missing = gt.assign(np.array([0, 1, 2]), np.array([100, 200, 300]), np.array([100, 200, 300]))
    assert list(frame_of) == [0, 2, -1] and missing == 1
    p2 = tmp_path / "gt2.csv"
    p2.write_text("bag_time_ns,person_id,x,y\n150,1,1,1\n320,1,1,1\n50,1,1,1\n")
    g2 = read_gt_csv(p2)
    frame_of, missing = g2.assign(
        np.array([0, 1, 2]), np.array([100, 200, 300]), np.array([100, 200, 300]), tolerance_ns=60
    )
    assert list(frame_of) == [0, 2, -1] and missing == 1  # the preceding frame, within 60 ns
    p3 = tmp_path / "gt3.csv"
    p3.write_text("stamp_ns,person_id,x,y\n100,1,1,x\n")
    with pytest.raises(ValueError, match=r"gt3.csv: line 2: x/y must be numbers"):
        read_gt_csv(p3)
    p3.write_text("frame,person_id,x,y\n")
    with pytest.raises(ValueError, match=r"needs one of the columns \['scan_index', 'stamp_ns', 'bag_time_ns'\]"):
        read_gt_csv(p3)


def test_gt_frames_map_into_the_grid_frame(tmp_path: Path) -> None:
    p = tmp_path / "gt.csv"
    p.write_text("scan_index,person_id,x_laser_m,y_laser_m\n0,1,1.0,0.0\n")
    gt = read_gt_csv(p)

    def run(grid_frame: str, frames_in_grid: dict[str, list[float]]) -> RunData:
        meta = {"grid_frame": grid_frame, "frames_in_grid": frames_in_grid}
        return RunData(
            path=tmp_path, meta=meta, grids=np.zeros((0, 1, 1), np.float32), frames={}, people={}, detections={}
        )

    # Grid on the driving laser: "laser" is an alias of the grid frame.
    np.testing.assert_allclose(
        gt_to_grid(run("base_laser_link", {"base_laser_link": [0, 0, 0]}), gt, "laser"), [[1, 0]]
    )
    # Grid on base_link with a recorded "laser" frame: its mount applies.
    mounted = run("base_link", {"base_link": [0, 0, 0], "laser": [0.2, 0.1, math.pi / 2]})
    np.testing.assert_allclose(gt_to_grid(mounted, gt, "laser"), [[0.2, 1.1]], atol=1e-12)
    with pytest.raises(ValueError, match="ground-truth frame 'camera' is not known"):
        gt_to_grid(mounted, gt, "camera")


# -- ego-motion ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("v", "w"), [(0.5, 0.0), (0.8, 0.6), (-0.3, -1.2), (0.0, 0.9)])
def test_odometry_between_inverts_the_velocity_model(v: float, w: float) -> None:
    dt = 0.1
    dx, dy, dth = velocity_displacement(v, w, dt)
    p0 = Pose2D(x=3.0, y=-1.0, yaw=2.5)
    p1 = p0.compose(Pose2D(x=float(dx), y=float(dy), yaw=float(dth)))
    odo, lateral = odometry_between(p0, p1, dt)
    assert odo.v == pytest.approx(v, abs=1e-9) and odo.omega == pytest.approx(w, abs=1e-9)
    assert lateral == pytest.approx(0.0, abs=1e-12)
    _, lat = odometry_between(Pose2D(), Pose2D(y=0.05), dt)  # pure sideways motion: all lateral
    assert lat == pytest.approx(0.05)


# -- images ----------------------------------------------------------------------------------------------------


def test_image_messages_decode_to_bgr() -> None:
    import cv2
    from rosbags.typesys import Stores, get_typestore

    from pfpeople.bag.reader import image_from_msg

    T = get_typestore(Stores.ROS2_HUMBLE).types
    header = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=1, nanosec=0), frame_id="cam")
    rgb = np.zeros((4, 5, 3), dtype=np.uint8)
    rgb[..., 0] = 200  # red in RGB
    padded = np.zeros((4, 16), dtype=np.uint8)  # step 16 > 5 * 3: row padding is dropped
    padded[:, :15] = rgb.reshape(4, 15)
    msg = T["sensor_msgs/msg/Image"](
        header=header, height=4, width=5, encoding="rgb8", is_bigendian=0, step=16, data=padded.ravel()
    )
    img = image_from_msg(msg, "sensor_msgs/msg/Image", stamp_ns=1, frame_id="cam", topic="/img")
    assert img.pixels.shape == (4, 5, 3) and img.pixels[0, 0].tolist() == [0, 0, 200]  # BGR
    ok, png = cv2.imencode(".png", img.pixels)
    assert ok
    cmsg = T["sensor_msgs/msg/CompressedImage"](header=header, format="png", data=png.ravel())
    dec = image_from_msg(cmsg, "sensor_msgs/msg/CompressedImage", stamp_ns=1, frame_id="cam", topic="/img")
    np.testing.assert_array_equal(dec.pixels, img.pixels)
    bad = T["sensor_msgs/msg/CompressedImage"](header=header, format="jpeg", data=np.arange(50, dtype=np.uint8))
    with pytest.raises(ValueError, match=r"topic '/img': CompressedImage .* cannot be decoded"):
        image_from_msg(bad, "sensor_msgs/msg/CompressedImage", stamp_ns=1, frame_id="cam", topic="/img")
    msg16 = T["sensor_msgs/msg/Image"](
        header=header, height=1, width=1, encoding="16UC1", is_bigendian=0, step=2, data=np.zeros(2, np.uint8)
    )
    with pytest.raises(ValueError, match=r"image encoding '16UC1' not supported"):
        image_from_msg(msg16, "sensor_msgs/msg/Image", stamp_ns=1, frame_id="cam", topic="/img")
