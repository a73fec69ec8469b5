"""The tracking harness (evaluation.harness.mot_eval): stand-in classifier, merged detections, a run directory with
GT."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from evaluation.harness.mot_eval import (
    FUSED_SOURCES,
    evaluate_log,
    evaluate_run,
    evaluate_scenario,
    format_rows,
    merge_detections,
    peak_classifier,
)
from evaluation.harness.replay import log_from_scenario
from evaluation.scenarios.scenario import Scenario
from gridbridge.grid import GridSpec
from pfpeople.io.ground_truth import read_gt_csv
from pfpeople.io.run_dir import RunWriter, load_run

SPEC = GridSpec()  # 30 x 30 cells of 0.3 m, x in [0, 9], y in [-4.5, 4.5]


def test_peak_classifier_two_blobs_and_nms() -> None:
    b = np.full(SPEC.shape, 0.05)
    b[10, 15] = 0.9  # cell centre (3.15, 0.15)
    b[11, 15] = 0.9 * 0.6  # a weaker neighbour: pulls the centroid along +x
    b[20, 5] = 0.7  # (6.15, -2.85)
    b[20, 6] = 0.69  # not a peak (its neighbour is higher)
    b[21, 8] = 0.65  # 0.67 m from the 0.69 cell, 0.95 m from the 0.7 peak: a peak of its own at min_separation 0.6
    pos, sc = peak_classifier(b, SPEC)
    assert sc.tolist() == pytest.approx([0.9, 0.7, 0.65])
    w = np.array([0.9, 0.54])
    assert pos[0] == pytest.approx([(3.15 * w[0] + 3.45 * w[1]) / w.sum(), 0.15])
    assert pos[1, 0] == pytest.approx(6.15) and pos[1, 1] == pytest.approx((-2.85 * 0.7 - 2.55 * 0.69) / 1.39)
    _, sc2 = peak_classifier(b, SPEC, nms_radius=1.0)
    assert sc2.tolist() == pytest.approx([0.9, 0.7])
    empty, esc = peak_classifier(np.full(SPEC.shape, 0.5), SPEC)
    assert empty.shape == (0, 2) and esc.shape == (0,)


def test_peak_classifier_border_cell() -> None:
    b = np.zeros(SPEC.shape)
    b[0, 0] = 0.8
    pos, _ = peak_classifier(b, SPEC)
    assert pos.tolist() == [pytest.approx([0.15, -4.35])]


def test_merge_detections() -> None:
    merged = merge_detections([np.array([[1.0, 0.0], [3.0, 0.0]]), np.array([[1.2, 0.0]]), np.zeros((0, 2))])
    assert merged.tolist() == [pytest.approx([1.1, 0.0]), pytest.approx([3.0, 0.0])]
    assert merge_detections([]).shape == (0, 2)


def test_evaluate_scenario_detectors_only() -> None:
    sc = Scenario.from_name("default", n_frames=40)
    rows = evaluate_scenario(sc, n_frames=40)
    names = [r.source for r in rows]
    assert names[-1] == "all detectors merged (raw)" and len(rows) == len(sc.config.detector_models) + 1
    for r in rows:
        s = r.scores
        assert s.num_frames == 40 and s.num_gt > 0
        assert s.num_gt == s.num_matches + s.num_misses
        assert s.mota <= 1.0 and 0.0 <= s.recall <= 1.0
    assert "MOTA" in format_rows(rows)


def test_evaluate_log_tracks_both_recommended_filters() -> None:
    """The replay table has a row per recommended filter (grid, particles) before the detectors' rows; each is
    scored on the same truth; a wrong fused source is named."""
    log = log_from_scenario(Scenario.from_name("default", n_frames=40))
    rows = evaluate_log(log)
    names = [r.source for r in rows]
    assert names[:2] == ["recommended (tracker)", "recommended particles (tracker)"] == list(FUSED_SOURCES)
    assert names[2:] == [f"{m.name} (raw)" for m in log.models] + ["all detectors merged (raw)"]
    num_gt = {r.scores.num_gt for r in rows}
    assert len(num_gt) == 1 and num_gt.pop() > 0
    for r in rows[:2]:
        assert r.scores.num_gt == r.scores.num_matches + r.scores.num_misses and 0.0 <= r.scores.recall <= 1.0
    only = evaluate_log(log, fused=["recommended particles (tracker)"])
    assert [r.source for r in only] == ["recommended particles (tracker)", *names[2:]]
    assert only[0].scores == rows[1].scores  # seeded: the same particles, the same tracks
    with pytest.raises(ValueError, match=r"fused sources \['particles'\] are none of"):
        evaluate_log(log, fused=["particles"])


def _write_run(path: Path, people: list[np.ndarray], dets: list[np.ndarray], dt: float = 0.1) -> None:
    with RunWriter(path, spec=SPEC, detector_names=["legs"], metadata={"provenance": {"bag": ["/x/synth.bag"]}}) as w:
        for k, (p, d) in enumerate(zip(people, dets, strict=True)):
            w.write_frame(
                frame=k,
                driver_index=k,
                stamp_ns=int(k * dt * 1e9),
                bag_time_ns=int(k * dt * 1e9),
                dt_s=dt,
                odometry=None,
                forced=False,
                belief=np.zeros(SPEC.shape),
                people=p,
                people_probability=[0.9] * len(p),
                detections=[d],
            )


def test_evaluate_run_followed_person(tmp_path: Path) -> None:
    """Person 7 walks away from the sensor; the filter sees it in every frame but 20-24 (coasting bridges the
    gap), the detector only in even frames plus a static clutter point. GT annotates person 7 only."""
    n = 60
    truth = [np.array([1.0 + 0.05 * k, 0.5]) for k in range(n)]
    people = [np.zeros((0, 2)) if 20 <= k < 25 else truth[k][None, :] for k in range(n)]
    dets = [np.vstack([truth[k][None, :], [[5.0, -3.0]]]) if k % 2 == 0 else np.array([[5.0, -3.0]]) for k in range(n)]
    _write_run(tmp_path / "run", people, dets)
    gt_path = tmp_path / "gt.csv"
    gt_path.write_text(
        "scan_index,person_id,x_laser_m,y_laser_m\n" + "".join(f"{k},7,{p[0]},{p[1]}\n" for k, p in enumerate(truth))
    )
    rows = evaluate_run(load_run(tmp_path / "run"), read_gt_csv(gt_path))
    by = {r.source: r for r in rows}
    assert set(by) == {"filter (people.csv)", "grid + peaks", "legs (raw)"}
    assert by["grid + peaks"].scores.num_misses == n  # the stored belief grids are empty
    f = by["filter (people.csv)"]
    # confirmed from frame 2 (3 of 5): matched 58 of 60 frames, one id, no false positives
    assert f.scores.num_gt == n and f.scores.num_misses == 2 and f.scores.id_switches == 0
    assert f.scores.num_false_positives == 0 and f.scores.mota == pytest.approx(1 - 2 / 60)
    assert f.extra["followed"] == {"id": 7, "annotated_frames": 60, "matched_fraction": 58 / 60, "id_switches": 0}
    d = by["legs (raw)"]
    # the static clutter point is confirmed (seen every frame): false positives in the GT's view
    assert d.scores.num_false_positives > 40 and d.scores.id_switches == 0
    assert d.extra["followed"]["matched_fraction"] > 0.9
    assert "followed person 7" in format_rows(rows) and rows[0].sequence == "synth"
    assert math.isfinite(d.scores.motp)


@pytest.mark.parametrize(
    ("kind", "label"), [("grid", "tracks.csv (pipeline)"), ("particle", "tracks.csv (particle pipeline)")]
)
def test_evaluate_run_labels_the_tracks_by_the_runs_filter(tmp_path: Path, kind: str, label: str) -> None:
    n = 10
    truth = [np.array([1.0 + 0.05 * k, 0.5]) for k in range(n)]
    meta = {"provenance": {"bag": ["/x/synth.bag"]}, "config": {"filter": {"kind": kind}}}
    with RunWriter(tmp_path / "run", spec=SPEC, detector_names=["legs"], metadata=meta) as w:
        for k in range(n):
            x, y = truth[k]
            w.write_frame(
                frame=k,
                driver_index=k,
                stamp_ns=int(k * 1e8),
                bag_time_ns=int(k * 1e8),
                dt_s=0.1,
                odometry=None,
                forced=False,
                belief=np.zeros(SPEC.shape),
                people=truth[k][None, :],
                people_probability=[0.9],
                detections=[truth[k][None, :]],
                tracks=[(k, int(k * 1e8), 3, x, y, 0.5, 0.0, 0.01, 0.0, 0.01, 0.9)],
            )
    gt_path = tmp_path / "gt.csv"
    gt_path.write_text(
        "scan_index,person_id,x_laser_m,y_laser_m\n" + "".join(f"{k},7,{p[0]},{p[1]}\n" for k, p in enumerate(truth))
    )
    (row,) = evaluate_run(load_run(tmp_path / "run"), read_gt_csv(gt_path), sources=["tracks"], followed=False)
    assert row.source == label and row.scores.num_matches == n and row.scores.mota == 1.0


def test_track_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from evaluation.cli import main

    out_json = tmp_path / "rows.json"
    argv = ["track", "--scenario", "default", "--frames", "15", "--particles", "--no-grid", "--json", str(out_json)]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "MOTA" in text and "all detectors merged (raw)" in text
    assert '"mota"' in out_json.read_text()
    assert main(["track"]) == 2
    assert "give --scenario" in capsys.readouterr().err


def test_evaluate_log_particle_overrides_change_only_the_particle_row() -> None:
    """``particle={"seed": s}``: another Monte Carlo draw of the particle row (other tracks on this scene), the
    same grid row; the default seed's row again with ``seed=0``."""
    log = log_from_scenario(Scenario.from_name("complementary", n_frames=40))
    base = {r.source: r.scores for r in evaluate_log(log)}
    zero = {r.source: r.scores for r in evaluate_log(log, particle={"seed": 0})}
    other = {r.source: r.scores for r in evaluate_log(log, particle={"seed": 7})}
    key = "recommended particles (tracker)"
    assert zero == base
    assert other["recommended (tracker)"] == base["recommended (tracker)"]
    assert other[key] != base[key]
