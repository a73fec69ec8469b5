"""Ground-truth CSV reliability (issue 11): byte-order marks, frame names in columns, runs cut short."""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np
import pytest

from evaluation.cli import main as eval_main
from evaluation.commands.score import score_run
from evaluation.harness.run_truth import gt_coverage, truth_and_sources
from gridbridge.grid import GridSpec
from pfpeople.io.ground_truth import read_gt_csv, resolve_gt_frame
from pfpeople.io.run_dir import RunWriter, load_run

SPEC = GridSpec(nx=10, ny=10, resolution=0.5, x0=0.0, y0=-2.5)


def write_run(path: Path, n_frames: int, *, person: tuple[float, float] = (2.0, 0.5)) -> Path:
    """A run of ``n_frames`` frames (driver_index = frame, stamps 100 ms apart) whose detector sees ``person``."""
    meta = {"grid_frame": "laser", "frames_in_grid": {"laser": [0, 0, 0], "base_link": [-0.5, 0.0, math.pi]}}
    with RunWriter(path, spec=SPEC, detector_names=["legs"], metadata=meta) as w:
        for k in range(n_frames):
            w.write_frame(
                frame=k,
                driver_index=k,
                stamp_ns=10**9 + k * 10**8,
                bag_time_ns=10**9 + k * 10**8,
                dt_s=0.1,
                odometry=None,
                forced=False,
                belief=np.zeros(SPEC.shape),
                people=np.zeros((0, 2)),
                detections=[np.array([person])],
            )
    return path


def test_a_byte_order_mark_does_not_move_the_key_to_another_column(tmp_path: Path) -> None:
    p = tmp_path / "bom.csv"
    # Without utf-8-sig the first column would be "\ufeffscan_index" and bag_time_ns would key the rows.
    p.write_bytes("scan_index,bag_time_ns,person_id,x,y\n3,999,1,1.0,2.0\n".encode("utf-8-sig"))
    assert p.read_bytes()[:3] == b"\xef\xbb\xbf"
    gt = read_gt_csv(p)
    assert gt.key == "scan_index" and gt.keys.tolist() == [3]
    np.testing.assert_array_equal(gt.xy, [[1.0, 2.0]])


def test_frame_named_by_the_columns_is_carried_and_checked(tmp_path: Path) -> None:
    p = tmp_path / "base.csv"
    p.write_text("scan_index,person_id,x_base_link_m,y_base_link_m\n0,1,1.5,-0.5\n")
    gt = read_gt_csv(p)
    assert gt.frame == "base_link"
    assert resolve_gt_frame(gt, None) == "base_link"
    assert resolve_gt_frame(gt, "base_link") == "base_link"
    with pytest.raises(ValueError, match=r"in frame 'base_link' .* but frame 'grid' was requested"):
        resolve_gt_frame(gt, "grid")
    plain = tmp_path / "plain.csv"
    plain.write_text("scan_index,person_id,x,y\n0,1,1.5,-0.5\n")
    assert resolve_gt_frame(read_gt_csv(plain), None) == "grid"
    assert resolve_gt_frame(read_gt_csv(plain), "laser") == "laser"
    # Scoring: without --frame the file's base_link is used, mapped by the run's recorded mount
    # (base_link at x = -0.5 m, turned by pi: (1.5, -0.5) -> (-2.0, 0.5), outside the grid).
    run = load_run(write_run(tmp_path / "run", 1))
    truth, _, _ = truth_and_sources(run, gt)
    np.testing.assert_allclose(truth[0], [[-2.0, 0.5]], atol=1e-12)
    with pytest.raises(ValueError, match=r"frame 'base_link'.*frame 'laser' was requested"):
        score_run(run, gt, frame="laser")
    two = tmp_path / "two.csv"
    two.write_text("scan_index,person_id,x_laser_m,y_laser_m,x_base_link_m,y_base_link_m\n0,1,1,2,3,4\n")
    with pytest.raises(ValueError, match=r"several frames \['laser', 'base_link'\]"):
        read_gt_csv(two)
    np.testing.assert_array_equal(read_gt_csv(two, frame="base_link").xy, [[3.0, 4.0]])
    with pytest.raises(ValueError, match=r"no columns x_odom_m, y_odom_m; its frames are \['laser', 'base_link'\]"):
        read_gt_csv(two, frame="odom")
    with pytest.raises(ValueError, match=r"in frame 'base_link' .* but frame 'odom' was requested"):
        read_gt_csv(p, frame="odom")
    assert read_gt_csv(plain, frame="odom").frame is None  # plain x, y: the caller names the frame


def test_gt_beyond_a_run_cut_short_is_reported(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, capsys: pytest.CaptureFixture[str]
) -> None:
    run_dir = write_run(tmp_path / "run", 4)
    gt_path = tmp_path / "gt.csv"
    rows = [f"{k},1,2.0,0.5" for k in range(10)] + ["9,2,3.0,0.0"]  # 10 GT frames, 11 rows
    gt_path.write_text("scan_index,person_id,x_laser_m,y_laser_m\n" + "\n".join(rows) + "\n")
    run, gt = load_run(run_dir), read_gt_csv(gt_path)
    cov = gt_coverage(run, gt)
    assert cov == {
        "gt_frames": 10,
        "gt_frames_without_run_frame": 6,
        "gt_frames_beyond_run": 6,
        "gt_rows_beyond_run": 7,
        "gt_rows_before_run": 0,
        "gt_rows_between_frames": 0,
        "gt_match_window_s": 0.0,
        "gt_rows_stamp_mismatch": 0,
    }
    with caplog.at_level(logging.WARNING, logger="evaluation.harness.run_truth"):
        result = score_run(run, gt)
    assert "7 ground-truth row(s)" in caplog.text and "6 frame key(s)" in caplog.text
    assert result["gt_frames_beyond_run"] == 6 and result["gt_frame"] == "laser"
    assert result["scores"]["legs"]["tp"] == 4 and result["scores"]["legs"]["fn"] == 0
    # frames.csv cut short (a crash while writing): the rows it lost are reported too.
    lines = (run_dir / "frames.csv").read_text().splitlines()
    (run_dir / "frames.csv").write_text("\n".join(lines[:3]) + "\n")  # header + frames 0, 1
    assert eval_main(["score", str(run_dir), "--gt", str(gt_path)]) == 0
    out = capsys.readouterr().out
    assert "GT frames: 10, of which 8 had no run frame (8 after the run's last frame" in out
    # Nothing beyond: no warning and zero counts.
    caplog.clear()
    short = tmp_path / "short.csv"
    short.write_text("scan_index,person_id,x_laser_m,y_laser_m\n0,1,2.0,0.5\n")
    with caplog.at_level(logging.WARNING, logger="evaluation.harness.run_truth"):
        assert score_run(run, read_gt_csv(short))["gt_frames_beyond_run"] == 0
    assert "ground-truth row" not in caplog.text


def test_beyond_by_stamp_and_bag_time(tmp_path: Path) -> None:
    p = tmp_path / "s.csv"
    p.write_text("stamp_ns,person_id,x,y\n100,1,0,0\n340,1,0,0\n360,1,0,0\n")
    gt = read_gt_csv(p)
    idx, t = np.array([0, 1, 2]), np.array([100, 200, 300])
    assert gt.beyond(idx, t, t, tolerance_ns=50).tolist() == [False, False, True]
    assert gt.beyond(idx[:0], t[:0], t[:0]).tolist() == [True, True, True]


HEADER = "scan_index,person_id,x_laser_m,y_laser_m\n"


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("", r"gt\.csv: empty file \(a header row is required\)"),
        (HEADER, r"gt\.csv: no ground-truth rows \(only a header\)"),
        (HEADER + "0,1,2.0,0.5\n-1,1,2.0,0.5\n", r"gt\.csv: line 3: scan_index must be non-negative, got -1"),
        (
            HEADER + "0,1,2.0,0.5\n1,1,2.0,0.5\n1,2,3.0,0.0\n1,1,2.1,0.5\n2,1,2.0,0.5\n2,1,2.0,0.5\n",
            r"gt\.csv: line 5 repeats scan_index 1, person_id 1 of line 3 \(a person would be counted twice\)",
        ),
    ],
    ids=["zero-bytes", "header-only", "negative-scan-index", "duplicate"],
)
def test_empty_negative_or_duplicated_ground_truth_is_refused_naming_the_file_and_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, match: str
) -> None:
    run_dir = write_run(tmp_path / "run", 3)
    gt_path = tmp_path / "gt.csv"
    gt_path.write_text(text)
    with pytest.raises(ValueError, match=match):
        read_gt_csv(gt_path)
    assert eval_main(["score", str(run_dir), "--gt", str(gt_path)]) == 2  # not 0 with NaN recall
    err = capsys.readouterr().err
    assert str(gt_path) in err and "Traceback" not in err
    # The same rows without the fault score as expected.
    gt_path.write_text(HEADER + "0,1,2.0,0.5\n1,1,2.0,0.5\n1,2,3.0,0.0\n")
    assert score_run(load_run(run_dir), read_gt_csv(gt_path))["scores"]["legs"]["tp"] == 2
