"""Single legs as support: they continue tracked walkers but never start a person (issue 9).

Unpaired single legs (:func:`pfpeople.detect.legs.people_and_single_legs`) reach the tracker as support
positions (:class:`pfpeople.track.multi_person.MultiPersonTracker` step 4c); the run reports the tracks they continue
(:class:`pfpeople.track.reported_people.PeopleTracker`), writes them to ``support.csv`` and a replay feeds them back.
"""

from __future__ import annotations

import csv
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from evaluation.harness.replay import log_from_run
from evaluation.scenarios.scan import write_scene_bag
from gridbridge.classifiers import PeakClassifier, People
from gridbridge.grid import GridSpec
from pfpeople.config import load_config
from pfpeople.detect import LegDetector, PairingParams, people_and_single_legs, people_from_legs
from pfpeople.detect.synthetic import render_scan
from pfpeople.io.bag.reader import BagSource
from pfpeople.io.run_dir import load_run
from pfpeople.pipeline.runner import Pipeline
from pfpeople.track import MultiPersonTracker, PeopleTracker, TrackerConfig

DT = 0.1
SPEC = GridSpec(nx=40, ny=40, resolution=0.25, x0=0.0, y0=-5.0)


def test_people_and_single_legs_by_hand() -> None:
    legs = np.array([[1.0, 0.0], [1.0, 0.3], [3.0, 1.0], [5.0, -1.0]])
    widths = np.array([0.12, 0.12, 0.12, 0.35])  # the last one: two legs together
    people, single = people_and_single_legs(legs, widths, params=PairingParams())
    np.testing.assert_allclose(people, [[5.0, -1.0], [1.0, 0.15]])
    np.testing.assert_allclose(single, [[3.0, 1.0]])
    np.testing.assert_allclose(people_from_legs(legs, widths, params=PairingParams()), people)
    counted, single2 = people_and_single_legs(legs, widths, params=PairingParams(count_single_legs=True))
    np.testing.assert_allclose(counted, [[5.0, -1.0], [1.0, 0.15], [3.0, 1.0]])
    np.testing.assert_allclose(single2, single)
    empty_people, empty_single = people_and_single_legs(np.zeros((0, 2)), np.zeros(0), params=PairingParams())
    assert empty_people.shape == (0, 2) and empty_single.shape == (0, 2)


def test_detect_with_singles_agrees_with_detect() -> None:
    """Two legs 0.3 m apart at 2 m and one lone leg at 3 m: one person, one single leg."""
    scan = render_scan(circles=[(2.0, 0.15, 0.06), (2.0, -0.15, 0.06), (3.0, 1.5, 0.06)])
    det = LegDetector()
    people, single = det.detect_with_singles(scan)
    np.testing.assert_allclose(det.detect(scan), people)
    assert people.shape == (1, 2) and single.shape == (1, 2)
    # the returns lie on the near half of each leg: centroid 2 - 0.06 * pi / 4 = 1.953 m
    np.testing.assert_allclose(people[0], [1.953, 0.0], atol=0.01)
    np.testing.assert_allclose(single[0], [3.0, 1.5], atol=0.08)


def _walk(tracker: MultiPersonTracker, frames: int, *, speed: float = 1.0, x0: float = 1.0) -> float:
    x = x0
    for _ in range(frames):
        tracker.update(np.array([[x, 0.0]]), DT)
        x += speed * DT
    return x


def test_support_continues_a_confirmed_walker_and_keeps_its_id() -> None:
    t = MultiPersonTracker()
    x = _walk(t, 10)
    (track,) = t.confirmed()
    for _ in range(5):  # only one leg is seen, 0.12 m beside the walker's centre
        out = t.update(np.zeros((0, 2)), DT, support=np.array([[x, 0.12]]))
        x += 0.1
    (after,) = out
    assert after.id == track.id and after.misses == 0 and after.supported and after.measurement == -1
    assert after.x == pytest.approx(x - 0.1, abs=0.05) and after.vx == pytest.approx(1.0, abs=0.2)
    # without the single leg the same walker coasts
    t2 = MultiPersonTracker()
    _walk(t2, 10)
    for _ in range(5):
        (coast,) = t2.update(np.zeros((0, 2)), DT)
    assert coast.misses == 5 and not coast.supported


def test_support_never_starts_or_confirms_a_track() -> None:
    t = MultiPersonTracker()
    for _ in range(20):
        t.update(np.zeros((0, 2)), DT, support=np.array([[2.0, 1.0], [3.0, -1.0]]))
    assert t.tracks == []
    t.update(np.array([[2.0, 0.0]]), DT)  # a tentative track is not continued by support either
    t.update(np.zeros((0, 2)), DT, support=np.array([[2.0, 0.0]]))
    (tentative,) = t.tracks
    assert not tentative.confirmed and tentative.misses == 1 and tentative.hits == 1


def test_support_needs_a_moving_track() -> None:
    """A confirmed track standing still (a chair taken for a person) is not continued by single legs
    (``support_min_speed``, 0.6 m/s by default); with the gate at 0 it is."""
    for min_speed, expect_misses in ((0.6, 3), (0.0, 0)):
        t = MultiPersonTracker(TrackerConfig(support_min_speed=min_speed))
        for _ in range(10):
            t.update(np.array([[2.0, 0.0]]), DT)
        for _ in range(3):
            (tr,) = t.update(np.zeros((0, 2)), DT, support=np.array([[2.0, 0.12]]))
        assert tr.misses == expect_misses


def test_support_beside_a_found_person_is_its_other_leg() -> None:
    """Two walkers side by side 0.7 m apart; only A is found, with a single leg 0.2 m from A, inside B's gate:
    the leg is left out (``support_exclusion`` 0.4 m), so B coasts instead of jumping onto A's leg."""
    t = MultiPersonTracker()
    for k in range(10):
        t.update(np.array([[1.0 + 0.1 * k, 0.0], [1.0 + 0.1 * k, 0.7]]), DT)
    out = t.update(np.array([[2.0, 0.0]]), DT, support=np.array([[2.0, 0.2]]))
    by_y = sorted(out, key=lambda tr: tr.y)
    assert by_y[0].measurement == 0 and by_y[1].misses == 1 and not by_y[1].supported


def test_bad_support_is_named() -> None:
    t = MultiPersonTracker()
    with pytest.raises(ValueError, match="support contains NaN"):
        t.update(np.zeros((0, 2)), DT, support=np.array([[np.nan, 0.0]]))
    with pytest.raises(ValueError, match=r"support must have shape \(M, 2\)"):
        t.update(np.zeros((0, 2)), DT, support=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="support_min_speed"):
        TrackerConfig(support_min_speed=-1.0)


def _people(x: float) -> People:
    mask = np.zeros(SPEC.shape, dtype=bool)
    return People(positions=np.array([[x, 0.0]]), scores=np.array([0.9]), sizes=np.array([3]), mask=mask)


@pytest.mark.parametrize("use_support", [True, False])
def test_people_tracker_reports_the_supported_walker(use_support: bool) -> None:
    pt = PeopleTracker(PeakClassifier(threshold=0.7), coast_frames=1, use_support=use_support)
    belief = np.full(SPEC.shape, 0.01)
    for k in range(10):
        pt.step(_people(1.0 + 0.1 * k), belief, SPEC, DT)
    none = People(
        positions=np.zeros((0, 2)), scores=np.zeros(0), sizes=np.zeros(0, np.int64), mask=np.zeros(SPEC.shape, bool)
    )
    reported = [len(pt.step(none, belief, SPEC, DT, support=np.array([[2.0 + 0.1 * k, 0.1]])).people) for k in range(4)]
    # with support the walker is reported in all four frames; without, through 1 coasting frame only
    assert reported == ([1, 1, 1, 1] if use_support else [1, 0, 0, 0])


@pytest.fixture(scope="module")
def wheelchair_runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    """The simulated wheelchair scene (150 scans, 20 s) run with and without single legs."""
    tmp = tmp_path_factory.mktemp("single_legs")
    sb = write_scene_bag("wheelchair", tmp / "bag", frames=150, seed=0)
    cfg = load_config(sb.run_toml)
    for name, on in (("with", True), ("without", False)):
        c = replace(cfg, tracking=replace(cfg.tracking, single_legs=on))
        with BagSource(sb.bag) as src:
            Pipeline(c).run(src, tmp / name)
    return tmp / "with", tmp / "without", sb.gt_csv


def _recall(run_dir: Path, gt: Path) -> float:
    from evaluation.harness.run_truth import truth_and_sources
    from evaluation.metrics.detection import DetectionAccumulator
    from pfpeople.io.ground_truth import read_gt_csv

    run = load_run(run_dir)
    truth, sources, _ = truth_and_sources(run, read_gt_csv(gt), frame="laser")
    acc = DetectionAccumulator(gate=0.5)
    for k in range(run.n_frames):
        acc.add(sources["filter"][k], truth[k])
    return float(acc.summary()["recall"])


def test_run_writes_support_and_a_replay_reads_it(wheelchair_runs: tuple[Path, Path, Path]) -> None:
    with_dir, without_dir, gt = wheelchair_runs
    assert not (without_dir / "support.csv").exists() and load_run(without_dir).support is None
    run = load_run(with_dir)
    assert run.support is not None and len(run.support["frame"]) > 50
    with (with_dir / "support.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(run.support["frame"])
    assert set(run.support["detector"]) <= set(run.meta["detectors"])
    for suppressed in (True, False):
        log = log_from_run(with_dir, gt=gt, frame="laser", suppressed=suppressed)
        assert log.support is not None and len(log.support) == run.n_frames
        keep = ~run.support["static"].astype(bool) if suppressed else np.ones(len(rows), dtype=bool)
        assert sum(len(s) for s in log.support) == int(keep.sum())
    assert log_from_run(without_dir, gt=gt, frame="laser").support is None


def test_single_legs_raise_recall_on_the_wheelchair_scene(wheelchair_runs: tuple[Path, Path, Path]) -> None:
    """Measured on these 150 scans: recall 0.590 with single legs, 0.554 without (0.514 / 0.449
    before the peak classifiers kept two people standing 0.6-0.85 m apart). Bound: at least +0.025."""
    with_dir, without_dir, gt = wheelchair_runs
    r_with, r_without = _recall(with_dir, gt), _recall(without_dir, gt)
    assert r_with >= r_without + 0.025


def test_log_truth_inside_the_grid(wheelchair_runs: tuple[Path, Path, Path], tmp_path: Path) -> None:
    """``log_from_run(in_grid=True)`` (the benchmark's scoring) drops true people outside the run's grid."""
    with_dir, _, gt = wheelchair_runs
    with gt.open() as fh:
        rows = list(csv.DictReader(fh))
    far = dict(rows[0], person_id="999", x_laser_m="50.0", y_laser_m="0.0")
    gt2 = tmp_path / "gt_far.csv"
    with gt2.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows([*rows, far])
    every = log_from_run(with_dir, gt=gt2, frame="laser")
    inside = log_from_run(with_dir, gt=gt2, frame="laser", in_grid=True)
    assert sum(len(t) for t in every.truth) == sum(len(t) for t in inside.truth) + 1
    spec = inside.spec
    assert all(spec.contains(t[:, 0], t[:, 1]).all() for t in inside.truth if len(t))


def test_score_in_grid(wheelchair_runs: tuple[Path, Path, Path], tmp_path: Path) -> None:
    """``pfpeople-eval score --in-grid``: a true person outside the grid is no longer a miss of every source."""
    from evaluation.commands.score import score_run
    from pfpeople.io.ground_truth import read_gt_csv

    with_dir, _, gt = wheelchair_runs
    with gt.open() as fh:
        rows = list(csv.DictReader(fh))
    gt2 = tmp_path / "gt_far.csv"
    with gt2.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows([*rows, dict(rows[0], person_id="999", x_laser_m="50.0", y_laser_m="0.0")])
    run = load_run(with_dir)
    every = score_run(run, read_gt_csv(gt2), frame="laser")["scores"]
    inside = score_run(run, read_gt_csv(gt2), frame="laser", in_grid=True)["scores"]
    for name in ("filter", "laser_legs", "laser_boosted"):
        assert every[name]["fn"] == inside[name]["fn"] + 1 and every[name]["tp"] == inside[name]["tp"]
