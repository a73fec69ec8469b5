"""Issue 27 (3, 5): ``pfpeople inspect`` on bags that broke it, and starter configs that ``run`` refused.

Bags are written with ``tests/test_pipeline_bags.py``'s message helpers: ``/scan`` at 10 Hz (0.5 deg beams from
-90 deg, two legs 2 m ahead), optionally ``/odom`` and a ``/tf`` mount of ``laser`` on ``base_link``.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from rosbags.rosbag1 import Writer as Writer1
from test_pipeline_bags import MOUNT, T0_NS, _Msgs, _typestore, base_pose

from pfpeople.bag.config import load_config
from pfpeople.bag.inspect import format_report, inspect_path, starter_config
from pfpeople.bag.reader import BagSource
from pfpeople.cli import main
from pfpeople.detectors.synthetic import render_scan
from pfpeople.pipeline import Pipeline

INC = math.radians(0.5)
LASER = "sensor_msgs/msg/LaserScan"


def write_bag(
    path: Path,
    n: int = 20,
    *,
    odom: bool = True,
    tf_from: int | None = 0,
    beams_first: int | None = None,
    odom_also_scan: bool = False,
) -> None:
    """``n`` scans; ``/tf`` base_link -> laser from scan ``tf_from`` on (None: no TF); the first ``beams_first``
    beams only in the first scan; ``odom_also_scan``: ``/odom`` also carries LaserScans (two types)."""
    ts = _typestore(False)
    m = _Msgs(ts, False)
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
        r = ranges[:beams_first] if beams_first is not None and k == 0 else ranges
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
