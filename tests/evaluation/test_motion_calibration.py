"""The motion detector's calibration counts its detections on held-out scenes and on negative_2, as the others'."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from evaluation.harness.motion_calibration import calibrate_motion, format_calibration


def test_ppv_pools_the_scenes_and_negative_2_and_fnr_averages_the_scenes(shared_data: Path, tmp_path: Path) -> None:
    cal = calibrate_motion(shared_data, tmp_path, seed=3, scenes=["scan:corridor"], frames=40, followed=False)
    ((recall, precision),) = cal.scenes.values()
    assert cal.fnr == pytest.approx(1.0 - recall)  # one scene: its miss rate
    assert set(cal.negatives) == {"/left_scan", "/rear_scan", "/right_scan"}
    assert all(v > 0.0 for v in cal.negatives.values())  # furniture edges: it fires on every laser of negative_2
    assert cal.ppv < precision  # ... which lowers the PPV below the scene's precision
    assert 0.0 <= cal.ppv <= 1.0 and not math.isnan(cal.fnr)
    assert "PPV" in format_calibration(cal) and "scan:corridor" in format_calibration(cal)


def test_a_missing_negative_2_is_named(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"negative_2\.bag"):
        calibrate_motion(tmp_path, tmp_path, scenes=[])
