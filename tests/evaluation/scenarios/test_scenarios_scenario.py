"""Scenario objects: reproducibility, truth grid, built-in scenarios, TOML config, filter compatibility."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from evaluation.cli import main as eval_main
from evaluation.scenarios import (
    Scenario,
    ScenarioConfig,
    WalkerConfig,
    builtin_scenarios,
    load_scenario_config,
    occupancy_grid,
    track_speeds,
)
from evaluation.scenarios.walkers import synthetic_tracks
from gridbridge.grid import GridSpec


def _assert_frames_equal(a, b) -> None:
    assert a.index == b.index and a.stamp == b.stamp
    assert (a.v, a.omega, a.v_odom, a.omega_odom) == (b.v, b.omega, b.v_odom, b.omega_odom)
    np.testing.assert_array_equal(a.robot_pose, b.robot_pose)
    np.testing.assert_array_equal(a.person_ids, b.person_ids)
    np.testing.assert_array_equal(a.people, b.people)
    np.testing.assert_array_equal(a.truth_grid, b.truth_grid)
    for oa, ob in zip(a.outputs, b.outputs, strict=True):
        np.testing.assert_array_equal(oa.positions, ob.positions)
        np.testing.assert_array_equal(oa.source, ob.source)


def test_same_seed_same_frames_and_random_access() -> None:
    cfg = load_scenario_config("corridor", n_frames=60, seed=5)
    first = list(Scenario(cfg))
    again = Scenario(cfg)
    for a, b in zip(first, again, strict=True):
        _assert_frames_equal(a, b)
    _assert_frames_equal(first[37], again.frame(37))  # lazily, in any order
    other = list(Scenario(dataclasses.replace(cfg, seed=6)))
    assert any(not np.array_equal(a.robot_pose, b.robot_pose) for a, b in zip(first, other, strict=True))
    assert len(first) == 60 and first[-1].stamp == pytest.approx(5.9)
    with pytest.raises(IndexError, match="60"):
        again.frame(60)


def test_truth_cells_hand_made_case() -> None:
    spec = GridSpec(nx=4, ny=4, resolution=1.0, x0=0.0, y0=-2.0)  # x in [0, 4], y in [-2, 2]

    def cells(p: list[float], radius: float = 0.25) -> set[tuple[int, int]]:
        return {(int(i), int(j)) for i, j in zip(*np.nonzero(occupancy_grid(spec, [p], radius=radius)), strict=True)}

    assert cells([1.5, 0.0]) == {(1, 1), (1, 2)}  # on the line between two cells
    assert cells([2.9, -1.5]) == {(2, 0), (3, 0)}  # 0.1 m from the next cell
    assert cells([0.9, -1.1]) == {(0, 0), (1, 0), (0, 1), (1, 1)}  # 0.14 m from a corner
    assert cells([0.8, -1.2]) == {(0, 0), (1, 0), (0, 1)}  # 0.28 m from the corner: diagonal cell not hit
    assert cells([0.5, -1.5]) == {(0, 0)}
    assert cells([1.5, 0.0], radius=0.0) == {(1, 2)}  # half-open cells as GridSpec.flat_index
    assert cells([-0.2, -1.5]) == {(0, 0)}  # a person just outside still overlaps the border cell
    assert cells([5.0, 0.0]) == set()
    assert not occupancy_grid(spec, np.zeros((0, 2))).any()


def test_frames_have_the_documented_content() -> None:
    sc = Scenario.from_name("default", n_frames=40)
    spec = sc.spec
    for fr in sc:
        assert fr.people.shape == (fr.person_ids.size, 2)
        assert fr.truth_grid.shape == spec.shape and fr.truth_grid.dtype == bool
        np.testing.assert_array_equal(fr.truth_grid, occupancy_grid(spec, fr.people, radius=0.25))
        assert len(fr.detections) == 3
        for out, det in zip(fr.outputs, fr.detections, strict=True):
            assert det.ndim == 2 and det.shape[1] == 2 and out.source.shape == (det.shape[0],)
            assert np.all(spec.contains(det[:, 0], det[:, 1]))  # crop_to_grid
            # true positives lie near their person (laser 35 mm noise: 0.25 m is > 7 sd)
            for pos, src in zip(det, out.source, strict=True):
                if src >= 0 and out.name.startswith("laser"):
                    assert np.hypot(*(fr.people[fr.person_ids == src][0] - pos)) < 0.25
        assert fr.odometry(noisy=False).v == fr.v


def test_scenario_feeds_the_grid_filter() -> None:
    """After 15 frames of the default scenario the paper's filter believes in most of its people: the cells of 3 of
    the 5 people in the grid are above 0.5, while the other cells average under 0.1 (hand-checked: 0.96, 0.89,
    0.78, 0.01, 0.02 and 0.05)."""
    gridbridge = pytest.importorskip("gridbridge")
    sc = Scenario.from_name("default", n_frames=15)
    flt = gridbridge.GridFilter(sc.spec, detectors=sc.config.detector_models)
    for fr in sc:
        step = flt.step(fr.detections, fr.odometry(), sc.dt)
    assert step.posterior.shape == sc.spec.shape
    assert np.all((step.posterior >= 0) & (step.posterior <= 1))
    inside = sc.spec.contains(fr.people[:, 0], fr.people[:, 1])
    cells = sc.spec.flat_index(fr.people[inside, 0], fr.people[inside, 1])
    post = step.posterior.ravel()
    others = np.ones(post.size, dtype=bool)
    others[cells] = False
    assert len(cells) == 5 and np.count_nonzero(post[cells] > 0.5) >= 3
    assert post[others].mean() < 0.1


def test_builtin_scenarios_load() -> None:
    names = builtin_scenarios()
    assert {"default", "corridor", "complementary", "eth"} <= set(names)
    for name in names:
        cfg = load_scenario_config(name)
        assert cfg.name == name and cfg.dt == pytest.approx(0.1)
        assert [d.name for d in cfg.detectors] == ["laser_legs", "laser_boosted", "camera_hog"]
    assert load_scenario_config("corridor").n_frames == 300
    assert load_scenario_config("eth").people == "eth_ucy"
    with pytest.raises(ValueError, match="built-in"):
        load_scenario_config("no-such-scenario")


def test_corridor_has_every_behaviour_turns_and_occlusion() -> None:
    sc = Scenario.from_name("corridor")
    assert set(sc.behaviours) == {"stand", "walk", "cross", "stop_and_go", "pair"}
    assert sc.v.max() <= 0.6 and np.abs(sc.omega).max() > 0.2
    occluded = sum(fr.outputs[0].occluded_ids.size for fr in sc)
    in_grid = sum(int(sc.spec.contains(fr.people[:, 0], fr.people[:, 1]).sum()) for fr in sc)
    assert occluded > 0 and in_grid / len(sc) > 1.5


def test_complementary_scenario_has_occlusions_the_camera_does_not_suffer() -> None:
    sc = Scenario.from_name("complementary", n_frames=150)
    laser_occ = sum(fr.outputs[0].occluded_ids.size for fr in sc)
    camera_occ = sum(fr.outputs[2].occluded_ids.size for fr in sc)
    assert laser_occ > 0 and camera_occ == 0


def test_walker_speeds_follow_the_truncated_normal() -> None:
    cfg = WalkerConfig(initial_people=0, spawn_rate=2.0, p_stand=0.0, p_stop_and_go=0.0, p_pair=0.0)
    poses = np.zeros((10000, 3))
    tracks, _ = synthetic_tracks(poses, 0.1, spec=GridSpec(), config=cfg, rng=np.random.default_rng(4))
    speeds = track_speeds(tracks)
    # N(1.46, 0.63) truncated to [0.3, 2.5]: mean 1.4402, sd 0.5151 (scipy.stats.truncnorm); 4 sd of the mean
    assert speeds.size > 1500
    assert speeds.mean() == pytest.approx(1.4402, abs=4 * 0.5151 / math.sqrt(speeds.size))
    assert speeds.std() == pytest.approx(0.5151, rel=0.1)
    assert speeds.min() >= 0.3 and speeds.max() <= 2.5


def test_pairs_walk_side_by_side() -> None:
    cfg = WalkerConfig(initial_people=0, spawn_rate=0.5, p_stand=0, p_walk=0, p_cross=0, p_stop_and_go=0, p_pair=1)
    tracks, kinds = synthetic_tracks(np.zeros((300, 3)), 0.1, spec=GridSpec(), config=cfg, rng=np.random.default_rng(1))
    assert len(tracks) % 2 == 0 and set(kinds) == {"pair"}
    for a, b in zip(tracks[::2], tracks[1::2], strict=True):
        np.testing.assert_allclose(a.t, b.t)
        np.testing.assert_allclose(np.hypot(*(a.xy - b.xy).T), cfg.pair_spacing)


def test_toml_round_trip(tmp_path) -> None:
    text = """
name = "mine"
n_frames = 25
seed = 3
odometry_noise = false
[grid]
nx = 20
ny = 20
resolution = 0.3
x0 = 0.0
y0 = -3.0
[walkers]
initial_people = 2
[[detectors]]
base = "laser_legs"
miss_rate = 0.1
"""
    path = tmp_path / "mine.toml"
    path.write_text(text)
    cfg = ScenarioConfig.from_toml(path)
    assert cfg.name == "mine" and cfg.grid.nx == 20 and cfg.odometry_noise is None
    assert len(cfg.detectors) == 1 and cfg.detectors[0].miss_rate == 0.1
    sc = Scenario(load_scenario_config(path))
    frames = list(sc)
    assert len(frames) == 25 and all(f.v == f.v_odom for f in frames)
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\nnframes = 3\n')
    with pytest.raises(ValueError, match="nframes"):
        ScenarioConfig.from_toml(bad)
    # by path (as the commands load them), errors name the file too, also for an override or bad TOML
    with pytest.raises(ValueError, match=r"bad\.toml: .*nframes"):
        load_scenario_config(bad)
    with pytest.raises(ValueError, match=r"mine\.toml: .*n_frames"):
        load_scenario_config(path, n_frames=0)
    broken = tmp_path / "broken.toml"
    broken.write_text("name = \n")
    with pytest.raises(ValueError, match=r"broken\.toml: invalid TOML"):
        load_scenario_config(broken)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"n_frames": 0}, "n_frames"),
        ({"dt": -0.1}, "dt"),
        ({"seed": -1}, "seed"),
        ({"people": "robots"}, "people"),
        ({"person_radius": float("inf")}, "person_radius"),
        ({"detectors": ()}, "detectors"),
    ],
)
def test_bad_scenario_config_names_the_field(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        ScenarioConfig(**kwargs)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"spawn_rate": -1.0}, "spawn_rate"),
        ({"initial_people": -2}, "initial_people"),
        ({"speed_min": 3.0}, "speed_min"),
        ({"p_pair": -0.5}, "p_pair"),
        ({"stand_min": 50.0}, "stand_min"),
    ],
)
def test_bad_walker_config_names_the_field(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        WalkerConfig(**kwargs)


def test_simulate_command(tmp_path, capsys) -> None:
    out = tmp_path / "run.npz"
    assert eval_main(["simulate", "default", "--frames", "30", "--out", str(out), "--csv-dir", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    assert "30 frames" in text and "laser_legs" in text
    data = np.load(out)
    assert data["truth_grid"].shape == (30, 30, 30)
    assert data["v"].shape == (30,) and data["people"].shape[1] == 4
    assert (tmp_path / "truth.csv").is_file() and (tmp_path / "detections_camera_hog.csv").is_file()
    assert eval_main(["simulate", "nowhere"]) == 2
