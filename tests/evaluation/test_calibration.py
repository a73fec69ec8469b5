"""Detector calibration: matching, counts, Wilson intervals, recovery of the simulator's configured rates."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from evaluation.cli import main as eval_main
from evaluation.harness.calibration import (
    CalibrationCounts,
    calibrate_detector,
    calibrate_frames,
    match_detections,
    oracle_calibration,
    wilson_interval,
)
from evaluation.scenarios import Scenario, load_scenario_config
from gridbridge.grid import GridSpec
from gridbridge.params import PAPER_DETECTORS

LASER, _, CAMERA = PAPER_DETECTORS


def test_wilson_interval_reference_values() -> None:
    # Newcombe (1998), Stat. Med. 17:857, Table I: 0/10 -> (0, 0.2775); 81/263 -> (0.2553, 0.3662)
    lo, hi = wilson_interval(0, 10)
    assert lo == 0.0 and hi == pytest.approx(0.2775, abs=1e-4)
    lo, hi = wilson_interval(81, 263)
    assert (lo, hi) == (pytest.approx(0.2553, abs=1e-4), pytest.approx(0.3662, abs=1e-4))
    assert wilson_interval(0, 0) == (0.0, 1.0)
    with pytest.raises(ValueError, match="successes"):
        wilson_interval(5, 3)


def test_hungarian_matching_with_a_gate() -> None:
    det = np.array([[0.0, 0.0], [0.6, 0.0], [5.0, 5.0]])
    truth = np.array([[0.35, 0.0], [-0.2, 0.0]])
    di, ti = match_detections(det, truth, gate=0.5)
    # one-to-one, minimum total distance: det0-truth1 (0.2) + det1-truth0 (0.25); det2 is too far
    assert sorted(zip(di.tolist(), ti.tolist(), strict=True)) == [(0, 1), (1, 0)]
    di, ti = match_detections(det, truth, gate=0.22)
    assert list(zip(di.tolist(), ti.tolist(), strict=True)) == [(0, 1)]
    assert match_detections(np.zeros((0, 2)), truth, gate=0.5)[0].size == 0
    with pytest.raises(ValueError, match="detections"):
        match_detections(np.zeros((2, 3)), truth, gate=0.5)
    with pytest.raises(ValueError, match="gate"):
        match_detections(det, truth, gate=-1.0)


def test_matching_takes_the_most_pairs_before_the_least_distance() -> None:
    # det0 is closest to truth0, but only det0 can reach truth1: two pairs beat one shorter pair
    det = np.array([[0.0, 0.0], [0.45, 0.0]])
    truth = np.array([[0.05, 0.0], [-0.4, 0.0]])
    di, ti = match_detections(det, truth, gate=0.5)
    assert sorted(zip(di.tolist(), ti.tolist(), strict=True)) == [(0, 1), (1, 0)]


def test_calibrate_frames_rejects_gates_of_unknown_detectors() -> None:
    frames = list(Scenario.from_name("default", n_frames=2))
    models = load_scenario_config("default").detector_models
    with pytest.raises(ValueError, match="laser-leg"):
        calibrate_frames(frames, models, gates={"laser-leg": 0.3})


def test_mahalanobis_gate_follows_the_line_of_sight() -> None:
    truth = np.array([[5.0, 0.0]])
    # 3 m along the ray is 1.76 sd (sigma_range 1.7); 3 m across is 3 sd (sigma_lateral 1.0)
    along = match_detections([[8.0, 0.0]], truth, gate=2.5, metric="mahalanobis", model=CAMERA)
    across = match_detections([[5.0, 3.0]], truth, gate=2.5, metric="mahalanobis", model=CAMERA)
    assert along[0].size == 1 and across[0].size == 0


def test_counts_on_a_hand_made_sequence() -> None:
    truth = [np.array([[2.0, 0.0], [4.0, 1.0]]), np.array([[2.1, 0.0], [-1.0, 0.0]]), np.zeros((0, 2))]
    dets = [
        np.array([[2.05, 0.0], [6.0, -2.0]]),  # 1 TP, 1 FP; person at (4, 1) missed
        np.array([[2.1, 0.1]]),  # 1 TP; the person behind the laser (x < 0) is outside its FOV
        np.array([[3.0, 3.0]]),  # 1 FP
    ]
    res = calibrate_detector(dets, truth, model=LASER)
    assert res.counts == CalibrationCounts(
        n_frames=3, n_detections=4, n_true_positives=2, n_people=3, n_detected_people=2
    )
    assert res.ppv == pytest.approx(0.5) and res.fnr == pytest.approx(1 / 3)
    assert res.metric == "euclidean" and res.gate == 0.5
    assert res.ppv_interval[0] < 0.5 < res.ppv_interval[1]
    assert res.to_model(LASER).ppv == pytest.approx(0.5)
    # a region restricts both counts: a 2 m deep grid keeps the people at x = 2.0/2.1 and the TPs only
    small = GridSpec(nx=10, ny=10, resolution=0.25, x0=0.0, y0=-1.25)
    res = calibrate_detector(dets, truth, model=LASER, region=small)
    assert (res.counts.n_detections, res.counts.n_true_positives, res.counts.n_people) == (2, 2, 2)
    with pytest.raises(ValueError, match="same length"):
        calibrate_detector(dets[:2], truth, model=LASER)
    with pytest.raises(ValueError, match="frame 1"):
        calibrate_detector([dets[0], np.zeros((1, 3))], truth[:2], model=LASER)


@pytest.fixture(scope="module")
def long_run():
    """3000 frames of the default scenario without occlusion or cropping: the configured rates apply."""
    base = load_scenario_config("default")
    dets = tuple(dataclasses.replace(d, occlusion=False, crop_to_grid=False) for d in base.detectors)
    cfg = dataclasses.replace(base, n_frames=3000, seed=11, detectors=dets)
    sc = Scenario(cfg)
    return cfg, list(sc)


def test_calibration_recovers_the_configured_rates(long_run) -> None:
    cfg, frames = long_run
    spec = cfg.grid
    measured = calibrate_frames(frames, cfg.detector_models, region=spec)
    labels = oracle_calibration(frames, region=spec)
    for det in cfg.detectors:
        m = measured[det.name]
        n_people = labels[det.name].counts.n_people  # people in view inside the grid, summed over frames
        # expected: TP = (1 - miss) N, FP = clutter_rate * frames (clutter lies inside the grid)
        tp = (1 - det.miss_rate) * n_people
        fp = det.clutter_rate * len(frames)
        ppv_expected = tp / (tp + fp)
        sd_ppv = math.sqrt(ppv_expected * (1 - ppv_expected) / m.counts.n_detections)
        sd_fnr = math.sqrt(det.miss_rate * (1 - det.miss_rate) / m.counts.n_people)
        if det.name.startswith("laser"):
            # lasers: 35 mm noise, 0.5 m gate; 4 binomial sd plus 0.01 for clutter matched to a missed person
            assert m.ppv == pytest.approx(ppv_expected, abs=4 * sd_ppv + 0.01), det.name
            assert m.fnr == pytest.approx(det.miss_rate, abs=4 * sd_fnr + 0.01), det.name
        else:
            # camera: 1.0/1.7 m noise moves detections across the grid border and a 3-sd gate covers several
            # m^2, so matching is biased (PPV up, FNR down); stated tolerance 0.05, and the labels agree with
            # the configured rates within 4 sd + 0.03 (truth near the border detected outside the grid)
            assert m.ppv == pytest.approx(ppv_expected, abs=4 * sd_ppv + 0.05)
            assert m.fnr == pytest.approx(det.miss_rate, abs=4 * sd_fnr + 0.05)
            assert labels[det.name].fnr == pytest.approx(det.miss_rate, abs=4 * sd_fnr + 0.03)
        assert m.counts.n_people > 1000


def test_occlusion_adds_to_the_measured_fnr() -> None:
    base = load_scenario_config("corridor")
    laser = dataclasses.replace(base.detectors[0], clutter_rate=0.0, miss_rate=0.2)
    cfg = dataclasses.replace(base, n_frames=1500, seed=3, detectors=(laser,))
    frames = list(Scenario(cfg))
    res = calibrate_frames(frames, cfg.detector_models, region=cfg.grid)["laser_legs"]
    inside = [cfg.grid.contains(f.people[:, 0], f.people[:, 1]) for f in frames]
    n_view = sum(
        int(np.isin(f.person_ids[k], f.outputs[0].in_view_ids).sum()) for f, k in zip(frames, inside, strict=True)
    )
    n_occ = sum(
        int(np.isin(f.person_ids[k], f.outputs[0].occluded_ids).sum()) for f, k in zip(frames, inside, strict=True)
    )
    occ = n_occ / n_view
    assert occ > 0.03  # occlusion happens in the corridor
    expected = occ + (1 - occ) * 0.2  # occluded people are always missed, the others with the miss rate
    assert res.fnr == pytest.approx(expected, abs=4 * math.sqrt(0.2 * 0.8 / n_view) + 0.01)
    assert res.ppv == pytest.approx(1.0)


def test_calibrate_command_on_a_scenario_and_on_files(tmp_path, capsys) -> None:
    out = tmp_path / "cal.json"
    assert eval_main(["calibrate", "--scenario", "default", "--frames", "80", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "laser_legs" in text and "camera_hog" in text and out.is_file()
    (tmp_path / "truth.csv").write_text("frame,person_id,x_m,y_m\n0,1,2.0,0.0\n0,2,4.0,1.0\n2,1,2.1,0.0\n")
    (tmp_path / "det.csv").write_text("frame,x_m,y_m\n0,2.05,0.0\n0,6.0,-2.0\n2,2.1,0.1\n")
    args = ["calibrate", "--truth", str(tmp_path / "truth.csv"), "--detections", str(tmp_path / "det.csv")]
    assert eval_main(args) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if ln.strip().startswith("laser_legs"))
    assert "2/3" in line and "1/3" in line  # TP/detections and missed/people
    assert (
        eval_main(["calibrate", "--truth", str(tmp_path / "nope.csv"), "--detections", str(tmp_path / "det.csv")]) == 2
    )
