"""Peaks with hysteresis (gridbridge.classifiers.HysteresisPeaks) and its configuration."""

from __future__ import annotations

import numpy as np
import pytest

from gridbridge.classifiers import HysteresisPeaks, PeakClassifier, classify_frame
from gridbridge.ego_motion import Odometry, odometry_pose
from gridbridge.geometry import Pose2D
from gridbridge.grid import GridSpec
from pfpeople.config import ClassifierConfig
from pfpeople.pipeline.assembly import build_classifier

SPEC = GridSpec()  # 30 x 30 cells of 0.3 m, x in [0, 9], y in [-4.5, 4.5]


def belief_with(*peaks: tuple[float, float, float]) -> np.ndarray:
    """A belief of 0.01 with single-cell peaks (x, y, value)."""
    b = np.full(SPEC.shape, 0.01)
    for x, y, v in peaks:
        i, j = SPEC.to_cell(x, y)
        b[int(i), int(j)] = v
    return b


def centre(x: float, y: float) -> np.ndarray:
    i, j = SPEC.to_cell(x, y)
    return np.asarray(SPEC.cell_centre(float(i), float(j)))


def test_a_person_continues_above_keep_and_a_new_peak_needs_start() -> None:
    h = HysteresisPeaks(threshold=0.7, keep=0.5, gate=0.5)
    first = h.classify(belief_with((3.0, 0.0, 0.8)), SPEC)
    assert np.allclose(first.positions, [centre(3.0, 0.0)])
    # next frame: the person's peak fell to 0.6 one cell on (continues); a new 0.6 peak far away does not start
    second = h.classify(belief_with((3.3, 0.0, 0.6), (6.0, 2.0, 0.6)), SPEC)
    assert np.allclose(second.positions, [centre(3.3, 0.0)])
    assert second.scores.tolist() == [0.6]
    i, j = SPEC.to_cell(6.0, 2.0)
    assert not second.mask[int(i), int(j)]  # the rejected peak's cells are not people (FPCPF)
    assert h.rejected is not None and np.allclose(h.rejected.positions, [centre(6.0, 2.0)])  # kept for a tracker
    assert h.rejected.scores.tolist() == [0.6]
    # at or below keep the person ends; a plain peak classifier at 0.7 would have lost it one frame earlier
    assert h.classify(belief_with((3.3, 0.0, 0.5)), SPEC).positions.shape == (0, 2)
    assert PeakClassifier(threshold=0.7).classify(belief_with((3.3, 0.0, 0.6)), SPEC).positions.shape == (0, 2)
    h.classify(belief_with((3.0, 0.0, 0.8)), SPEC)
    h.reset()
    assert h.classify(belief_with((3.0, 0.0, 0.6)), SPEC).positions.shape == (0, 2)


def test_the_previous_people_move_with_the_grid() -> None:
    """The robot drives 1 m forward: the person seen at x = 3 m is now at x = 2 m of the grid frame."""
    ego = odometry_pose(Odometry(v=1.0, omega=0.0), 1.0)
    assert (ego.x, ego.y, ego.yaw) == pytest.approx((1.0, 0.0, 0.0))
    for where, kept in ((2.0, True), (3.0, False)):
        h = HysteresisPeaks(threshold=0.7, keep=0.5, gate=0.5)
        h.classify(belief_with((3.0, 0.0, 0.8)), SPEC)
        got = classify_frame(h, belief_with((where, 0.0, 0.6)), SPEC, ego=ego)
        assert got.positions.shape[0] == int(kept)
    assert odometry_pose(None, 0.1) == Pose2D()
    with pytest.raises(TypeError, match="ego"):
        HysteresisPeaks().classify(belief_with(), SPEC, ego=(1.0, 0.0, 0.0))  # type: ignore[arg-type]


def test_thresholds_are_checked_and_the_config_builds_the_right_classifier() -> None:
    with pytest.raises(ValueError, match="keep must be <= threshold"):
        HysteresisPeaks(threshold=0.6, keep=0.7)
    with pytest.raises(ValueError, match=r"\[classifier\] keep: must be less than or equal to 1, got 1\.5"):
        ClassifierConfig(keep=1.5)
    default = build_classifier(ClassifierConfig())
    assert isinstance(default, HysteresisPeaks) and (default.threshold, default.keep) == (0.7, 0.5)
    assert isinstance(build_classifier(ClassifierConfig(keep=0.7)), PeakClassifier)
    assert isinstance(build_classifier(ClassifierConfig(threshold=0.4)), PeakClassifier)  # keep capped at 0.4
    assert isinstance(build_classifier(ClassifierConfig(threshold=0.6, keep=0.7)), PeakClassifier)  # the same
    # a stateless classifier ignores ego
    assert classify_frame(
        PeakClassifier(threshold=0.7), belief_with((3.0, 0.0, 0.8)), SPEC, ego=Pose2D(x=5.0)
    ).positions.shape == (1, 2)
