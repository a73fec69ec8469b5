"""What a new user meets first (issue 45's findings): clear refusals in the right order, what inspect says about
ego-motion, valid ROS names by default (old configs still read), ``-v``, no ``.lock`` left behind, aligned tables.

The bags: ``bag_fixtures.write_scan_bag`` (one laser on /scan, no odometry, no TF) and
``bag_fixtures.write_lasers_bag`` (three lasers with /tf_static, no odometry).
"""

from __future__ import annotations

import logging
import re
from dataclasses import replace
from pathlib import Path

import pytest
from bag_fixtures import write_lasers_bag, write_scan_bag

from gridbridge.params import LEGACY_DETECTOR_NAMES, PAPER_DETECTORS, current_detector_name
from pfpeople.cli import main
from pfpeople.config import builtin_config_path, load_config
from pfpeople.io.bag.inspect import NO_ODOMETRY, format_report, inspect_path, starter_config
from pfpeople.io.bag.reader import ROS1_MAGIC
from pfpeople.io.bag.writer import detection_topic


def _err(capsys: pytest.CaptureFixture[str]) -> str:
    return capsys.readouterr().err


def test_run_says_a_file_is_not_a_bag(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    notes = tmp_path / "notes.txt"
    notes.write_text("not a bag\n")
    assert main(["run", str(notes), "--driver", "/scan", "--out", str(tmp_path / "r")]) == 2
    err = _err(capsys)
    assert "the file is not a bag" in err and "does not exist" not in err and "AnyReaderError" not in err
    renamed = tmp_path / "recording.bag.active"  # a ROS 1 bag under another name
    renamed.write_bytes(ROS1_MAGIC + b"\n")
    assert main(["inspect", str(renamed)]) == 2
    assert "a ROS1 bag by its first bytes, but not named *.bag: rename it" in _err(capsys)


def test_a_missing_bag_is_named_before_the_configuration(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "missing.bag"
    assert main(["run", str(missing), "--out", str(tmp_path / "r")]) == 2  # neither --config nor --driver
    err = _err(capsys)
    assert f"bag '{missing}' does not exist" in err and "give --config or --driver" not in err
    write_scan_bag(tmp_path / "here.bag", 2)
    assert main(["run", str(tmp_path / "here.bag"), "--out", str(tmp_path / "r")]) == 2
    assert "give --config or --driver" in _err(capsys)  # a bag that is there: then the configuration


def test_inspect_says_a_run_scan_matches_without_odometry(tmp_path: Path) -> None:
    bag = tmp_path / "scan.bag"
    write_scan_bag(bag, 3)
    report = inspect_path(bag)
    text = format_report(report)
    assert f"odometry: none (no nav_msgs/Odometry topic): {NO_ODOMETRY}" in text
    assert "scan matching the driving laser" in text and "takes the robot as standing (" not in text
    config = " ".join(line.lstrip("# ") for line in starter_config(report).splitlines() if line.startswith("#"))
    assert "scan matching the driving laser where its scans match" in config


def test_refusals_name_the_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = tmp_path / "scan.bag"
    write_scan_bag(bag, 2)
    args = ["run", str(bag), "--driver", "/scan", "--out", str(tmp_path / "r"), "--no-progress"]
    assert main(args) == 0
    capsys.readouterr()
    assert main(args) == 2
    assert "already holds a run (replace it with --overwrite" in _err(capsys)
    # inspect --write-config refuses an existing file before it reads the bag and prints the report
    config = tmp_path / "my.toml"
    config.write_text("# mine\n")
    assert main(["inspect", str(bag), "--write-config", str(config)]) == 2
    out, err = capsys.readouterr()
    assert out == "" and "exists (use --overwrite to replace it)" in err and config.read_text() == "# mine\n"
    assert main(["inspect", str(bag), "--write-config", str(config), "--overwrite"]) == 0
    assert "topic" in capsys.readouterr().out and load_config(config).driver == "/scan"


def test_a_finished_run_directory_holds_no_lock(tmp_path: Path) -> None:
    bag = tmp_path / "scan.bag"
    write_scan_bag(bag, 2)
    out = tmp_path / "r"
    assert main(["run", str(bag), "--driver", "/scan", "--out", str(out), "--no-progress"]) == 0
    assert (out / "run.json").is_file() and not (out / ".lock").exists()
    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "mine.txt").write_text("x")  # not a run: refused, and nothing of ours left in it
    assert main(["run", str(bag), "--driver", "/scan", "--out", str(busy), "--no-progress"]) == 2
    assert sorted(p.name for p in busy.iterdir()) == ["mine.txt"]


def test_verbose_shows_debug_messages(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    bag = tmp_path / "scan.bag"
    write_scan_bag(bag, 2)
    monkeypatch.setattr(logging.getLogger(), "level", logging.WARNING)  # as a fresh process: root at WARNING

    def debug_lines(*flags: str) -> list[str]:
        caplog.clear()
        args = [*flags, "run", str(bag), "--driver", "/scan", "--out", str(tmp_path / "r"), "--overwrite"]
        assert main([*args, "--no-progress"]) == 0
        return [r.getMessage() for r in caplog.records if r.levelno == logging.DEBUG and r.name.startswith("pfpe")]

    lines = debug_lines("-v")
    assert any(line.startswith("frames: driver /scan") for line in lines)
    assert any(line.startswith("detector laser_legs (leg on /scan, frame 'laser'): at x=0.000") for line in lines)
    assert debug_lines() == []
    assert logging.getLogger("pfpeople").level == logging.NOTSET  # the command's level does not outlive it


def test_default_detector_names_are_ros_names(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    bag = tmp_path / "lasers.bag"
    write_lasers_bag(bag, n_scans=3)
    config = tmp_path / "lasers.toml"
    config.write_text(starter_config(inspect_path(bag)))
    names = [d.name for d in load_config(config).detectors]
    names += [d.name for n in ("person_following_outdoor_1", "person_following_outdoor_1_paper")
              for d in load_config(builtin_config_path(n)).detectors]  # fmt: skip
    names += [m.name for m in PAPER_DETECTORS]
    assert "laser_boosted_side_scan" in names
    assert all(detection_topic(n) == f"/pfpeople/detections/{n}" for n in names)  # valid ROS name tokens
    with caplog.at_level(logging.WARNING):
        args = ["run", str(bag), "--config", str(config), "--out", str(tmp_path / "r"), "--no-progress"]
        assert main([*args, "--bag-out", str(tmp_path / "out.bag")]) == 0
    assert "its detections go to" not in caplog.text  # no renaming warning


def _old_names(text: str) -> str:
    """A starter config with the default names of earlier versions (``laser-legs``, ``laser-legs:side_scan``)."""
    old = {new: legacy for legacy, new in LEGACY_DETECTOR_NAMES.items()}

    def legacy(m: re.Match[str]) -> str:
        return f'name = "{old[m[1]]}{":" + m[3] if m[3] else ""}"'

    return re.sub(r'name = "(laser_legs|laser_boosted|laser_single_legs)(_(\w+))?"', legacy, text)


def test_configs_with_the_old_default_names_still_run(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    assert current_detector_name("laser-legs") == "laser_legs"
    assert current_detector_name("laser-boosted:robot/rear_scan") == "laser_boosted_robot_rear_scan"
    assert current_detector_name("laser-legs:") == "laser-legs:"  # not a form of the old defaults: kept
    assert current_detector_name("my-detector") == "my-detector"
    bag = tmp_path / "lasers.bag"
    write_lasers_bag(bag, n_scans=3)
    (tmp_path / "new.toml").write_text(new := starter_config(inspect_path(bag)))
    (tmp_path / "old.toml").write_text(old := _old_names(new))
    active = [line for line in old.split("[[detectors]]", 1)[1].splitlines() if not line.lstrip().startswith("#")]
    assert 'name = "laser-single-legs:rear_scan"' in old and not any("laser_" in line for line in active)
    with caplog.at_level(logging.WARNING, logger="pfpeople.config"):
        cfg = load_config(tmp_path / "old.toml")
    assert cfg.detectors == load_config(tmp_path / "new.toml").detectors  # read with today's names
    assert caplog.text.count("former default names") == 1 and "'laser-legs' as 'laser_legs'" in caplog.text
    args = ["run", str(bag), "--config", str(tmp_path / "old.toml"), "--out", str(tmp_path / "r"), "--no-progress"]
    assert main(args) == 0
    clash = tmp_path / "clash.toml"
    clash.write_text(new + '\n[[detectors]]\nname = "laser-legs"\nkind = "leg"\ntopic = "/front_scan"\n')
    with pytest.raises(ValueError, match=r"clash\.toml.*names must be unique"):
        load_config(clash)


def test_topic_table_stays_aligned_with_long_names(tmp_path: Path) -> None:
    bag = tmp_path / "lasers.bag"
    write_lasers_bag(bag, n_scans=2)
    report = inspect_path(bag)
    long = "/robot/sensors/front_laser_with_a_very_long_topic_name/scan"
    topics = tuple(replace(t, topic=long) if t.topic == "/side_scan" else t for t in report.topics)
    rows = [line for line in format_report(replace(report, topics=topics)).splitlines() if "msg/LaserScan " in line]
    assert len(rows) == 3 and any(row.startswith(long + " ") for row in rows)
    assert len({row.index("sensor_msgs/msg/LaserScan") for row in rows}) == 1  # the type column starts alike
    assert {row.split("sensor_msgs/msg/LaserScan")[1].split()[0] for row in rows} == {"2"}  # the counts
