"""Issue 46, findings 7 and 15 (ground truth and run.json read by ``pfpeople-eval score``).

- 7: ground truth keyed by ``bag_time_ns`` was matched to the run's frames within a fixed 50 ms, so rows that
  leg_tracker writes 43-57 ms after their 7.5 Hz scan were dropped silently (393 of 588; recall 0.974 instead of
  0.939). Now the window follows the run's frame period, and rows on no frame are counted and warned about.
- 15: ground-truth rows with extra fields, a non-UTF-8 ground-truth file, and ``"status": NaN`` in ``run.json`` were
  accepted or failed without naming the file.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

from evaluation.cli import main as eval_main
from evaluation.commands.score import score_run
from gridbridge.grid import GridSpec
from pfpeople.io.ground_truth import match_window_ns, read_gt_csv
from pfpeople.io.run_dir import RunWriter, load_run

SPEC = GridSpec(nx=10, ny=10, resolution=0.5, x0=0.0, y0=-2.5)
T0, PERIOD = 10**12, 133_333_333  # a 7.5 Hz laser
PERSON = (2.0, 0.5)


def _run(path: Path, n: int, *, seen: object = lambda k: True, skip: tuple[int, ...] = ()) -> Path:
    """A run of ``n`` scans (those in ``skip`` not made), its detector seeing the person where ``seen(k)``."""
    with RunWriter(path, spec=SPEC, detector_names=["legs"], metadata={"grid_frame": "laser"}) as w:
        for f, k in enumerate(k for k in range(n) if k not in skip):
            w.write_frame(
                frame=f,
                driver_index=k,
                stamp_ns=T0 + k * PERIOD,
                bag_time_ns=T0 + k * PERIOD + 3_000_000,
                dt_s=0.133,
                odometry=None,
                forced=False,
                belief=np.zeros(SPEC.shape),
                people=np.zeros((0, 2)),
                detections=[np.array([PERSON]) if seen(k) else np.zeros((0, 2))],  # type: ignore[operator]
            )
    return path


def _gt(path: Path, delays_ms: list[float]) -> Path:
    """GT keyed by ``bag_time_ns`` only: scan ``k``'s row recorded ``delays_ms[k]`` after the scan."""
    lines = ["bag_time_ns,person_id,x_laser_m,y_laser_m"]
    lines += [
        f"{T0 + k * PERIOD + 3_000_000 + round(d * 1e6)},1,{PERSON[0]},{PERSON[1]}" for k, d in enumerate(delays_ms)
    ]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_rows_recorded_43_to_57_ms_after_their_scan_are_all_scored(tmp_path: Path) -> None:
    """The detector misses every third scan; those scans' rows were recorded 51-57 ms after it, the others' 43-49 ms:
    a 50 ms window dropped exactly the missed scans' rows and reported a recall of 1.0."""
    n = 60
    run = load_run(_run(tmp_path / "run", n, seen=lambda k: k % 3 != 0))
    delays = [51 + (k % 7) if k % 3 == 0 else 43 + (k % 7) for k in range(n)]
    result = score_run(run, read_gt_csv(_gt(tmp_path / "gt.csv", delays)))
    assert result["gt_rows_unassigned"] == 0
    assert result["gt_match_window_s"] == pytest.approx(PERIOD * 1e-9)
    legs = result["scores"]["legs"]
    assert legs["tp"] + legs["fn"] == n and legs["recall"] == pytest.approx(40 / 60)


def test_rows_on_no_frame_are_counted_and_warned(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    run = load_run(_run(tmp_path / "run", 20, skip=(7, 8)))
    delays = [45.0] * 20
    gt_path = _gt(tmp_path / "gt.csv", delays)
    with gt_path.open("a") as fh:
        fh.write(f"{T0 - 10**9},1,2.0,0.5\n")  # before the run
        fh.write(f"{T0 + 40 * PERIOD},1,2.0,0.5\n")  # after it
    with caplog.at_level(logging.WARNING, logger="evaluation.harness.run_truth"):
        result = score_run(run, read_gt_csv(gt_path))
    assert result["gt_rows_unassigned"] == 4
    assert (result["gt_rows_before_run"], result["gt_rows_between_frames"], result["gt_rows_beyond_run"]) == (1, 2, 1)
    assert "3 ground-truth row(s)" in caplog.text and "1 before its first frame, 2 between frames" in caplog.text


def test_the_window_follows_the_frame_period() -> None:
    times = T0 + np.arange(10) * PERIOD
    assert match_window_ns("stamp_ns", times) == PERIOD // 2
    assert match_window_ns("bag_time_ns", times) == PERIOD
    assert match_window_ns("bag_time_ns", times[:1]) == 50_000_000


def test_a_gt_row_with_extra_fields_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "gt.csv"
    path.write_text("scan_index,person_id,x,y\n0,1,2.0,0.5\n1,1,2.0,0.5,7\n")
    with pytest.raises(ValueError, match=r"gt\.csv: line 3 has 5 fields, expected 4 \(the header's: scan_index"):
        read_gt_csv(path)


def test_a_gt_file_that_is_not_utf8_is_named(tmp_path: Path) -> None:
    path = tmp_path / "gt.csv"
    path.write_bytes("scan_index,person_id,x,y\n0,1,2.0,0.5 # caf\xe9\n".encode("latin-1"))
    with pytest.raises(ValueError, match=r"ground-truth file '.*gt\.csv' is not UTF-8 text \(byte 0xe9 at line 2\)"):
        read_gt_csv(path)


@pytest.mark.parametrize("status", ["NaN", "Infinity", '"done"', "1"])
def test_a_run_json_with_a_bad_status_is_refused_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture, status: str
) -> None:
    run_dir = _run(tmp_path / "run", 3)
    meta = run_dir / "run.json"
    meta.write_text(meta.read_text().replace('"status": "complete"', f'"status": {status}'))
    gt = _gt(tmp_path / "gt.csv", [45.0] * 3)
    assert eval_main(["score", str(run_dir), "--gt", str(gt)]) == 2
    err = capsys.readouterr().err
    assert "run.json" in err and ("status" in err or "not a JSON value" in err) and "Traceback" not in err
