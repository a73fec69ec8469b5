"""Issue 27 (3, 5): ``pfpeople inspect`` on bags that broke it, and starter configs that ``run`` refused.

Bags are written with ``tests/pfpeople/pipeline/test_pipeline_bags.py``'s message helpers: ``/scan`` at 10 Hz (0.5 deg
beams from -90 deg, two legs 2 m ahead), optionally ``/odom`` and a ``/tf`` mount of ``laser`` on ``base_link``.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

import pytest
from bag_fixtures import MOUNT, T0_NS, Msgs, base_pose, typestore
from rosbags.rosbag1 import Writer as Writer1

from pfpeople.cli import main
from pfpeople.config import load_config
from pfpeople.detect.synthetic import render_scan
from pfpeople.io.bag.inspect import format_report, inspect_path, starter_config
from pfpeople.io.bag.reader import BagSource
from pfpeople.pipeline.runner import Pipeline

INC = math.radians(0.5)
LASER = "sensor_msgs/msg/LaserScan"


def write_bag(
    path: Path,
    n: int = 20,
    *,
    odom: bool = True,
    tf_from: int | None = 0,
    one_beam: int = 0,
    odom_also_scan: bool = False,
) -> None:
    """``n`` scans; ``/tf`` base_link -> laser from scan ``tf_from`` on (None: no TF); the first ``one_beam`` scans
    of one beam (no field of view); ``odom_also_scan``: ``/odom`` also carries LaserScans (two types)."""
    ts = typestore(False)
    m = Msgs(ts, False)
    w = Writer1(path)
    w.open()
    scan = w.add_connection("/scan", LASER, typestore=ts)
    tf = w.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=ts)
    odo = w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=ts) if odom else None
    odo_scan = w.add_connection("/odom", LASER, typestore=ts) if odom_also_scan else None
    ranges = render_scan(circles=[(2.0, 0.15, 0.06), (2.0, -0.15, 0.06)], angle_increment=INC).ranges
    for k in range(n):
        st = T0_NS + k * 100_000_000
        if tf_from is not None and k >= tf_from:
            w.write(tf, st + 1, ts.serialize_ros1(m.tf(st, "base_link", "laser", MOUNT), tf.msgtype))
        if odo is not None:
            w.write(odo, st + 2, ts.serialize_ros1(m.odom(st, base_pose(0.0)), odo.msgtype))
        r = ranges[:1] if k < one_beam else ranges
        msg = ts.serialize_ros1(m.scan(st, r, -math.pi / 2, INC), LASER)
        w.write(scan, st + 3, msg)
        if odo_scan is not None:
            w.write(odo_scan, st + 4, msg)
    w.close()


def _starter_runs(bag: Path, tmp_path: Path) -> tuple[str, object]:
    report = inspect_path(bag)
    cfg = tmp_path / "cfg.toml"
    cfg.write_text(starter_config(report))
    with BagSource(bag) as src:
        summary, _ = Pipeline(load_config(cfg), front_process=False).run(src, None)
    return cfg.read_text(), summary


def test_a_topic_with_two_message_types_is_reported_and_the_rest_inspected(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 27 (3): inspect died with an AttributeError (an Odometry read as a LaserScan)."""
    bag = tmp_path / "mixed.bag"
    write_bag(bag, 5, odom_also_scan=True)
    report = inspect_path(bag)
    both = "nav_msgs/msg/Odometry, sensor_msgs/msg/LaserScan"
    assert any(w.startswith(f"topic /odom carries 2 message types ({both})") for w in report.warnings)
    topics = {t.topic: t for t in report.topics}
    assert topics["/odom"].msgtype == "nav_msgs/msg/Odometry | sensor_msgs/msg/LaserScan"
    assert topics["/odom"].count == 10 and topics["/scan"].count == 5
    assert [li.topic for li in report.lasers] == ["/scan"] and report.odometry == ()
    assert "/odom" in format_report(report)
    cfg = tmp_path / "cfg.toml"
    assert main(["inspect", str(bag), "--write-config", str(cfg)]) == 0
    assert load_config(cfg).odometry == ""  # the mixed topic is left out: the config runs
    with (
        BagSource(bag) as src,
        pytest.raises(ValueError, match=rf"topic '/odom' in bag .* carries 2 message types \({both}\)"),
    ):
        src.require(["/odom"])


def test_a_mount_first_published_after_one_second_runs_with_the_starter_config(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """Issue 27 (5a): the run read /tf for 1 s only and refused the config inspect wrote (no mount on the base)."""
    bag = tmp_path / "late.bag"
    write_bag(bag, 20, tf_from=15)
    with caplog.at_level(logging.WARNING):
        text, summary = _starter_runs(bag, tmp_path)
    assert "[mounts]" not in text  # inspect saw the TF: nothing to measure
    assert summary.frames == 20  # type: ignore[attr-defined]
    assert "TF first published after the first 1 s of the bag: frame 'laser' (topic /tf) at 1.5 s" in caplog.text
    with BagSource(bag) as src:
        pipe = Pipeline(load_config(tmp_path / "cfg.toml"))
        pipe.prepare(src)
    assert pipe.setup is not None and pipe.setup.base_to_grid == MOUNT


def test_a_one_beam_first_scan_gives_the_next_scans_field_of_view(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """Issue 27 (5b): inspect wrote fov_min = fov_max from a one-beam first scan, and run refused the grid."""
    bag = tmp_path / "one.bag"
    write_bag(bag, 10, one_beam=1)
    report = inspect_path(bag)
    (laser,) = report.lasers
    assert laser.beams == 361 and laser.fov_max_rad == pytest.approx(math.pi / 2, abs=1e-6)
    assert any("/scan: its first 1 scan(s) give no field of view (1 beam(s)" in w for w in report.warnings)
    with caplog.at_level(logging.WARNING):
        text, summary = _starter_runs(bag, tmp_path)
    assert "fov_max = 1.5708" in text and summary.frames == 10  # type: ignore[attr-defined]
    assert "the field of view, range and grid come from scan 1" in caplog.text
    flat = tmp_path / "flat.bag"
    write_bag(flat, 3, one_beam=3)
    with (
        BagSource(flat) as src,
        pytest.raises(ValueError, match=r"topic '/scan': none of its first 3 LaserScans gives"),
    ):
        Pipeline(load_config(tmp_path / "cfg.toml"), front_process=False).run(src, None)
    assert any("/scan: none of the 3 scans read gives a field of view" in w for w in inspect_path(flat).warnings)
