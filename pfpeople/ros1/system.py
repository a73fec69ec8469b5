"""Where ROS 1 is on this machine: a Python interpreter that imports rospy, or what to install.

Debian (12 and later) packages ROS 1's Python client (``python3-rospy``) for its own ``/usr/bin/python3``, into
``/usr/lib/python3/dist-packages``. pfpeople may run in another interpreter (a virtual environment, a Python of
another minor version), so the node runs its transport in an interpreter that imports rospy
(:mod:`pfpeople.ros1.bridge`). Looked for, in order: ``--ros-python``, ``$PFPEOPLE_ROS_PYTHON``, ``/usr/bin/python3``,
then this interpreter itself (a ROS environment that pfpeople was installed into).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

__all__ = ["APT_PACKAGES", "ROS_MISSING", "RosMissingError", "bridge_script", "find_ros_python", "ros_tool"]

#: Debian's packages the node and its test need (ROS 1 core, the Python client, rosbag, TF, the message packages).
APT_PACKAGES = (
    "ros-core",
    "python3-rospy",
    "python3-rosbag",
    "python3-tf2-ros",
    "python3-std-msgs",
    "python3-sensor-msgs",
    "python3-nav-msgs",
    "python3-geometry-msgs",
    "python3-visualization-msgs",
    "python3-tf2-msgs",
)
ROS_MISSING = (
    "ROS 1 is not installed (no Python here imports rospy): on Debian or Ubuntu, "
    f"`sudo apt-get install {' '.join(APT_PACKAGES)}` (or `make setup` as root), or give the Python that imports "
    "rospy with --ros-python / PFPEOPLE_ROS_PYTHON"
)


class RosMissingError(RuntimeError):
    """No Python on this machine imports rospy (the message names the apt packages to install)."""


def _imports_rospy(python: str) -> bool:
    try:
        done = subprocess.run(
            [python, "-c", "import rospy"], capture_output=True, timeout=30, check=False, env=_clean_env()
        )
    except (OSError, subprocess.TimeoutExpired):
        return False
    return done.returncode == 0


def _clean_env() -> dict[str, str]:
    """The environment for the system interpreter: without this interpreter's virtual environment and paths."""
    env = dict(os.environ)
    for key in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "PYTHONSTARTUP"):
        env.pop(key, None)
    return env


def find_ros_python(explicit: str | None = None) -> str:
    """An interpreter that imports rospy (see the module docstring).

    Raises
    ------
    RosMissingError
        When none does (naming the apt packages); or when ``explicit`` (or ``$PFPEOPLE_ROS_PYTHON``) is given and
        does not.
    """
    given = explicit or os.environ.get("PFPEOPLE_ROS_PYTHON")
    if given:
        if not _imports_rospy(given):
            raise RosMissingError(f"{given!r} does not import rospy; {ROS_MISSING}")
        return given
    for python in ("/usr/bin/python3", sys.executable):
        if Path(python).is_file() and _imports_rospy(python):
            return python
    raise RosMissingError(ROS_MISSING)


def bridge_script() -> Path:
    """The path of :mod:`pfpeople.ros1.bridge` (run as a script by the ROS interpreter)."""
    return Path(__file__).with_name("bridge.py")


def ros_tool(name: str) -> str | None:
    """The path of a ROS 1 command (``roscore``, ``rosmaster``, ``rosbag``), or None."""
    return shutil.which(name) or next((p for p in (f"/usr/bin/{name}",) if Path(p).is_file()), None)


def bridge_env() -> dict[str, str]:
    """The bridge process's environment (this one, less this interpreter's paths)."""
    return _clean_env()
