"""The single-legs detector (its own PPV / FNR in the fusion) and the noise augmentation of the boosted
classifier's training (issue 24: standing people, one leg hidden, lasers noisier than the recordings)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gridbridge.params import CALIBRATED_LASER_DETECTORS
from pfpeople.config import config_from_mapping
from pfpeople.detect import SingleLegDetector
from pfpeople.detect.leg_tracker_bags import LabelledScan
from pfpeople.detect.synthetic import render_scan
from pfpeople.detect.training import BoostTrainingParams, augmented, noisy_scan
from pfpeople.io.bag.inspect import LASER_DETECTORS
from pfpeople.sensors import LaserScan

_INC = math.radians(0.35)


def test_single_legs_are_reported_alone_and_pairs_are_not() -> None:
    """Geometric source: a lone leg at (2, 1) is a single leg; the pair at (3, -1) is the paired detectors'
    person, and a third leg 0.4 m beside it is within ``exclude_radius`` of that person: neither is reported."""
    det = SingleLegDetector("leg")
    lone = (2.0, 1.0, 0.06)
    pair = [(3.0, -1.125, 0.06), (3.0, -0.875, 0.06)]
    beside = (3.0, -0.6, 0.06)
    found = det.detect(render_scan(circles=[lone, *pair, beside], angle_increment=_INC))
    assert found.shape == (1, 2)
    assert np.hypot(*(found[0] - [2.0, 1.0])) < 0.08  # the segment centroid lies on the leg's near side
    assert det.detect(render_scan(circles=pair, angle_increment=_INC)).shape == (0, 2)
    empty = LaserScan(ranges=np.full(50, np.inf), angle_min=-1.0, angle_increment=0.04)
    assert det.detect(empty).shape == (0, 2)
    far = SingleLegDetector("leg", exclude_radius=0.0).detect(
        render_scan(circles=[lone, *pair, beside], angle_increment=_INC)
    )
    assert far.shape == (2, 2)  # without the exclusion the leg beside the pair is reported too


def test_single_legs_detector_arguments_and_model() -> None:
    assert SingleLegDetector().model == CALIBRATED_LASER_DETECTORS[2]
    assert CALIBRATED_LASER_DETECTORS[2].name == "laser_single_legs"
    with pytest.raises(ValueError, match="source must be one of"):
        SingleLegDetector("camera")
    with pytest.raises(ValueError, match="model_path is for source"):
        SingleLegDetector("leg", model_path="x.yml")
    with pytest.raises(ValueError, match="exclude_radius"):
        SingleLegDetector(exclude_radius=-1.0)


def test_starter_detectors_include_single_legs_and_load() -> None:
    assert [k for _, k, _ in LASER_DETECTORS] == ["leg", "boosted", "single-legs"]
    cfg = config_from_mapping(
        {
            "frames": {"driver": "/scan"},
            "detectors": [{"name": n, "kind": k, "topic": "/scan"} for n, k, _ in LASER_DETECTORS],
        }
    )
    assert [d.kind for d in cfg.detectors] == ["leg", "boosted", "single-legs"]


def test_noisy_scan_adds_the_stated_noise_to_returns_only() -> None:
    """10^4 returns at 3 m: the added noise has sd 0.02 m within 3 % (sd of a sample sd: 0.7 %); no-return (+inf),
    NaN and too-close (-inf) beams keep their codes."""
    r = np.full(10_000, 3.0)
    r[:3] = [np.inf, np.nan, -np.inf]
    scan = LaserScan(ranges=r, angle_min=0.0, angle_increment=1e-4, range_min=0.05, range_max=10.0)
    out = noisy_scan(scan, 0.02, np.random.default_rng(0)).ranges
    assert math.isinf(out[0]) and out[0] > 0 and math.isnan(out[1]) and out[2] == -np.inf
    assert np.std(out[3:] - 3.0) == pytest.approx(0.02, rel=0.03)
    assert np.array_equal(scan.ranges[3:], np.full(9_997, 3.0))  # the input is not changed


def test_augmented_copies_keep_the_labels_and_are_reproducible() -> None:
    pos = [
        LabelledScan(scan=render_scan(circles=[(2.0, 0.0, 0.06)], angle_increment=_INC), legs=np.array([[1.95, 0.0]]))
    ]
    neg = [render_scan(segments=[(3.0, -2.0, 3.0, 2.0)], angle_increment=_INC)] * 2
    p = BoostTrainingParams(augment_noise=(0.01, 0.03), seed=5)
    ap, an = augmented(pos, neg, p)
    assert len(ap) == 2 and len(an) == 4
    assert all(np.array_equal(a.legs, pos[0].legs) for a in ap)
    again, _ = augmented(pos, neg, p)
    assert np.array_equal(again[1].scan.ranges, ap[1].scan.ranges, equal_nan=True)
    ok = np.isfinite(pos[0].scan.ranges)
    spread = [np.std(a.scan.ranges[ok] - pos[0].scan.ranges[ok]) for a in ap]
    assert spread[0] < spread[1]  # one copy per sd, in order
    assert augmented(pos, neg, BoostTrainingParams(augment_noise=())) == ([], [])
    with pytest.raises(ValueError, match="augment_noise"):
        BoostTrainingParams(augment_noise=(-0.01,))


def test_boosted_and_single_legs_classify_a_scan_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """The single-legs detector reuses the boosted detector's leg classification of the same scan object: one
    call of the classifier for both; a new scan, or another model, is classified again."""
    import pfpeople.detect.boosted as boosted

    calls = []
    real = boosted.boost_scores
    monkeypatch.setattr(boosted, "boost_scores", lambda m, x: calls.append(len(x)) or real(m, x))
    scan = render_scan(circles=[(2.0, 1.0, 0.06), (3.0, -1.125, 0.06), (3.0, -0.875, 0.06)], angle_increment=_INC)
    pair, single = boosted.BoostedSegmentDetector(), SingleLegDetector()
    pair.detect(scan)
    single.detect(scan)
    assert len(calls) == 1
    single.detect(render_scan(circles=[(2.0, 1.0, 0.06)], angle_increment=_INC))
    assert len(calls) == 2
