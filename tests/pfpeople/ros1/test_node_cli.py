"""``pfpeople node`` without a Python that imports rospy: one line naming the apt packages to install, exit 2."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from pfpeople.cli import main
from pfpeople.ros1.system import APT_PACKAGES, RosMissingError, find_ros_python


def test_node_without_rospy_names_the_packages_to_install(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    toml = tmp_path / "c.toml"
    toml.write_text('[frames]\ndriver = "/scan"\n[[detectors]]\nname = "legs"\nkind = "leg"\ntopic = "/scan"\n')
    no_ros = tmp_path / "python_without_ros"
    no_ros.write_text("#!/bin/sh\nexit 1\n")
    no_ros.chmod(0o755)
    assert main(["node", "--config", str(toml), "--ros-python", str(no_ros)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("pfpeople node: error:") and "does not import rospy" in err[0]
    assert all(pkg in err[0] for pkg in APT_PACKAGES)
    monkeypatch.setenv("PFPEOPLE_ROS_PYTHON", sys.executable + "-missing")
    with pytest.raises(RosMissingError, match="apt-get install ros-core python3-rospy"):
        find_ros_python()


def test_node_refuses_a_missing_config(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["node", "--config", "/nonexistent/c.toml"]) == 2
    assert "c.toml" in capsys.readouterr().err
