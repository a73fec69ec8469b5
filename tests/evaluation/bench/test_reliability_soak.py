"""The soak benchmark's machinery on a few steps (the benchmark itself is ``python -m evaluation.bench.soak``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from evaluation.bench.soak import soak, soak_modes
from gridbridge import GridFilter, GridSpec

SMALL = GridSpec(nx=8, ny=8, resolution=0.5, x0=0.0, y0=-2.0)


def test_soak_modes_run_and_report_bounded_beliefs() -> None:
    assert {"grid-paper", "grid-linear", "particle", "particle-persistent"} <= set(soak_modes())
    r = soak("small", lambda rng: GridFilter(SMALL, form="paper"), 20, seed=3)
    assert r.steps == 20 and r.bad_steps == 0
    assert 0.0 <= r.mass_min <= r.mass_max <= SMALL.n_cells
    assert r.rss_start_mib > 0 and r.peak_end_mib >= r.peak_start_mib > 0
    with pytest.raises(ValueError, match="steps must be at least 10"):
        soak("small", lambda rng: GridFilter(SMALL), 5)


def test_the_bag_soak_writes_a_bag_of_the_frames_asked_for(tmp_path: Path) -> None:
    from evaluation.bench.soak_bag import CYCLE, write_soak_bag
    from pfpeople.io.bag.reader import BagSource

    write_soak_bag(tmp_path / "s.bag", 12)
    with BagSource(tmp_path / "s.bag") as src:
        assert src.message_counts == {"/tf_static": 1, "/scan": 12}
        scans = [m for m in src.messages(["/scan"])]
    assert [m.stamp_ns - scans[0].stamp_ns for m in scans[:3]] == [0, 100_000_000, 200_000_000]
    assert len(scans[0].msg.ranges) == 361 and CYCLE > 12
