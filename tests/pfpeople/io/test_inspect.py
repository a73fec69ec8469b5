"""``pfpeople inspect``: bag reports and starter configs on synthetic ROS 1 / ROS 2 bags and the real bags.

The synthetic bags are the scene of ``test_pipeline_bags`` (``write_bag``): /scan at 10 Hz (361 beams of
0.5 deg from -90 deg, header stamps 3 ms before their record time), /odom at 50 Hz (odom -> base_link),
/tf_static base_link -> laser at (0.2 m, 0.1 m, 0.3 rad), /people detections.
"""

from __future__ import annotations

import json
import math
import shlex
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from bag_fixtures import MOUNT, T0_NS, Msgs, typestore, write_bag
from rosbags.rosbag1 import Writer as Writer1

from pfpeople.cli import main
from pfpeople.config import FilterConfig, load_config
from pfpeople.io.bag.inspect import format_report, inspect_bag, inspect_path, starter_config
from pfpeople.io.bag.reader import BagSource
from pfpeople.pipeline.runner import Pipeline


@pytest.mark.parametrize(("ros2", "storage"), [(False, ""), (True, "sqlite3"), (True, "mcap")])
def test_synthetic_bag_report_and_config_that_runs(tmp_path: Path, ros2: bool, storage: str) -> None:
    bag = tmp_path / ("b2" if ros2 else "b.bag")
    write_bag(bag, ros2=ros2, storage=storage or "sqlite3", n_scans=12)
    report = inspect_path(bag)
    topics = {t.topic: t for t in report.topics}
    assert report.storage == ("ROS 2 bag" if ros2 else "ROS 1 bag")
    assert topics["/scan"].count == 12 and topics["/scan"].rate_hz == pytest.approx(10.0, rel=1e-9)
    assert topics["/scan"].frame_ids == ("laser",) and topics["/scan"].header_rate_hz == pytest.approx(10.0, rel=1e-9)
    assert topics["/scan"].header_offset_s == pytest.approx(-0.003, abs=1e-9)
    assert topics["/odom"].rate_hz == pytest.approx(50.0, rel=1e-9)
    (edge,) = report.tf
    assert (edge.parent, edge.child, edge.static) == ("base_link", "laser", True)
    assert (edge.x, edge.y, edge.yaw) == pytest.approx((MOUNT.x, MOUNT.y, MOUNT.yaw), abs=1e-9)
    (laser,) = report.lasers
    assert laser.beams == 361 and laser.increment_sign == 1
    assert laser.angle_min_deg == pytest.approx(-90.0, abs=1e-4)
    assert laser.fov_max_rad == pytest.approx(math.pi / 2, abs=1e-6)
    assert (laser.range_min_m, laser.range_max_m) == pytest.approx((0.05, 10.0), rel=1e-6)
    assert laser.mount_in_base == pytest.approx((MOUNT.x, MOUNT.y, MOUNT.yaw), abs=1e-9)
    (odom,) = report.odometry
    assert (odom.topic, odom.frame_id, odom.child_frame_id) == ("/odom", "odom", "base_link")
    assert report.driver == "/scan" and report.time_source == "header" and report.warnings == ()
    text = format_report(report)
    assert "base_link -> laser: x=0.200 y=0.100 yaw=17.2 (static)" in text
    assert "FOV -90.0 .. 90.0 deg, 361 beams" in text
    # The starter config loads and runs unchanged; the product's grid and filter defaults apply.
    cfg_path = tmp_path / "cfg.toml"
    cfg_path.write_text(starter_config(report))
    cfg = load_config(cfg_path)
    assert (cfg.driver, cfg.odometry, cfg.base_frame, cfg.time_source) == ("/scan", "/odom", "base_link", "header")
    assert [(d.name, d.kind, d.topic) for d in cfg.detectors] == [
        ("laser_legs", "leg", "/scan"),
        ("laser_boosted", "boosted", "/scan"),
        ("laser_single_legs", "single-legs", "/scan"),
    ]
    model = cfg.detectors[0].model
    assert model.given() == pytest.approx({"fov_min": -math.pi / 2, "fov_max": math.pi / 2, "max_range": 10}, abs=1e-5)
    assert model.fov_min <= -math.pi / 2 + 1e-7 and model.fov_max >= math.pi / 2 - 1e-7  # outwards
    assert cfg.grid.fixed is None and cfg.filter == FilterConfig() and dict(cfg.mounts) == {}
    with BagSource(bag) as src:
        summary, results = Pipeline(cfg).run(src, None, max_frames=4, keep=True)
    assert summary.frames == 4 and all(r.detections[0] is not None for r in results)


def test_far_header_stamps_choose_bag_time(tmp_path: Path) -> None:
    bag = tmp_path / "late.bag"
    write_bag(bag, n_scans=5, scan_hook=lambda k, stamp, r: (stamp + 130 * 10**9, r))
    report = inspect_path(bag)
    assert report.time_source == "bag"
    text = starter_config(report)
    assert 'time_source = "bag"' in text and "129.997 s (median) from the record times" in text


def test_burst_recorded_bag_keeps_header_time(tmp_path: Path) -> None:
    """Header stamps 1 s apart (and ~9 h before), record times 0.1 s apart: a re-written bag (ratio 0.1 < 0.25)."""
    bag = tmp_path / "burst.bag"
    write_bag(bag, n_scans=6, scan_hook=lambda k, stamp, r: (T0_NS - 32_000 * 10**9 + k * 10**9, r))
    report = inspect_path(bag)
    (scan,) = [t for t in report.topics if t.topic == "/scan"]
    assert scan.record_burst and scan.header_rate_hz == pytest.approx(1.0) and scan.rate_hz == pytest.approx(10.0)
    assert report.time_source == "header"
    assert any("recorded in a burst (10.00 Hz of record time, 1.00 Hz of header stamps)" in w for w in report.warnings)
    text = starter_config(report)
    assert 'time_source = "header"' in text and "# Recorded in a burst" in text
    # the same stamps spread like the record times are a late clock, not a burst: bag time, as before
    late = tmp_path / "late.bag"
    write_bag(late, n_scans=6, scan_hook=lambda k, stamp, r: (T0_NS - 32_000 * 10**9 + k * 10**8, r))
    report = inspect_path(late)
    assert report.time_source == "bag" and not any(t.record_burst for t in report.topics)


def test_no_tf_to_the_base_writes_a_flagged_mount(tmp_path: Path) -> None:
    bag = tmp_path / "b.bag"
    write_bag(bag, n_scans=3)
    report = inspect_path(bag)
    bare = replace(report, tf=(), lasers=tuple(replace(li, mount_in_base=None) for li in report.lasers))
    text = starter_config(bare)
    assert "NO TF connects the laser to the base frame" in text
    path = tmp_path / "c.toml"
    path.write_text(text)
    assert dict(load_config(path).mounts) == {"laser": (0.0, 0.0, 0.0)}
    with pytest.raises(ValueError, match=r"driver '/odom' is not a LaserScan topic; LaserScan topics: \['/scan'\]"):
        starter_config(report, driver="/odom")


def test_inspect_command_json_config_and_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = tmp_path / "b.bag"
    write_bag(bag, n_scans=4)
    cfg = tmp_path / "cfg.toml"
    assert main(["inspect", str(bag), "--json", "--write-config", str(cfg)]) == 0
    out = capsys.readouterr()
    data = json.loads(out.out)
    assert data["driver"] == "/scan" and data["lasers"][0]["beams"] == 361 and data["duration_s"] > 0
    assert f"pfpeople run {bag} --config {cfg}" in out.err
    assert load_config(cfg).driver == "/scan"
    assert main(["inspect", str(bag), "--write-config", str(cfg)]) == 2
    assert "exists (use --overwrite" in capsys.readouterr().err
    junk = tmp_path / "junk.bag"
    junk.write_bytes(b"not a bag at all")
    assert main(["inspect", str(junk)]) == 2
    assert f"cannot open bag {str(junk)!r}" in capsys.readouterr().err
    assert main(["inspect", str(tmp_path / "missing.bag")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_the_suggested_run_command_quotes_paths_for_the_shell(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "my bags"
    folder.mkdir()
    bag, cfg = folder / "b 1.bag", folder / "it's.toml"
    write_bag(bag, n_scans=3)
    assert main(["inspect", str(bag), "--write-config", str(cfg)]) == 0
    err = capsys.readouterr().err
    line = next(t for t in err.splitlines() if "run it with" in t)
    suggested = line.split("run it with", 1)[1].strip()
    assert shlex.split(suggested) == ["pfpeople", "run", str(bag), "--config", str(cfg)]


@pytest.mark.realdata
def test_every_real_bag(shared_data: Path, tmp_path_factory: pytest.TempPathFactory) -> None:
    bags = sorted((shared_data / "leg_tracker").glob("*.bag*"))
    if not bags:
        pytest.skip("no bags in ../shared/data/leg_tracker")
    cache = tmp_path_factory.getbasetemp() / "bags"
    out = tmp_path_factory.mktemp("inspect")
    configs = {}
    for path in bags:
        with BagSource(path, cache_dir=cache) as src:
            report = inspect_bag(src, name=str(path))
        assert report.driver is not None, path.name
        assert report.lasers and all(li.beams > 0 and li.increment_sign == 1 for li in report.lasers), path.name
        cfg_path = out / f"{path.name}.toml"
        cfg_path.write_text(starter_config(report))
        configs[path.name] = (report, load_config(cfg_path), cfg_path)
    report, cfg, _ = configs["person_following_outdoor_1.bag.zip"]
    assert cfg.driver == "/scan_base2" and cfg.time_source == "bag" and cfg.odometry == ""
    model = cfg.detectors[1].model
    assert (math.degrees(model.fov_min), math.degrees(model.fov_max)) == pytest.approx((-34.45, 51.33), abs=0.01)
    assert model.max_range == pytest.approx(5.6)
    report, cfg, cfg_path = configs["demo_stationary_simple_environment.bag"]
    assert cfg.driver == "/scan" and cfg.time_source == "header" and report.lasers[0].beams == 512
    for k in (1, 2, 3, 4, 6, 7):  # re-written training bags: record times within 0.5 s
        report, cfg, _ = configs[f"positive_{k}_extracted.bag"]
        assert cfg.time_source == "header" and report.warnings and "recorded in a burst" in report.warnings[0]
    report, cfg, _ = configs["negative_2.bag"]
    assert cfg.driver == "/left_scan" and "#   /right_scan: 434 msgs" in starter_config(report)
    with BagSource(shared_data / "leg_tracker" / "demo_stationary_simple_environment.bag") as src:
        summary, _ = Pipeline(load_config(cfg_path)).run(src, None, max_frames=10)
    assert summary.frames == 10


def test_reversed_laser_is_flagged_and_its_fov_kept(tmp_path: Path) -> None:
    ts = typestore(False)
    m = Msgs(ts, False)
    bag = tmp_path / "rev.bag"
    inc = -math.radians(0.5)
    with Writer1(bag) as w:
        conn = w.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=ts)
        for k in range(3):
            t = T0_NS + k * 10**8
            scan = m.scan(t, np.full(181, 3.0), math.radians(45.0), inc)  # beams from +45 deg down to -45 deg
            w.write(conn, t, ts.serialize_ros1(scan, "sensor_msgs/msg/LaserScan"))
    report = inspect_path(bag)
    (laser,) = report.lasers
    assert laser.increment_sign == -1 and laser.angle_min_deg == pytest.approx(45.0)
    assert (laser.fov_min_rad, laser.fov_max_rad) == pytest.approx((-math.pi / 4, math.pi / 4), abs=1e-6)
    assert any("negative angle_increment" in w for w in report.warnings)
    assert "[sign - (CW: reversed or upside down)]" in format_report(report)
    assert report.odometry == () and report.tf == ()
    cfg_path = tmp_path / "rev.toml"
    cfg_path.write_text(starter_config(report))
    cfg = load_config(cfg_path)
    assert cfg.odometry == "" and cfg.detectors[0].model.fov_min == pytest.approx(-math.pi / 4, abs=1e-5)
