"""Replay of the real ETH/UCY trajectories (../shared/data/eth_ucy; skipped when absent)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from evaluation.scenarios import DataNotFoundError, EthReplay, Scenario, load_scenario_config, load_tracks, track_speeds
from evaluation.scenarios.eth_ucy import load_obsmat


@pytest.fixture(scope="module")
def eth_root(shared_data: Path) -> Path:
    if not (shared_data / "eth_ucy" / "seq_eth" / "obsmat.txt").is_file():
        pytest.skip(f"{shared_data}/eth_ucy/seq_eth/obsmat.txt is absent")
    return shared_data


@pytest.mark.realdata
def test_seq_eth_loads_with_plausible_speeds(eth_root: Path) -> None:
    tracks = load_tracks("seq_eth", data_root=eth_root)
    table = load_obsmat(eth_root / "eth_ucy" / "seq_eth" / "obsmat.txt")
    assert len(tracks) == 360 == np.unique(table[:, 1]).size  # MANIFEST: 360 people, 8908 rows
    assert sum(t.t.size for t in tracks) == 8908
    # annotations every 0.4 s (ETH: every 6 video frames)
    steps = np.concatenate([np.diff(t.t) for t in tracks])
    assert np.median(steps) == pytest.approx(0.4)
    speeds = track_speeds(tracks)
    mean = float(speeds.mean())
    print(f"seq_eth: {speeds.size} segments, mean speed {mean:.3f} m/s (paper's model: N(1.46, 0.63))")
    # measured 1.384 m/s; the paper's mu is 1.46 m/s (Daamen & Hoogendoorn 2007)
    assert 1.2 < mean < 1.6
    # the dataset's own velocity columns agree with the finite differences (same 0.4 s clock)
    vel = np.hypot(table[:, 5], table[:, 7])
    assert float(vel.mean()) == pytest.approx(mean, rel=0.05)


@pytest.mark.realdata
def test_interpolation_hits_the_annotations(eth_root: Path) -> None:
    track = load_tracks("seq_eth", data_root=eth_root)[0]
    np.testing.assert_allclose(track.sample(track.t), track.xy)
    mid = 0.5 * (track.t[:-1] + track.t[1:])
    np.testing.assert_allclose(track.sample(mid), 0.5 * (track.xy[:-1] + track.xy[1:]))
    outside = track.sample([track.t_start - 0.1, track.t_end + 0.1])
    assert np.all(np.isnan(outside))  # a person exists between first and last observation only


@pytest.mark.realdata
def test_eth_scenario_puts_the_robot_into_the_crowd(eth_root: Path) -> None:
    cfg = load_scenario_config("eth", n_frames=150)
    cfg = dataclasses.replace(cfg, eth=EthReplay(sequence="seq_eth", start_s=600.0, data_root=str(eth_root)))
    sc = Scenario(cfg)
    in_grid = [int(sc.spec.contains(f.people[:, 0], f.people[:, 1]).sum()) for f in sc.frames()]
    assert max(in_grid) >= 2 and np.mean(in_grid) > 0.5
    # real people in the sensor frame move at walking speed (robot motion removed through the world frame)
    world = sc.world_people
    v = np.hypot(*np.diff(world, axis=0).transpose(2, 0, 1)) / sc.dt
    assert 0.8 < float(np.nanmean(v[v > 0.2])) < 2.0
    assert np.linalg.norm(sc.robot_poses[-1, :2] - sc.robot_poses[0, :2]) > 1.0


def test_missing_data_gives_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(DataNotFoundError, match="seq_eth"):
        load_tracks("seq_eth", data_root=tmp_path)
    cfg = load_scenario_config("eth")
    cfg = dataclasses.replace(cfg, eth=EthReplay(data_root=str(tmp_path)))
    with pytest.raises(FileNotFoundError, match="eth_ucy"):
        Scenario(cfg)


def test_bad_obsmat_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "obsmat.txt"
    path.write_text("1 2 3\n")
    with pytest.raises(ValueError, match=r"obsmat\.txt"):
        load_obsmat(path)
