"""The bag pipeline end to end: synthetic ROS1 / ROS2 bags written here with rosbags, bad input, real data.

The synthetic scene: the robot drives an arc (v = 0.5 m/s, omega = 0.15 rad/s, 2 s) past two people standing
still in the odom frame; a laser mounted on base_link at (0.2 m, 0.1 m, yaw 0.3 rad) through /tf_static sees
their legs (circles of 6 cm radius 0.3 m apart, ray-cast by ``render_scan``); odometry at 50 Hz; a message
type defined only inside the bag (``test_msgs/Person {geometry_msgs/Pose pose, uint32 id}``) carries the
true positions as a detector's output.
"""

from __future__ import annotations

import csv
import json
import logging
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from bag_fixtures import MOUNT, Truth, V, W, config, laser_pose, people_in, write_bag
from rosbags.highlevel import AnyReader

from evaluation.cli import main as eval_main
from evaluation.commands.score import score_run
from gridbridge.ego_motion import odometry_pose
from gridbridge.grid import GridSpec
from pfpeople.config import BagConfig, DetectorConfig, builtin_config_path, load_config
from pfpeople.detect.synthetic import render_scan
from pfpeople.io.bag.reader import BagReadError, BagSource
from pfpeople.io.ground_truth import read_gt_csv
from pfpeople.io.run_dir import load_run
from pfpeople.pipeline.runner import Pipeline, odometry_between
from pfpeople.sensors import Pose2D


def _nearest(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from every row of b to its nearest row of a."""
    if len(a) == 0:
        return np.full(len(b), np.inf)
    return np.min(np.linalg.norm(a[:, None, :] - b[None, :, :], axis=-1), axis=0)


def _check_round_trip(results: list[Any], truth: Truth, spec: GridSpec) -> None:
    assert len(results) == len(truth.stamps_ns)
    for r, stamp, xy in zip(results, truth.stamps_ns, truth.people_laser, strict=True):
        assert r.frame.stamp_ns == stamp
        legs, topic = r.detections
        # Leg detections: segment centroids sit a few cm in front of the leg centres; 0.1 m tolerance.
        assert len(legs) == 2
        assert np.all(_nearest(legs, xy) < 0.1)
        # Detections from the custom message, mapped through TF: exact up to float rounding.
        assert topic.shape == (2, 2)
        assert np.all(_nearest(topic, xy) < 1e-6)
    # Ego-motion of the yawed, offset laser: omega exact; v and the lateral vy reproduce the laser's displacement.
    dt = 0.1
    for r, k in zip(results[1:], range(1, len(results)), strict=True):
        assert r.odometry is not None
        expect, _ = odometry_between(laser_pose(0.1 * (k - 1)), laser_pose(0.1 * k), dt)
        assert r.odometry.omega == pytest.approx(W, abs=1e-6)
        assert r.odometry.v == pytest.approx(expect.v, abs=1e-6)
        assert r.odometry.vy == pytest.approx(expect.vy, abs=1e-6) and abs(r.odometry.vy) > 0.1
        d, got = laser_pose(0.1 * (k - 1)).inverse().compose(laser_pose(0.1 * k)), odometry_pose(r.odometry, dt)
        assert (got.x, got.y, got.yaw) == pytest.approx((d.x, d.y, d.yaw), abs=1e-6)
    # Filter: high belief at the people's cells (mean over frames and people > 0.9); the reported people are
    # all within 0.3 m (one cell) of a true person. The two people stand still: they are reported once their
    # tracks are 1 s old ([tracking] static_confirm_s), in none of the first 9 frames (0.8 s) and both in
    # >= 75 % of the frames from 1 s on.
    at_people = [r.belief[spec.to_cell(x, y)] for r, xy in zip(results, truth.people_laser, strict=True) for x, y in xy]
    assert np.mean(at_people) > 0.9
    both = 0
    for k, (r, xy) in enumerate(zip(results, truth.people_laser, strict=True)):
        assert np.all(_nearest(xy, r.people) < 0.3)
        if k < 9:
            assert len(r.people) == 0
        elif k >= 10:
            both += int(len(r.people) == 2 and np.all(_nearest(r.people, xy) < 0.3))
    assert both >= 0.75 * (len(results) - 10)


def test_ros1_round_trip_recovers_positions_and_motion(tmp_path: Path) -> None:
    bag = tmp_path / "synthetic.bag"
    truth = write_bag(bag)
    with BagSource(bag) as src:
        assert src.topics["/people"] == "test_msgs/msg/Person"
        pipe = Pipeline(config())
        summary, results = pipe.run(src, tmp_path / "run", keep=True)
    _check_round_trip(results, truth, pipe.spec)
    assert summary.frames == 20 and summary.frames_without_odometry == 0
    # The laser (0.2 m ahead, 0.1 m left, yawed 0.3 rad) moves sideways in its own frame: applied as vy, and its
    # largest lateral step reported.
    lateral = max(abs(odometry_between(laser_pose(0.1 * k), laser_pose(0.1 * k + 0.1), 0.1)[1]) for k in range(19))
    assert summary.max_lateral_m == pytest.approx(lateral, rel=1e-3)
    run = load_run(tmp_path / "run")
    vy = [r.odometry.vy for r in results[1:]]
    np.testing.assert_allclose(run.frames["vy_mps"][1:], vy, rtol=1e-8)
    assert run.frames["vy_mps"][0] == 0.0 and np.all(np.abs(run.frames["vy_mps"][1:]) > 0.1)
    assert run.meta["status"] == "complete" and run.grids.shape == (20, *pipe.spec.shape)
    assert run.meta["frames_in_grid"]["laser"] == [0.0, 0.0, 0.0]
    np.testing.assert_allclose(run.grids[-1], results[-1].belief, atol=1e-6)  # float32 storage
    assert list(run.frames["driver_index"]) == list(range(20))


def test_off_axis_yawed_laser_moves_the_grid_sideways(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # A driving laser 0.85 m ahead, 0.24 m left, yawed 42 deg (as on a real robot): driving on an arc, its
    # frame moves sideways. The run's odometry carries that as vy, frames.csv records it and a replay of the
    # run gives the filters the same motion.
    import bag_fixtures

    from evaluation.harness.replay import log_from_run

    monkeypatch.setattr(bag_fixtures, "MOUNT", Pose2D(x=0.85, y=0.24, yaw=math.radians(42.0)), raising=True)
    write_bag(tmp_path / "off_axis.bag", n_scans=8)
    with BagSource(tmp_path / "off_axis.bag") as src:
        summary, results = Pipeline(config()).run(src, tmp_path / "run", keep=True)
    assert summary.frames == 8 and summary.ego_motion["odometry"] == 7
    for k, r in enumerate(results[1:], start=1):
        p0, p1 = laser_pose(0.1 * (k - 1)), laser_pose(0.1 * k)
        expect, _ = odometry_between(p0, p1, 0.1)
        assert r.odometry is not None and r.odometry.vy == pytest.approx(expect.vy, abs=1e-6)
        # The laser's velocity in the base frame is (V - W y_mount, W x_mount); its y in the laser frame:
        assert r.odometry.vy == pytest.approx(
            -math.sin(math.radians(42.0)) * (V - W * 0.24) + math.cos(math.radians(42.0)) * W * 0.85, abs=1e-6
        )
        d, got = p0.inverse().compose(p1), odometry_pose(r.odometry, 0.1)
        assert (got.x, got.y, got.yaw) == pytest.approx((d.x, d.y, d.yaw), abs=1e-6)
    log = log_from_run(tmp_path / "run", nobody=True)
    assert log.odometry[0] is None
    for odo, r in zip(log.odometry[1:], results[1:], strict=True):
        assert odo is not None and r.odometry is not None
        assert (odo.v, odo.omega, odo.vy) == pytest.approx((r.odometry.v, r.odometry.omega, r.odometry.vy), rel=1e-8)


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_ros2_round_trip_with_custom_type_in_metadata(tmp_path: Path, storage: str) -> None:
    bag = tmp_path / f"synthetic_{storage}"
    truth = write_bag(bag, ros2=True, storage=storage)
    pipe = Pipeline(config(ros2=True))
    with BagSource(bag) as src:
        assert src.topics["/people"] == "test_msgs/msg/PersonArray"
        _, results = pipe.run(src, None, keep=True)
    _check_round_trip(results, truth, pipe.spec)
    # The custom detector's frame (base_link) was composed with the inverse of the laser's TF mount.
    assert results[0].frame.inputs["/people"][0].frame_id == "base_link"
    inv = MOUNT.inverse()
    got = pipe.mounts[1]
    assert (got.x, got.y, got.yaw) == pytest.approx((inv.x, inv.y, inv.yaw), abs=1e-6)
    assert (pipe.models[1].mount_yaw, pipe.models[0].mount_yaw) == pytest.approx((-0.3, 0.0), abs=1e-6)


def test_zip_bag_is_extracted_once_into_the_cache(tmp_path: Path) -> None:
    import zipfile

    bag = tmp_path / "z.bag"
    write_bag(bag, n_scans=3)
    zpath = tmp_path / "z.bag.zip"
    with zipfile.ZipFile(zpath, "w") as zf:
        zf.write(bag, "z.bag")
    with BagSource(zpath, cache_dir=tmp_path / "cache") as src:
        assert src.message_counts["/scan"] == 3
    assert len(list((tmp_path / "cache").rglob("z.bag"))) == 1


def test_camera_driven_frames_take_the_closest_laser_scan(tmp_path: Path) -> None:
    bag = tmp_path / "cam.bag"
    write_bag(bag, n_scans=20, n_images=6)
    cfg = BagConfig(
        driver="/image",
        detectors=(
            DetectorConfig(name="camera_hog", kind="hog", topic="/image"),
            DetectorConfig(name="laser_legs", kind="leg", topic="/scan"),
        ),
        sync_tolerance_s=0.04,
    )
    with BagSource(bag) as src:
        summary, results = Pipeline(cfg).run(src, None, keep=True)
    assert summary.frames == 6
    # Images at 37 + 250 k ms; scans every 100 ms: the closest scan is 13 ms (k even) or 37 ms (k odd) away.
    for k, r in enumerate(results):
        scan = r.frame.inputs["/scan"][0]
        expect = round((37 + 250 * k) / 100)
        assert scan.index == expect and abs(scan.stamp_ns - r.frame.stamp_ns) <= 40_000_000
        assert r.detections[0] is not None and len(r.detections[0]) == 0  # a flat grey image: nobody
        assert r.detections[1] is not None and len(r.detections[1]) == 2
    # With a 10 ms tolerance no scan is close enough: the laser detector covers no cell in any frame.
    with BagSource(bag) as src:
        summary, results = Pipeline(replace(cfg, sync_tolerance_s=0.01)).run(src, None, keep=True)
    assert all(r.detections[1] is None for r in results) and summary.no_data == {"laser_legs": 6}


# -- bad input -------------------------------------------------------------------------------------------------


def test_missing_topic_names_the_topics_the_bag_has(tmp_path: Path) -> None:
    bag = tmp_path / "b.bag"
    write_bag(bag, n_scans=2)
    cfg = replace(
        config(), driver="/front_scan", detectors=(DetectorConfig(name="l", kind="leg", topic="/front_scan"),)
    )
    with (
        BagSource(bag) as src,
        pytest.raises(
            ValueError, match=r"\['/front_scan'\] not in bag .*the bag has: .*/scan \(sensor_msgs/msg/LaserScan\)"
        ),
    ):
        Pipeline(cfg).run(src, None)


def test_wrong_message_type_is_named(tmp_path: Path) -> None:
    bag = tmp_path / "b.bag"
    write_bag(bag, n_scans=2)
    cfg = replace(config(), detectors=(DetectorConfig(name="l", kind="leg", topic="/odom"),), odometry="")
    with (
        BagSource(bag) as src,
        pytest.raises(
            ValueError,
            match=r"topic '/odom' .* type 'nav_msgs/msg/Odometry'; expected one of \['sensor_msgs/msg/LaserScan'\]",
        ),
    ):
        Pipeline(cfg).run(src, None)
    # A detection topic whose message type holds no positions is refused before the run.
    cfg = replace(
        config(), detectors=(DetectorConfig(name="t", kind="topic", topic="/scan", model={"ppv": 0.9, "fnr": 0.2}),)
    )
    with (
        BagSource(bag) as src,
        pytest.raises(ValueError, match=r"topic '/scan': message type 'sensor_msgs/msg/LaserScan' holds no positions"),
    ):
        Pipeline(cfg).run(src, None)


def test_not_a_bag_gives_a_clear_error(tmp_path: Path) -> None:
    bad = tmp_path / "junk.bag"
    bad.write_bytes(b"this is not a rosbag at all" * 10)
    with pytest.raises(BagReadError, match=r"cannot open bag .*junk.bag"):
        BagSource(bad)
    with pytest.raises(FileNotFoundError, match="does not exist"):
        BagSource(tmp_path / "absent.bag")


def test_corrupt_tail_keeps_the_frames_already_processed(tmp_path: Path) -> None:
    bag = tmp_path / "c.bag"
    write_bag(bag, n_scans=40, chunk_threshold=4096)
    data = bytearray(bag.read_bytes())
    with AnyReader([bag]) as r:  # locate the chunks: corrupt the data of the last quarter of the file's chunks
        chunk_pos = sorted(c.pos for rd in r.readers for c in rd.chunk_infos)  # type: ignore[union-attr]
    start = chunk_pos[3 * len(chunk_pos) // 4]
    data[start + 300 : start + 1500] = b"\xff" * 1200
    bag.write_bytes(bytes(data))
    out = tmp_path / "run"
    with BagSource(bag) as src, pytest.raises(BagReadError, match="truncated or corrupt after"):
        Pipeline(config()).run(src, out)
    run = load_run(out)
    assert run.meta["status"] == "failed" and "BagReadError" in run.meta["error"]
    assert 5 <= run.n_frames < 40
    assert len(run.frames["frame"]) == run.n_frames and np.all(np.isfinite(run.grids[: run.n_frames]))
    assert run.meta["stats"]["frames"] == run.n_frames == run.meta["stats"]["sync"]["frames"]["emitted"]


def test_nan_inf_and_empty_scans_and_non_monotonic_stamps(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    def hook(k: int, stamp: int, ranges: np.ndarray) -> tuple[int, np.ndarray]:
        r = ranges.copy()
        if k == 3:
            r[:60] = np.nan  # NaN, inf and below-range_min returns (away from the people, at -4 and -42 deg):
            r[300:340] = np.inf  # invalid beams, not points
            r[340:] = -1.0
        if k == 5:
            r = np.zeros(0)  # empty scan
        if k == 8:
            stamp -= 250_000_000  # earlier than scan 7
        return stamp, r

    bag = tmp_path / "bad.bag"
    truth = write_bag(bag, scan_hook=hook)
    with caplog.at_level(logging.WARNING), BagSource(bag) as src:
        summary, results = Pipeline(config()).run(src, tmp_path / "run", keep=True)
    assert summary.frames == 19  # scan 8 skipped
    assert summary.sync["non_monotonic"] == {"/scan": 1}
    assert summary.empty_scans == {"laser_legs": 1} and summary.no_data["laser_legs"] == 1
    by_index = {r.frame.driver.index: r for r in results}
    assert 8 not in by_index
    assert by_index[5].detections[0] is None  # no data: covers no cell
    legs3 = by_index[3].detections[0]
    assert legs3 is not None and np.all(_nearest(legs3, truth.people_laser[3]) < 0.1)
    assert "not after the previous one" in caplog.text and "empty LaserScan" in caplog.text
    run = load_run(tmp_path / "run")
    assert run.frames["no_data"][list(run.frames["driver_index"]).index(5)] == "laser_legs"
    assert run.meta["stats"]["sync"]["non_monotonic"] == {"/scan": 1}


def test_without_odometry_the_robot_stands_and_it_is_logged_once(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    bag = tmp_path / "n.bag"
    write_bag(bag, n_scans=4, odometry=False)
    with caplog.at_level(logging.INFO), BagSource(bag) as src:
        _, results = Pipeline(config(odometry=False)).run(src, None, keep=True)
    assert all(r.odometry is None for r in results)
    assert caplog.text.count("taken as standing") == 1
    with BagSource(bag) as src:
        assert Pipeline(config(odometry=False)).run(src, None, max_frames=0)[0].frames == 0
        with pytest.raises(ValueError, match="max_frames must be an integer >= 0"):
            Pipeline(config(odometry=False)).run(src, None, max_frames=-1)


def test_a_frame_without_odometry_does_not_lose_the_motion(tmp_path: Path) -> None:
    bag = tmp_path / "g.bag"
    write_bag(bag, n_scans=10, odom_gap_s=(0.4, 0.8))
    with BagSource(bag) as src:
        summary, results = Pipeline(config()).run(src, None, keep=True)
    # The frame at 0.5 s is finalised (the driver is more than two tolerances past it) before odometry resumes
    # at 0.8 s: it takes the robot as standing. The frame at 0.6 s (bracketed by 0.4 s and 0.8 s) then moves
    # the grid by both frames' motion, from the pose of the frame at 0.4 s.
    assert summary.frames_without_odometry == 1
    assert [r.odometry is None for r in results[4:8]] == [False, True, False, False]
    got = results[6].odometry
    assert got is not None and got.omega == pytest.approx(2 * W, rel=1e-6)
    expect, _ = odometry_between(laser_pose(0.4), laser_pose(0.6), 0.1)
    assert got.v == pytest.approx(expect.v, rel=1e-2)  # odometry interpolated linearly over the gap


def test_sync_tolerance_no_data_for_a_late_topic(tmp_path: Path) -> None:
    bag = tmp_path / "s.bag"
    write_bag(bag, n_scans=6, ros2=False)
    # "nearest" with 5 ms tolerance: the Person messages come 20 ms after their scan -> no data every frame.
    people = DetectorConfig(
        name="bag-people", kind="topic", topic="/people", frame="laser", model={"ppv": 0.9, "fnr": 0.2}
    )
    cfg = replace(config(), detectors=(config().detectors[0], people), sync_tolerance_s=0.005)
    with BagSource(bag) as src:
        summary, results = Pipeline(cfg).run(src, None, keep=True)
    assert all(r.detections[1] is None for r in results)
    assert summary.no_data == {"bag-people": 6}


# -- commands --------------------------------------------------------------------------------------------------


def test_run_and_score_commands(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from pfpeople.cli import main

    bag = tmp_path / "cmd.bag"
    truth = write_bag(bag)
    cfg_path = tmp_path / "cfg.toml"
    cfg_path.write_text(
        '[frames]\ndriver = "/scan"\n[odometry]\ntopic = "/odom"\n'
        '[[detectors]]\nname = "laser_legs"\nkind = "leg"\ntopic = "/scan"\n'
        # the two people stand still from the first scan and one detector sees them: the clutter map would take
        # them for furniture after ~0.6 s
        "[clutter]\nenabled = false\n"
    )
    out = tmp_path / "run"
    rc = main(
        [
            "run",
            str(bag),
            "--config",
            str(cfg_path),
            "--out",
            str(out),
            "--bag-out",
            str(tmp_path / "o.bag"),
            "--no-progress",
        ]
    )
    assert rc == 0
    assert "20 frames in" in capsys.readouterr().out
    with AnyReader([tmp_path / "o.bag"]) as r:
        counts = {c.topic: c.msgcount for c in r.connections}
        conn = next(c for c in r.connections if c.topic == "/pfpeople/belief")
        grid: Any = r.deserialize(next(r.messages(connections=[conn]))[2], conn.msgtype)
    assert counts["/pfpeople/belief"] == 20 and counts["/pfpeople/people"] == 20
    belief0 = load_run(out).grids[0]
    nx, ny = belief0.shape
    assert (grid.info.width, grid.info.height) == (nx, ny)
    assert grid.data[5 * nx + 7] == round(float(belief0[7, 5]) * 100)  # data[j * nx + i] = belief[i, j]
    gt = tmp_path / "gt.csv"
    with gt.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["scan_index", "person_id", "x_laser_m", "y_laser_m"])
        for k, xy in enumerate(truth.people_laser):
            for pid, (x, y) in enumerate(xy):
                w.writerow([k, pid, x, y])
    rc = eval_main(["score", str(out), "--gt", str(gt), "--frame", "laser", "--json", str(tmp_path / "s.json")])
    assert rc == 0
    text = capsys.readouterr().out
    assert "laser_legs" in text and "filter" in text
    result = score_run(load_run(out), read_gt_csv(gt), frame="laser")
    legs = result["scores"]["laser_legs"]
    assert (legs["tp"], legs["fn"], legs["fp"]) == (40, 0, 0) and legs["recall"] == 1.0
    # measured 0.50: the two people stand still for 2 s and are reported from 1 s on ([tracking] static_confirm_s)
    assert 0.45 <= result["scores"]["filter"]["recall"] <= 0.55
    # A sector from -90 to -20 deg keeps only the person at -39 .. -62 deg (the other is at -2 .. -14 deg).
    left = score_run(load_run(out), read_gt_csv(gt), frame="laser", sector=(-90.0, -20.0))
    assert left["scores"]["laser_legs"]["tp"] + left["scores"]["laser_legs"]["fn"] == 20
    # The detector's field of view and range come from its LaserScan when the config leaves them out.
    model0 = load_run(out).meta["detector_models"][0]
    assert model0["max_range"] == 10.0 and model0["fov_min"] == pytest.approx(-np.pi / 2, abs=1e-6)
    cal = tmp_path / "cal.json"
    assert eval_main(["calibrate", "--run", str(out), "--gt", str(gt), "--frame", "laser", "--json", str(cal)]) == 0
    assert json.loads(cal.read_text())["matched"]["laser_legs"]["fnr"] == pytest.approx(0.0)
    capsys.readouterr()
    # Running again into the same directory is refused with a message, not a traceback.
    assert main(["run", str(bag), "--config", str(cfg_path), "--out", str(out), "--no-progress"]) == 2
    assert "already holds a run" in capsys.readouterr().err


def test_run_command_error_is_clean(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from pfpeople.cli import main

    bag = tmp_path / "e.bag"
    write_bag(bag, n_scans=2)
    assert main(["run", str(bag), "--driver", "/nope", "--out", str(tmp_path / "r"), "--no-progress"]) == 2
    assert "the bag has:" in capsys.readouterr().err


# -- real data -------------------------------------------------------------------------------------------------


@pytest.mark.realdata
@pytest.mark.parametrize(("kind", "frames", "particles"), [("grid", 600, 0), ("particle", 300, 5000)])
def test_real_bag_recall_per_detector_and_filter(
    shared_data: Path, tmp_path_factory: pytest.TempPathFactory, kind: str, frames: int, particles: int
) -> None:
    zbag = shared_data / "leg_tracker" / "person_following_outdoor_1.bag.zip"
    gt_path = shared_data / "leg_tracker" / "person_following_outdoor_1_gt.csv"
    if not zbag.is_file() or not gt_path.is_file():
        pytest.skip(f"{zbag.name} or its GT CSV is absent")
    cfg = load_config(builtin_config_path("person_following_outdoor_1"))
    cfg = replace(cfg, filter=replace(cfg.filter, kind=kind, n_particles=max(particles, 1)))
    out = tmp_path_factory.mktemp("real") / "run"
    with BagSource(zbag, cache_dir=tmp_path_factory.getbasetemp() / "bags") as src:
        summary, _ = Pipeline(cfg).run(src, out, max_frames=frames)
    assert summary.frames == frames
    result = score_run(load_run(out), read_gt_csv(gt_path), frame="laser", recall_only=True)
    s = result["scores"]
    # Measured (gate 0.5 m): first 600 scans, grid filter: legs 0.466, boosted 0.682, filter 0.867;
    # first 300 scans, particle filter (5000 particles, seed 0): legs 0.416, boosted 0.735, filter 0.863.
    assert s["laser_legs"]["recall"] > 0.35
    assert s["laser_boosted"]["recall"] > 0.35
    assert s["filter"]["recall"] > max(s["laser_legs"]["recall"], s["laser_boosted"]["recall"]) - 0.05
    assert "precision" not in s["filter"]
    # Calibration from the same ground truth: FNR only (passers-by are not annotated), FNR = 1 - recall.
    cal_json = out.parent / "cal.json"
    args = ["calibrate", "--run", str(out), "--gt", str(gt_path), "--frame", "laser", "--recall-only"]
    assert eval_main([*args, "--json", str(cal_json)]) == 0
    cal = json.loads(cal_json.read_text())["matched"]
    for name in ("laser_legs", "laser_boosted"):
        assert cal[name]["ppv"] is None
        assert cal[name]["fnr"] == pytest.approx(1.0 - s[name]["recall"], abs=1e-9)


ROOM_ODOM = [(-2.0, -3.0, 6.0, -3.0), (6.0, -3.0, 6.0, 4.0), (6.0, 4.0, -2.0, 4.0), (-2.0, 4.0, -2.0, -3.0)]


def _room_scan(k: int, stamp: int, ranges: Any) -> tuple[int, Any]:
    """scan_hook: the people's legs of ``write_bag`` inside a room (walls fixed in the odom frame)."""
    lp = laser_pose(0.1 * k)
    walls = [(*lp.inverse().apply(np.array([[a, b], [c, d]])).ravel(),) for a, b, c, d in ROOM_ODOM]
    circles = []
    for x, y in people_in(lp):
        b = math.atan2(y, x)
        px, py = -math.sin(b) * 0.15, math.cos(b) * 0.15
        circles += [(x + px, y + py, 0.06), (x - px, y - py, 0.06)]
    return stamp, render_scan(circles=circles, segments=walls, angle_increment=math.radians(0.5)).ranges


def test_run_json_says_where_the_ego_motion_came_from(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """``stats.ego_motion`` counts the frames by source and the log says it: odometry; scan matching in a room
    (every frame after the first, no warning); scan matching of legs alone (never: a warning, not "standing in
    every frame" nor silence)."""
    cases = [("odom", True, None), ("room", False, _room_scan), ("legs", False, None)]
    got: dict[str, tuple[dict[str, int], str]] = {}
    for name, odometry, hook in cases:
        bag = tmp_path / f"{name}.bag"
        write_bag(bag, n_scans=20, odometry=odometry, scan_hook=hook)
        caplog.clear()
        with caplog.at_level(logging.INFO), BagSource(bag) as src:
            summary, _ = Pipeline(config(odometry=odometry)).run(src, tmp_path / name)
        stats = json.loads((tmp_path / name / "run.json").read_text())["stats"]
        assert stats["ego_motion"] == summary.ego_motion
        assert stats["ego_motion"]["scan_matching"] == stats["laser_odometry_frames"]
        got[name] = (summary.ego_motion, caplog.text)
    assert got["odom"][0] == {"odometry": 19, "scan_matching": 0, "none": 1}
    assert got["room"][0] == {"odometry": 0, "scan_matching": 19, "none": 1}
    assert got["legs"][0] == {"odometry": 0, "scan_matching": 0, "none": 20}
    assert "0 from odometry, 19 from scan matching, 1 none" in got["room"][1]
    assert "gave the ego-motion of only" not in got["room"][1] + got["odom"][1]
    assert "scan matching of /scan gave the ego-motion of only 0 of 19 frames (0 %)" in got["legs"][1]
    assert "standing in every frame" not in got["legs"][1]
