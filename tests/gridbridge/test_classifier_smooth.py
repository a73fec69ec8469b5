"""Peaks found on a smoothed belief (``classify_peaks(smooth=...)``, ``[classifier] smooth``): hand-made grids."""

from __future__ import annotations

import numpy as np
import pytest

from gridbridge.classifiers import HysteresisPeaks, PeakClassifier, classify_peaks
from gridbridge.grid import GridSpec
from pfpeople.config import ClassifierConfig
from pfpeople.pipeline.assembly import build_classifier
from pfpeople.track.belief_inputs import tracker_inputs

SPEC = GridSpec(nx=20, ny=20, resolution=0.3, x0=0.0, y0=-3.0)


def _ragged_person() -> np.ndarray:
    """One person as the particle filter rasterises them: a blob of 0.5-0.6 cells with two cells at the bound
    0.99, three cells (0.9 m) apart, so a 0.6 m non-maximum suppression keeps both."""
    g = np.full(SPEC.shape, 0.01)
    g[8:12, 8:12] = 0.55
    g[8, 9] = g[11, 10] = 0.99
    return g


def test_a_ragged_blob_is_one_person_when_smoothed_and_its_score_is_the_raw_peak() -> None:
    g = _ragged_person()
    raw = classify_peaks(g, SPEC, threshold=0.7, min_separation=0.6)
    assert len(raw.positions) == 2  # the doubles the particle pipeline reports
    one = classify_peaks(g, SPEC, threshold=0.7, min_separation=0.6, smooth=1.0)
    assert len(one.positions) == 1
    # the score is the largest belief within one cell of the smoothed maximum (the threshold keeps its meaning)
    assert one.scores[0] == pytest.approx(0.99)
    centre = np.array(SPEC.cell_centre(9.5, 9.5))
    assert np.hypot(*(one.positions[0] - centre)) < 0.35  # inside the blob, near its middle


def test_two_people_apart_stay_two_and_no_smoothing_is_the_old_classifier() -> None:
    g = np.full(SPEC.shape, 0.01)
    g[4:6, 4:6] = 0.95  # two compact people 1.8 m apart
    g[10:12, 4:6] = 0.9
    for smooth in (0.7, 1.0):
        p = classify_peaks(g, SPEC, threshold=0.7, min_separation=0.6, smooth=smooth)
        assert sorted(np.round(p.scores, 2).tolist()) == [0.9, 0.95]
        assert np.hypot(*(p.positions[0] - p.positions[1])) == pytest.approx(1.8, abs=0.15)
    rng = np.random.default_rng(3)
    noisy = np.clip(rng.random(SPEC.shape) ** 3, 0, 1)
    a = classify_peaks(noisy, SPEC, threshold=0.5, min_separation=0.6)
    b = classify_peaks(noisy, SPEC, threshold=0.5, min_separation=0.6, smooth=0.0)
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.scores, b.scores)
    np.testing.assert_array_equal(a.mask, b.mask)


def test_the_config_reaches_both_peak_classifiers_and_the_tracker_inputs() -> None:
    hyst = build_classifier(ClassifierConfig(smooth=1.0))
    assert isinstance(hyst, HysteresisPeaks) and hyst.peaks.smooth == 1.0
    plain = build_classifier(ClassifierConfig(smooth=1.0, keep=0.7))
    assert isinstance(plain, PeakClassifier) and plain.smooth == 1.0
    assert build_classifier(ClassifierConfig()).peaks.smooth == 0.0  # type: ignore[union-attr]
    g = _ragged_person()
    g[8:12, 8:12] = np.where(g[8:12, 8:12] > 0.9, 0.65, 0.55)  # the same blob between the two thresholds
    people = plain.classify(g, SPEC)
    assert len(people.positions) == 0
    low = PeakClassifier(threshold=0.5, min_separation=0.6, smooth=1.0)
    pos, sc = tracker_inputs(people, g, SPEC, low=low, high=0.7)
    assert pos.shape == (1, 2) and sc.tolist() == [pytest.approx(0.65)]  # one weaker peak, not two
    pos, _ = tracker_inputs(people, g, SPEC, low=PeakClassifier(threshold=0.5, min_separation=0.6), high=0.7)
    assert pos.shape == (4, 2)  # unsmoothed: the two high cells and the plateau's corners 0.6 m from both


@pytest.mark.parametrize("bad", [-0.5, float("nan"), True, "1"])
def test_bad_smooth_is_refused_naming_it(bad: object) -> None:
    with pytest.raises(ValueError, match="smooth"):
        ClassifierConfig(smooth=bad)  # type: ignore[arg-type]
    with pytest.raises((ValueError, TypeError), match="smooth"):
        classify_peaks(_ragged_person(), SPEC, smooth=bad)  # type: ignore[arg-type]
