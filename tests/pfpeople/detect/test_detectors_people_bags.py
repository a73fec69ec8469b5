"""Training the boosted classifier on bags annotated with people's centres (pfpeople.detect.people_bags)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from evaluation.scenarios.scan.bagfile import write_scene_bag
from evaluation.scenarios.scan.training_scenes import TRAINING_SEED
from pfpeople.cli import main as pfpeople_main
from pfpeople.detect.people_bags import (
    find_people_bags,
    label_people_segments,
    load_people_scans,
    people_training_set,
)


@pytest.fixture(scope="module")
def sim_bags(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two short simulated scenes, written as ``pfpeople-eval simulate-bag`` writes them."""
    root = tmp_path_factory.mktemp("people_bags")
    for scene in ("corridor", "lobby"):
        write_scene_bag(scene, root / scene, seed=3, frames=12)
    return root


def test_labels_by_distance_to_the_people() -> None:
    centroids = np.array([[0.2, 0.0], [1.5, 0.0], [0.7, 0.0], [5.1, 0.0], [3.0, 3.0]])
    people = np.array([[0.0, 0.0], [5.0, 0.0]])
    # 0.2 m from a seen person: leg; 1.5 m from everyone: not a leg; 0.7 m: skipped; 0.1 m from a hidden one: skipped
    lab = label_people_segments(centroids, people, np.array([True, False]))
    assert lab.tolist() == [1, 0, -1, -1, 0]
    # nobody annotated in the scan: every segment is a negative
    assert label_people_segments(centroids, np.zeros((0, 2)), np.zeros(0, dtype=bool)).tolist() == [0] * 5
    with pytest.raises(ValueError, match="person_radius"):
        label_people_segments(centroids, people, np.ones(2, dtype=bool), person_radius=1.0, clear_radius=0.5)


def test_scans_carry_their_own_rows_of_the_ground_truth(sim_bags: Path) -> None:
    bag, gt = sim_bags / "lobby" / "lobby.bag", sim_bags / "lobby" / "lobby_gt.csv"
    rows = np.genfromtxt(gt, delimiter=",", names=True)
    scans = load_people_scans(bag, gt, scan_step=5)
    assert len(scans) == 3  # scans 0, 5, 10 of 12
    for k, item in zip((0, 5, 10), scans, strict=True):
        mine = rows[rows["scan_index"] == k]
        assert item.people.shape == (mine.size, 2)
        mine = mine[np.argsort(mine["x_laser_m"])]
        order = np.argsort(item.people[:, 0])
        np.testing.assert_allclose(item.people[order, 0], mine["x_laser_m"], atol=1e-9)
        np.testing.assert_allclose(item.people[order, 1], mine["y_laser_m"], atol=1e-9)
        np.testing.assert_array_equal(item.seen[order], mine["hit_beams"] > 0)  # each person's own flag
    X, y, counts = people_training_set(scans)
    assert X.shape == (y.size, X.shape[1]) and counts["positives"] == int(y.sum()) > 0
    assert counts["negatives"] == int(np.count_nonzero(y == 0)) > 0


def test_people_bag_errors_name_what_is_wrong(sim_bags: Path, tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"no <name>\.bag"):
        find_people_bags(tmp_path)
    (tmp_path / "x.bag").write_bytes(b"")
    with pytest.raises(FileNotFoundError, match=r"x_gt\.csv"):
        find_people_bags(tmp_path)
    gt = tmp_path / "other_frame_gt.csv"
    gt.write_text("scan_index,person_id,x_base_m,y_base_m\n0,1,1.0,0.0\n", encoding="utf-8")
    with pytest.raises(ValueError, match="frame 'base'"):
        load_people_scans(sim_bags / "corridor" / "corridor.bag", gt)
    stamped = tmp_path / "stamped_gt.csv"
    stamped.write_text("stamp_ns,person_id,x_laser_m,y_laser_m\n5,1,1.0,0.0\n", encoding="utf-8")
    with pytest.raises(ValueError, match="keyed by scan_index"):
        load_people_scans(sim_bags / "corridor" / "corridor.bag", stamped)


@pytest.mark.realdata
def test_train_detector_with_people_bags(shared_data: Path, sim_bags: Path, tmp_path: Path) -> None:
    args = ["train-detector", "--data-dir", str(shared_data / "leg_tracker"), "--out", str(tmp_path)]
    args += ["--name", "small", "--weak-count", "20", "--scan-step", "10", "--people-bags", str(sim_bags)]
    args += ["--train-positive", "positive_2_extracted.bag", "positive_6_extracted.bag"]
    assert pfpeople_main(args) == 0
    side = json.loads((tmp_path / "small.json").read_text())
    # the bags are recorded by their place in the folder, with their hashes
    names = [d["file"] for d in side["people_data"]]
    assert names == ["corridor/corridor.bag", "corridor/corridor_gt.csv", "lobby/lobby.bag", "lobby/lobby_gt.csv"]
    assert all(len(d["sha256"]) == 64 for d in side["people_data"])
    assert side["split"]["people_scans"] == 2 * 2  # scans 0 and 10 of each 12-scan bag
    assert side["counts"]["people_bags"]["positives"] > 0
    assert "annotated with people" in side["leave_one_bag_out"]["scheme"]


def test_the_makefile_trains_on_the_training_scenes() -> None:
    """``make model`` simulates the scenes and seed that the benchmark's held-out boosted models are trained on."""
    from evaluation.scenarios.scan.training_scenes import BOOSTED_TRAINING_SCENES

    text = (Path(__file__).resolve().parents[3] / "Makefile").read_text(encoding="utf-8")
    recipe = text[text.index("\nmodel-boosted:") : text.index("\nmodel-learned:")]
    assert f"for s in {' '.join(BOOSTED_TRAINING_SCENES)};" in recipe
    assert f"--seed {TRAINING_SEED} " in recipe and "--people-bags build/sim-train" in recipe
