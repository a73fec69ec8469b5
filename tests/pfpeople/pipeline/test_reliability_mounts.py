"""Issue 27 (1, 2): mounts followed over TF time, and scans in another frame than their topic's first.

Before, the first value of every mount was used for the whole run (a panning laser's detections drifted with
its pan) and every scan of a topic was placed as if in the topic's first frame (two lasers on one topic). Now
each frame's detectors are placed with their frame's mount at the frame's stamp (latest transform at or before
it; :mod:`pfpeople.pipeline.mounts`), counted in ``stats.mounts_followed``, ``frame_id_changes``, ``frame_id_unplaced``.
The bags are ``write_scan_bag``'s: two people in the laser frame at ``PEOPLE``, the grid in ``base_link``.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest
from bag_fixtures import PEOPLE, legs_only, write_scan_bag

from gridbridge.grid import GridSpec
from pfpeople.io.bag.reader import BagSource
from pfpeople.io.bag.tf import MountFollower, TfBuffer
from pfpeople.io.run_dir import load_run
from pfpeople.pipeline.runner import Pipeline
from pfpeople.sensors import Pose2D

GRID = GridSpec(nx=30, ny=30, resolution=0.3, x0=-1.0, y0=-4.5)
BEFORE, AFTER = Pose2D(x=0.2, y=0.1, yaw=0.3), Pose2D(x=0.2, y=0.1, yaw=0.8)


def _nearest(a: np.ndarray, b: np.ndarray) -> float:
    """Largest distance from a row of ``b`` to its nearest row of ``a`` (m)."""
    return float(np.max(np.min(np.linalg.norm(a[:, None] - b[None], axis=-1), axis=0)))


@pytest.mark.parametrize("two_processes", [False, True])
def test_a_panning_laser_is_placed_with_its_mount_at_each_scan(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, two_processes: bool
) -> None:
    bag = tmp_path / "pan.bag"
    write_scan_bag(bag, 16, tf_mount=lambda k: AFTER if k >= 10 else BEFORE)
    cfg = legs_only(grid_frame="base_link", grid=GRID)
    pipe = Pipeline(cfg, front_process=two_processes)
    with BagSource(bag) as src, caplog.at_level(logging.WARNING):
        summary, results = pipe.run(src, tmp_path / "run", keep=True)
    for k, r in enumerate(results):
        truth = (AFTER if k >= 10 else BEFORE).apply(PEOPLE)
        assert r.detections[0] is not None and _nearest(r.detections[0], truth) < 0.1  # 0.5 rad off: 1.4 m
    assert summary.mounts_followed == {"legs": 6} and summary.mount_changes == {"base_link -> laser": 6}
    assert load_run(tmp_path / "run").meta["stats"]["mounts_followed"] == {"legs": 6}
    assert pipe.filter is not None and pipe.filter.detectors[0].mount_yaw == pytest.approx(AFTER.yaw)
    assert "The run follows it" in caplog.text


def test_two_lasers_on_one_topic_are_each_placed_by_their_own_mount(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    bag = tmp_path / "two.bag"
    other = Pose2D(x=-0.3, y=0.0, yaw=2.5)
    frames = {1: "laser_b", 3: "laser_b", 5: "nowhere"}
    write_scan_bag(bag, 8, frame_of=lambda k: frames.get(k, "laser"), static_mounts={"laser": BEFORE, "laser_b": other})
    with BagSource(bag) as src, caplog.at_level(logging.WARNING):
        summary, results = Pipeline(legs_only(grid_frame="base_link", grid=GRID)).run(src, None, keep=True)
    assert summary.frame_id_changes == {"legs": 3} and summary.frame_id_unplaced == {"legs": 1}
    assert summary.no_data == {"legs": 1} and results[5].detections[0] is None
    for k in (0, 1, 2, 3, 4, 6):
        truth = (other if k in (1, 3) else BEFORE).apply(PEOPLE)
        assert _nearest(results[k].detections[0], truth) < 0.1
    assert caplog.text.count("has messages in frame 'laser_b' besides its first frame 'laser'") == 1
    assert "frame 'nowhere', not its first frame 'laser', and TF does not place that frame" in caplog.text


def test_the_follower_applies_transforms_at_their_stamps_latest_before() -> None:
    tf = TfBuffer()
    tf.set_transform("base_link", "laser", BEFORE, 0, topic="/tf")
    follow = MountFollower(tf, "base_link")

    class _T:  # the fields of a geometry_msgs/TransformStamped a TFMessage holds
        def __init__(self, sec: int, yaw: float, parent: str = "base_link") -> None:
            import math
            from types import SimpleNamespace as N

            self.header = N(frame_id=parent, stamp=N(sec=sec, nanosec=0))
            self.child_frame_id = "laser"
            self.transform = N(
                translation=N(x=0.2, y=0.1, z=0.0), rotation=N(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))
            )

    from types import SimpleNamespace as N

    follow.add(N(transforms=[_T(2, 0.5), _T(1, 0.4), _T(3, 0.6, parent="mast")]))  # out of order; a second parent
    assert follow.mount("laser") == BEFORE
    follow.advance(1_500_000_000)
    assert follow.mount("laser").yaw == pytest.approx(0.4)
    follow.advance(10**10)
    assert follow.mount("laser").yaw == pytest.approx(0.5)  # the transform to another parent is left out
    assert tf.lookup("base_link", "laser") == BEFORE  # the setup's buffer is not changed
