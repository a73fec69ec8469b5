"""Ground-truth stamps checked against the run's frames (issue 27): a shifted ``scan_index`` is refused."""

from __future__ import annotations

import csv
import logging
from pathlib import Path

import numpy as np
import pytest

from evaluation.cli import main as eval_main
from evaluation.commands.score import score_run
from evaluation.harness.run_truth import check_gt_stamps, gt_coverage
from evaluation.scenarios.scan.bagfile import write_scene_bag
from gridbridge.grid import GridSpec
from pfpeople.cli import main as pf_main
from pfpeople.io.ground_truth import read_gt_csv, stamp_agreement
from pfpeople.io.run_dir import RunWriter, load_run

SPEC = GridSpec(nx=10, ny=10, resolution=0.5, x0=0.0, y0=-2.5)
T0, PERIOD = 10**9, 10**8  # frame k: stamp T0 + k * PERIOD, recorded 3 ms later


def write_run(path: Path, n_frames: int) -> Path:
    """A run of ``n_frames`` frames (driver_index = frame) whose detector sees a person at (2.0, 0.5)."""
    with RunWriter(path, spec=SPEC, detector_names=["legs"], metadata={"grid_frame": "laser"}) as w:
        for k in range(n_frames):
            w.write_frame(
                frame=k,
                driver_index=k,
                stamp_ns=T0 + k * PERIOD,
                bag_time_ns=T0 + k * PERIOD + 3_000_000,
                dt_s=0.1,
                odometry=None,
                forced=False,
                belief=np.zeros(SPEC.shape),
                people=np.zeros((0, 2)),
                detections=[np.array([[2.0, 0.5]])],
            )
    return path


def write_gt(path: Path, column: str, stamps: list[int], *, shift: int = 0) -> Path:
    """GT rows for scans 0.. with the given time column, their scan_index shifted by ``shift``."""
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["scan_index", column, "person_id", "x_laser_m", "y_laser_m"])
        for k, t in enumerate(stamps):
            if k + shift >= 0:
                w.writerow([k + shift, t, 1, 2.0, 0.5])
    return path


def test_correct_stamps_pass_and_a_shifted_scan_index_is_refused(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, capsys: pytest.CaptureFixture[str]
) -> None:
    run_dir = write_run(tmp_path / "run", 20)
    run = load_run(run_dir)
    stamps = [T0 + k * PERIOD for k in range(20)]
    good = write_gt(tmp_path / "good.csv", "stamp_ns", stamps)
    with caplog.at_level(logging.WARNING, logger="evaluation.harness.run_truth"):
        result = score_run(run, read_gt_csv(good))
    assert result["gt_rows_stamp_mismatch"] == 0 and result["scores"]["legs"]["recall"] == 1.0
    assert "disagree" not in caplog.text
    shifted = write_gt(tmp_path / "shifted.csv", "stamp_ns", stamps, shift=5)  # recall would still be 1.0
    msg = (
        r"shifted\.csv' does not match run .*: 15 of 15 matched ground-truth rows \(100 %\) disagree in stamp_ns; "
        rf"first at line 2: scan_index 5 has stamp_ns {T0} but run frame 5 \(driver_index 5\) has stamp_ns "
        rf"{T0 + 5 * PERIOD}: an offset of -5 frame\(s\), -0\.500 s"
    )
    with pytest.raises(ValueError, match=msg):
        score_run(run, read_gt_csv(shifted))
    for argv in (["score", str(run_dir)], ["calibrate", "--run", str(run_dir)]):
        assert eval_main([*argv, "--gt", str(shifted)]) == 2
        err = capsys.readouterr().err
        assert str(shifted) in err and "-5 frame(s)" in err and "Traceback" not in err
    assert eval_main(["calibrate", "--run", str(run_dir), "--gt", str(good)]) == 0
    # An hour off: refused too.
    hour = write_gt(tmp_path / "hour.csv", "stamp_ns", [t + 3600 * 10**9 for t in stamps])
    with pytest.raises(ValueError, match=r"an offset of \+36000 frame\(s\), \+3600\.000 s"):
        score_run(run, read_gt_csv(hour))


def test_a_few_disagreeing_stamps_are_warned_about_and_counted(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, capsys: pytest.CaptureFixture[str]
) -> None:
    run_dir = write_run(tmp_path / "run", 20)
    run = load_run(run_dir)
    stamps = [T0 + k * PERIOD for k in range(20)]
    stamps[7] += 2 * PERIOD  # one row of 20 (5 %)
    stamps[8] += PERIOD // 2 - 1  # within half a period: agrees
    gt = read_gt_csv(write_gt(tmp_path / "few.csv", "stamp_ns", stamps))
    with caplog.at_level(logging.WARNING, logger="evaluation.harness.run_truth"):
        result = score_run(run, gt)
    assert result["gt_rows_stamp_mismatch"] == 1
    assert "1 of 20 matched ground-truth rows (5 %) disagree" in caplog.text and "line 9: scan_index 7" in caplog.text
    assert "+2 frame(s), +0.200 s" in caplog.text
    assert eval_main(["score", str(run_dir), "--gt", str(gt.path)]) == 0
    assert "GT rows whose stamp disagrees with their run frame's: 1" in capsys.readouterr().out


def test_bag_time_is_a_record_time_after_its_scan(tmp_path: Path) -> None:
    """As the leg_tracker GT (recorded 30 to 70 ms after its 100 ms scans): agrees from a quarter period before
    the frame's record time to a period after; a shift by one scan either way is refused."""
    run = load_run(write_run(tmp_path / "run", 20))
    delays = [30, 50, 70, 45, 55] * 4
    times = [T0 + 3_000_000 + k * PERIOD + d * 1_000_000 for k, d in enumerate(delays)]
    gt = read_gt_csv(write_gt(tmp_path / "bag.csv", "bag_time_ns", times))
    assert gt.key == "scan_index" and gt.stamp_column == "bag_time_ns"
    assert gt_coverage(run, gt)["gt_rows_stamp_mismatch"] == 0
    fr = run.frames
    frame_of_row, _ = gt.assign(fr["driver_index"], fr["stamp_ns"], fr["bag_time_ns"])
    assert check_gt_stamps(run, gt, frame_of_row) == 0
    for shift, offset in ((1, r"-1 frame\(s\), -0\.070 s"), (-1, r"\+1 frame\(s\), \+0\.150 s")):
        bad = read_gt_csv(write_gt(tmp_path / f"bag{shift}.csv", "bag_time_ns", times, shift=shift))
        with pytest.raises(ValueError, match=rf"disagree in bag_time_ns; first at line 2: .*{offset}"):
            score_run(run, bad, recall_only=True)
    # No time column, or keyed by the stamp itself: nothing to check.
    plain = tmp_path / "plain.csv"
    plain.write_text("scan_index,person_id,x,y\n0,1,2.0,0.5\n")
    keyed = tmp_path / "keyed.csv"
    keyed.write_text(f"stamp_ns,bag_time_ns,person_id,x,y\n{T0},{T0 + 10**12},1,2.0,0.5\n")
    for path in (plain, keyed):
        assert stamp_agreement(read_gt_csv(path), np.zeros(1, np.int64), fr["stamp_ns"], fr["bag_time_ns"]) is None


def test_a_simulated_run_scores_against_its_own_gt_and_refuses_it_shifted(tmp_path: Path) -> None:
    """The scan-level simulator's GT (scan_index, stamp_ns) through ``pfpeople run`` and ``pfpeople-eval score``."""
    out = write_scene_bag("corridor", tmp_path, frames=25, seed=0)
    run_dir = tmp_path / "run"
    assert pf_main(["run", str(out.bag), "--config", str(out.run_toml), "--out", str(run_dir), "--no-progress"]) == 0
    run = load_run(run_dir)
    result = score_run(run, read_gt_csv(out.gt_csv), recall_only=True)
    assert result["gt_rows_stamp_mismatch"] == 0 and result["gt_rows_unassigned"] == 0
    with out.gt_csv.open(newline="") as fh:
        rows = list(csv.reader(fh))
    shifted = tmp_path / "shifted.csv"
    with shifted.open("w", newline="") as fh:
        csv.writer(fh).writerows([rows[0]] + [[str(int(r[0]) + 5), *r[1:]] for r in rows[1:]])
    with pytest.raises(ValueError, match=r"shifted\.csv' does not match run .* an offset of -5 frame\(s\)"):
        score_run(run, read_gt_csv(shifted), recall_only=True)
