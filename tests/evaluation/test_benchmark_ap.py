"""Scans of a recording without odometry get the ego-motion a run gives them: by scan matching."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from evaluation.scenarios.scan import write_scene_bag
from pfpeople.detect.learned.samples import simulated_scans, with_scan_matched_motion


def test_scans_without_odometry_get_their_scan_matched_motion(tmp_path: Path) -> None:
    sb = write_scene_bag("corridor", tmp_path, seed=0, frames=12)
    scans = simulated_scans(sb.bag, sb.gt_csv)  # with the simulated odometry's motion
    got = with_scan_matched_motion([dataclasses.replace(s, ego=(math.nan,) * 3) for s in scans])
    assert all(math.isnan(v) for v in got[0].ego)  # the first scan has no motion
    ego, odo = np.array([s.ego for s in got[1:]]), np.array([s.ego for s in scans[1:]])
    assert np.isfinite(ego).all()
    assert np.abs(ego[:, :2] - odo[:, :2]).max() < 0.1 and np.abs(ego[:, 2] - odo[:, 2]).max() < 0.02
