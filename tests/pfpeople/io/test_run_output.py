"""The run directory (pfpeople.io.run_dir): readable while written and after a crash."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gridbridge.grid import GridSpec
from pfpeople.io.run_dir import RunWriter, load_run


def test_run_output_is_readable_while_written_and_after_a_crash(tmp_path: Path) -> None:
    spec = GridSpec(nx=4, ny=3)
    w = RunWriter(tmp_path / "run", spec=spec, detector_names=["a", "b"], metadata={"x": 1})
    for k in range(3):
        w.write_frame(
            frame=k,
            driver_index=10 + k,
            stamp_ns=k * 100,
            bag_time_ns=k * 100 + 1,
            dt_s=0.1,
            odometry=(0.5, 0.1),
            forced=False,
            belief=np.full(spec.shape, 0.1 * k),
            people=np.array([[1.0, 0.5]]) if k else np.zeros((0, 2)),
            people_size=[2] if k else [],
            people_probability=[0.8] if k else [],
            detections=[np.array([[1.0, 0.4], [2.0, 0.0]]), None],
        )
        run = load_run(tmp_path / "run")  # the process could die here: everything written so far is readable
        assert run.n_frames == k + 1 and run.meta["status"] == "running"
    np.testing.assert_allclose(run.grids[2], 0.2, rtol=1e-6)
    assert list(run.frames["driver_index"]) == [10, 11, 12] and list(run.frames["no_data"]) == ["b"] * 3
    assert list(run.people["frame"]) == [1, 2] and run.people["x_m"][0] == 1.0
    assert list(run.detections["detector"]) == ["a"] * 6
    w.close(status="complete")
    assert load_run(tmp_path / "run").meta["status"] == "complete"
    with pytest.raises(FileExistsError, match="already holds a run"):
        RunWriter(tmp_path / "run", spec=spec, detector_names=["a"])
    with pytest.raises(FileNotFoundError, match="not a run directory"):
        load_run(tmp_path)


def test_particle_records_are_the_sorted_seeded_subsample() -> None:
    """particle_records: the frame-seeded choice without replacement, in index order (as np.sort of it)."""
    from pfpeople.io.run_dir import MAX_PARTICLES_SAVED, PARTICLE_DTYPE, particle_records

    rng = np.random.default_rng(2)
    for n, frame in ((10, 0), (MAX_PARTICLES_SAVED, 3), (MAX_PARTICLES_SAVED + 1, 4), (20_500, 7)):
        x, y = rng.normal(size=n), rng.normal(size=n)
        rec = particle_records(frame, x, y)
        idx = np.arange(n)
        if n > MAX_PARTICLES_SAVED:
            idx = np.sort(np.random.default_rng(frame).choice(n, MAX_PARTICLES_SAVED, replace=False))
        want = np.zeros(len(idx), dtype=PARTICLE_DTYPE)
        want["frame"], want["x"], want["y"] = frame, x[idx], y[idx]
        assert rec.tobytes() == want.tobytes()


def test_scan_records_drop_nonfinite_points_and_keep_flags() -> None:
    from pfpeople.io.run_dir import SCAN_DTYPE, scan_records

    pts = np.array([[1.0, 2.0], [np.nan, 1.0], [3.0, 4.0], [5.0, np.inf]])
    static = np.array([True, False, False, True])
    topics: list[str] = []
    rec = scan_records(7, {"/a": (pts, static), "/b": (pts[[0, 2]], None)}, topics)
    assert topics == ["/a", "/b"] and rec.dtype == SCAN_DTYPE
    assert rec["laser"].tolist() == [0, 0, 1, 1] and set(rec["frame"].tolist()) == {7}
    assert rec["x"].tolist() == [1.0, 3.0, 1.0, 3.0] and rec["y"].tolist() == [2.0, 4.0, 2.0, 4.0]
    assert rec["static"].tolist() == [1, 0, 0, 0]
