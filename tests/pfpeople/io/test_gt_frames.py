"""Ground-truth CSV reading, frame assignment and the mapping into the grid frame."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from evaluation.harness.run_truth import gt_to_grid
from pfpeople.io.ground_truth import read_gt_csv
from pfpeople.io.run_dir import RunData


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
