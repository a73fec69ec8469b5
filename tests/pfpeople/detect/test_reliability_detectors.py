"""Issue 46, findings 10 and 11: detectors that went blind silently.

- 10: a boosted model file with NaN leaves loaded, and the detector then found nobody;
- 11: scans much denser than the lasers the detectors are built for blinded them (two people, the boosted detector
  found 1 a scan at 0.02 deg and none at 0.005 deg), without a warning: now their scans are thinned to the spacing
  they are built for (:mod:`pfpeople.detect.spacing`) and a run warns once.
"""

from __future__ import annotations

import logging
import math
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from bag_fixtures import PEOPLE, legs, legs_only, write_scan_bag

from pfpeople.config import DetectorConfig
from pfpeople.detect import BoostedSegmentDetector
from pfpeople.detect.adapters import BoostedAdapter, LegAdapter, SingleLegAdapter
from pfpeople.detect.boosted import default_model_path
from pfpeople.detect.spacing import detector_scan, thinning
from pfpeople.detect.synthetic import render_scan
from pfpeople.io.bag.reader import BagMessage, BagSource
from pfpeople.pipeline.runner import Pipeline
from pfpeople.sensors import Pose2D


def _damaged_model(tmp_path: Path, old: str, new: str) -> Path:
    text = default_model_path().read_text()
    assert old in text
    path = tmp_path / "damaged.yml"
    path.write_text(text.replace(old, new, 1))
    return path


@pytest.mark.parametrize(
    ("old", "new", "where"),
    [
        ("value: -0.71012529630875942", "value: .Nan", r"tree 0 node 3 has the value nan"),
        ("value: -0.71012529630875942", "value: .Inf", r"tree 0 node 3 has the value inf"),
        ("le:0.13181589543819427", "le:.Nan", r"tree 0 node 0 splits at le nan"),
    ],
)
def test_a_boosted_model_with_a_nan_leaf_is_refused_naming_the_tree(
    tmp_path: Path, old: str, new: str, where: str
) -> None:
    """Finding 10: the model loaded and every segment scored NaN (nobody found, silently)."""
    path = _damaged_model(tmp_path, old, new)
    with pytest.raises(ValueError, match=rf"boosted model file '.*damaged\.yml' is damaged: {where}"):
        BoostedSegmentDetector(model_path=path)


def _msg(spacing_deg: float) -> BagMessage:
    scan = render_scan(circles=legs(PEOPLE), angle_increment=math.radians(spacing_deg))
    n = scan.ranges.size
    msg = SimpleNamespace(
        ranges=scan.ranges,
        range_min=0.05,
        range_max=10.0,
        angle_min=scan.angle_min,
        angle_max=scan.angle_min + scan.angle_increment * (n - 1),
        angle_increment=scan.angle_increment,
    )
    return BagMessage("/scan", "sensor_msgs/msg/LaserScan", 0, 1, 1, "laser", msg)


@pytest.mark.parametrize("adapter", [LegAdapter, BoostedAdapter])
@pytest.mark.parametrize("spacing_deg", [0.5, 0.25, 0.02, 0.005])
def test_the_laser_detectors_find_both_people_on_dense_scans(adapter: type, spacing_deg: float) -> None:
    """Finding 11: two people at 2 and 3 m; the detectors get the dense scans thinned to about 0.3 deg."""
    cfg = DetectorConfig(name="d", kind="leg" if adapter is LegAdapter else "boosted", topic="/scan")
    found = adapter(cfg, Pose2D(), None).detect([_msg(spacing_deg)])
    assert found.scan is not None and found.scan.ranges.size == round(180 / spacing_deg) + 1  # every beam kept
    assert len(found.grid) == 2
    assert np.min(np.linalg.norm(found.grid[:, None] - PEOPLE[None], axis=-1), axis=0).max() < 0.15


def test_the_detectors_of_one_laser_share_the_thinned_scan() -> None:
    msg = _msg(0.02)
    a = BoostedAdapter(DetectorConfig(name="b", kind="boosted", topic="/scan"), Pose2D(), None)
    b = SingleLegAdapter(DetectorConfig(name="s", kind="single-legs", topic="/scan"), Pose2D(), None)
    a.detect([msg]), b.detect([msg])
    scan = a.read(msg)
    assert b.read(msg) is scan and detector_scan(scan) is detector_scan(scan)
    assert thinning(scan.angle_increment) == 15 and detector_scan(scan).ranges.size == scan.ranges[::15].size


@pytest.mark.parametrize(("spacing_deg", "k"), [(1.0, 1), (0.25, 1), (0.2, 1), (0.1667, 2), (0.1, 3), (0.005, 60)])
def test_the_thinning_of_a_spacing(spacing_deg: float, k: int) -> None:
    assert thinning(math.radians(spacing_deg)) == k


def test_a_run_on_a_dense_laser_warns_once_and_finds_the_people(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    bag = tmp_path / "dense.bag"
    write_scan_bag(bag, 3, angle_increment=math.radians(0.01))
    with BagSource(bag) as src, caplog.at_level(logging.WARNING):
        _, results = Pipeline(legs_only(), front_process=False).run(src, None, keep=True)
    warned = [r.message for r in caplog.records if "finer than the laser detectors are built for" in r.message]
    assert len(warned) == 1
    assert re.search(r"topic /scan: beam spacing 0.01 deg .* legs get every 30-th beam \(0.3 deg\)", warned[0])
    assert all(r.detections[0] is not None and len(r.detections[0]) == 2 for r in results)
