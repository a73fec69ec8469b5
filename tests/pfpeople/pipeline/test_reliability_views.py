"""Issue 46, finding 6: fields of view follow each scan.

Scans narrower than the configured field of view (a consistent ``angle_min`` and beam count, or one beam) had their
unscanned sector treated as seen empty: a person's belief fell from 0.99 to 0.02 in 6 frames, with no warning and no
count. Now each scan gives its detectors the field of view it covers (:mod:`pfpeople.detect.coverage`): a sector a
scan did not cover gets no update, the frames are counted in ``stats.fov_narrowed`` and warned once per detector.
The bags are ``write_scan_bag``'s: two people standing at ``PEOPLE`` (bearings 21.8 and -18.4 deg), 0.5 deg beams
over -90 .. 90 deg.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np
import pytest
from bag_fixtures import INC, PEOPLE, legs_only, write_scan_bag

from gridbridge.grid import GridSpec
from pfpeople.config import FilterConfig
from pfpeople.detect.coverage import frame_view, scan_sector
from pfpeople.io.bag.reader import BagSource
from pfpeople.io.run_dir import load_run
from pfpeople.pipeline.runner import Pipeline
from pfpeople.sensors import LaserScan

N_BEAMS = 361  # -90 .. 90 deg at 0.5 deg
NARROW = slice(160, 201)  # -10 .. 10 deg: neither person


def _narrowing(k: int) -> slice:
    return NARROW if k >= 5 else slice(None)


@pytest.mark.parametrize("two_processes", [False, True])
def test_a_sector_a_scan_did_not_cover_gets_no_update(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, two_processes: bool
) -> None:
    bag = tmp_path / "narrow.bag"
    write_scan_bag(bag, 12, beams_of=_narrowing)
    pipe = Pipeline(legs_only(), front_process=two_processes)
    with BagSource(bag) as src, caplog.at_level(logging.WARNING):
        summary, results = pipe.run(src, tmp_path / "run", keep=True)
    spec = pipe.spec
    assert spec is not None
    cells = [spec.to_cell(x, y) for x, y in PEOPLE]
    for k, r in enumerate(results):
        step = r.step
        for i, j in cells:
            i, j = int(i), int(j)
            if k >= 5:  # outside the scanned sector: the posterior is the prior (no "nobody there")
                assert step.posterior[i, j] == step.sensor_prior[i, j]
            else:
                assert step.posterior[i, j] > step.sensor_prior[i, j]  # seen: detected, raised
    assert results[4].belief[tuple(int(v) for v in cells[0])] > 0.5
    assert summary.fov_narrowed == {"legs": 7}
    assert load_run(tmp_path / "run").meta["stats"]["fov_narrowed"] == {"legs": 7}
    warned = [r.message for r in caplog.records if "less than its field of view" in r.message]
    assert (
        len(warned) == 1 and "covers -10.25 .. 10.25 deg, less than its field of view -90.00 .. 90.00 deg" in warned[0]
    )
    assert pipe.filter is not None
    d = pipe.filter.detectors[0]
    assert (d.fov_min, d.fov_max) == pytest.approx(np.radians([-10.25, 10.25]))


def test_the_view_comes_back_when_the_scans_widen_again(tmp_path: Path) -> None:
    bag = tmp_path / "back.bag"
    write_scan_bag(bag, 8, beams_of=lambda k: NARROW if 2 <= k < 5 else slice(None))
    pipe = Pipeline(legs_only(), front_process=False)
    with BagSource(bag) as src:
        summary, results = pipe.run(src, None, keep=True)
    assert summary.fov_narrowed == {"legs": 3}
    assert pipe.filter is not None
    assert (pipe.filter.detectors[0].fov_min, pipe.filter.detectors[0].fov_max) == pytest.approx(
        (-math.pi / 2, math.pi / 2)
    )
    assert np.asarray(results[-1].step.covered).sum() == np.asarray(results[0].step.covered).sum()


def test_a_one_beam_scan_covers_nothing_and_is_no_data(tmp_path: Path) -> None:
    bag = tmp_path / "one.bag"
    write_scan_bag(bag, 6, beams_of=lambda k: slice(180, 181) if k in (2, 3) else slice(None))
    with BagSource(bag) as src:
        summary, results = Pipeline(legs_only(), front_process=False).run(src, None, keep=True)
    assert summary.no_data == {"legs": 2} and summary.bad_scans == {"legs": {"sector": 2}}
    for k in (2, 3):
        assert results[k].detections[0] is None
        np.testing.assert_array_equal(results[k].step.posterior, results[k].step.sensor_prior)


def test_the_particle_filter_follows_the_view(tmp_path: Path) -> None:
    bag = tmp_path / "narrow.bag"
    write_scan_bag(bag, 7, beams_of=_narrowing)
    cfg = legs_only(filter=FilterConfig(kind="particle", n_particles=5000), grid=GridSpec(x0=0.0, y0=-4.5))
    pipe = Pipeline(cfg, front_process=False)
    with BagSource(bag) as src:
        summary, _ = pipe.run(src, None)
    assert summary.fov_narrowed == {"legs": 2}
    assert pipe.filter is not None
    assert pipe.filter.detectors[0].fov_max == pytest.approx(math.radians(10.25))


def _scan(a0_deg: float, n: int, inc_deg: float = 0.5) -> LaserScan:
    return LaserScan(ranges=np.ones(n), angle_min=math.radians(a0_deg), angle_increment=math.radians(inc_deg))


@pytest.mark.parametrize(
    ("view_deg", "scan", "expect_deg"),
    [
        ((-90, 90), _scan(-90, 361), None),  # the configured scan itself
        ((-90, 90.5), _scan(-90, 361), None),  # angle_max one step past the last beam: not narrower
        ((-90, 90), _scan(-10, 41), (-10.25, 10.25)),
        ((-90, 90), _scan(90, 361, -0.5), None),  # reversed: the same sector
        ((-90, 90), _scan(10, 41, -0.5), (-10.25, 10.25)),
        ((-180, 179.5), _scan(0, 720), None),  # a full turn in [0, 360) covers a view in [-180, 180)
        ((-180, 179.5), _scan(180, 181), (-180, -89.75)),  # bearings a turn apart
        ((-180, 179.5), _scan(170, 41), (-180, -169.75)),  # across the seam: the larger part of the view
        ((-90, 90), _scan(0, 1), (-90, -90)),  # one beam: nothing
        ((-90, 90), _scan(120, 10), (-90, -90)),  # another sector: nothing
    ],
)
def test_frame_view(view_deg: tuple, scan: LaserScan, expect_deg: tuple | None) -> None:
    got = frame_view((math.radians(view_deg[0]), math.radians(view_deg[1])), scan)
    if expect_deg is None:
        assert got is None
    else:
        assert got is not None and np.degrees(got) == pytest.approx(expect_deg)


def test_scan_sector_is_half_a_beam_beyond_the_first_and_last() -> None:
    assert np.degrees(scan_sector(_scan(-10, 41))) == pytest.approx((-10.25, 10.25))
    assert np.degrees(scan_sector(_scan(10, 41, -0.5))) == pytest.approx((-10.25, 10.25))
    assert math.degrees(INC) == 0.5 and N_BEAMS == 361
