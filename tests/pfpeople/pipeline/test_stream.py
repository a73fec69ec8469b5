"""The streaming API (pfpeople.pipeline.stream.PeopleStream), run_bag / Run, load_run's tracks, and the ego-motion
hook of the detector adapters (``uses_ego_motion``).

The synthetic scene of ``bag_fixtures.write_bag``: a robot driving an arc past two standing people, odometry at
50 Hz, a laser mounted on base_link by /tf_static; the grid frame is the laser's.
"""

from __future__ import annotations

import ast
from dataclasses import replace
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest
from bag_fixtures import config, laser_pose, write_bag

import pfpeople
from evaluation.scenarios.scan import SceneBag, write_scene_bag
from pfpeople.config import load_config
from pfpeople.detect.adapters import LegAdapter, SensorMotion
from pfpeople.io.bag.reader import BagSource
from pfpeople.io.run_dir import load_run
from pfpeople.perception.odometry import odometry_between
from pfpeople.pipeline.runner import Pipeline
from pfpeople.pipeline.stream import PeopleStream
from pfpeople.sensors import Pose2D

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def odom_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("stream") / "odom.bag"
    write_bag(path, n_scans=20)
    return path


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> SceneBag:
    """A ray-cast corridor with walls (scan matching works there), its odometry left out of the config."""
    return write_scene_bag("corridor", tmp_path_factory.mktemp("scene"), frames=30, seed=1)


def _same(a: Any, b: Any) -> None:
    """Two frame results alike bit for bit: stamp, detections, belief, people, tracks."""
    assert a.frame.stamp_ns == b.frame.stamp_ns and a.dt == b.dt and a.odometry == b.odometry
    assert np.array_equal(a.belief, b.belief) and np.array_equal(a.people, b.people)
    for x, y in zip(a.detections, b.detections, strict=True):
        assert (x is None and y is None) or np.array_equal(x, y)
    ta = [(t.id, t.x, t.y, t.vx, t.vy) for t in a.tracks or []]
    assert ta == [(t.id, t.x, t.y, t.vx, t.vy) for t in b.tracks or []]


def test_messages_pushed_one_by_one_give_the_bag_runs_frames(odom_bag: Path) -> None:
    cfg = config()
    with BagSource(odom_bag) as src:
        _, run = Pipeline(cfg, front_process=False).run(src, None, keep=True)
    with BagSource(odom_bag) as src:
        stream = PeopleStream.open(cfg, src)
        pushed = [r for m in src.messages(stream.topics(src)) for r in stream.push(m)]
    pushed += stream.finish()
    assert len(pushed) == len(run) == 20 and stream.summary.frames == 20
    for a, b in zip(run, pushed, strict=True):
        _same(a, b)
    assert any(len(r.people) for r in pushed)


def test_run_bag_returns_what_the_run_directory_holds(odom_bag: Path, tmp_path: Path) -> None:
    run = pfpeople.run_bag(odom_bag, config(), out_dir=tmp_path / "run", front_process=False)
    back = load_run(tmp_path / "run")
    assert run.summary.frames == back.n_frames == len(run.frames) == 20
    assert run.grids.shape == back.grids.shape and np.array_equal(run.grids, back.grids)
    assert np.array_equal(run.stamps_ns, back.frames["stamp_ns"])
    people = np.concatenate([f.people for f in run.frames])
    assert np.allclose(people, np.column_stack((back.people["x_m"], back.people["y_m"])))
    assert back.tracks is not None and back.tracks["id"].dtype == np.int64
    tracks = [(f.index, t.id, t.x, t.y) for f in run.frames for t in f.tracks]
    assert len(tracks) == len(back.tracks["id"]) > 0
    got = list(zip(back.tracks["frame"], back.tracks["id"], back.tracks["x"], back.tracks["y"], strict=True))
    assert [(a, b) for a, b, _x, _y in got] == [(a, b) for a, b, _x, _y in tracks]
    assert np.allclose([x for *_, x, _ in got], [x for *_, x, _ in tracks])


def test_a_run_without_tracking_has_no_tracks_and_a_path_runs(odom_bag: Path, tmp_path: Path) -> None:
    cfg = config()
    cfg = replace(cfg, tracking=replace(cfg.tracking, enabled=False))
    summary, _ = Pipeline(cfg, front_process=False).run(str(odom_bag), tmp_path / "run", max_frames=3)
    assert summary.frames == 3 and load_run(tmp_path / "run").tracks is None


class _EgoLegs(LegAdapter):
    """A leg adapter that asks for the frame's ego-motion and records it."""

    uses_ego_motion = True
    seen: ClassVar[list[SensorMotion]] = []

    def detect(self, msgs: Any, *, motion: SensorMotion | None = None) -> Any:
        assert motion is not None
        type(self).seen.append(motion)
        return super().detect(msgs)


def test_a_detector_that_uses_ego_motion_gets_the_odometry_motion_of_its_laser(odom_bag: Path) -> None:
    _EgoLegs.seen = []
    with BagSource(odom_bag) as src:
        _, run = Pipeline(config(), adapters={"leg": _EgoLegs}).run(src, None, keep=True)
    seen = _EgoLegs.seen
    assert len(seen) == 20 and seen[0].ego is None and seen[0].restarted and seen[0].dt == pytest.approx(0.1)
    for k in range(1, 20):
        m = seen[k]
        true = laser_pose((k - 1) * 0.1).inverse().compose(laser_pose(k * 0.1))  # the laser frame is the grid frame
        assert not m.restarted and m.stamp_ns == run[k].frame.stamp_ns and m.dt == pytest.approx(0.1)
        assert m.ego is not None
        assert (m.ego.x, m.ego.y, m.ego.yaw) == pytest.approx((true.x, true.y, true.yaw), abs=1e-9)


def test_a_detector_that_uses_ego_motion_gets_the_scan_matched_motion(scene: SceneBag) -> None:
    """Without odometry the motion is the driving laser's scan match, known before the detectors run: what the
    filter is given (frames.csv's controls) is the same motion."""
    _EgoLegs.seen = []
    cfg = replace(load_config(scene.run_toml), odometry="")
    with BagSource(scene.bag) as src:
        summary, run = Pipeline(cfg, adapters={"leg": _EgoLegs}).run(src, None, keep=True)
    assert summary.ego_motion["scan_matching"] > 20 and len(_EgoLegs.seen) == 30
    for m, r in zip(_EgoLegs.seen, run, strict=True):
        assert (m.ego is None) == (r.odometry is None)
        if m.ego is not None and r.odometry is not None:
            odo, _ = odometry_between(Pose2D(), m.ego, m.dt)
            assert (odo.v, odo.vy, odo.omega) == pytest.approx((r.odometry.v, r.odometry.vy, r.odometry.omega))


def _imports(path: Path) -> set[str]:
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


def _unit(module: str) -> str:
    """A module's folder (``pfpeople.io``) or top-level module (``pfpeople.config``)."""
    return ".".join(module.split(".")[:2])


def test_no_two_folders_of_pfpeople_import_each_other() -> None:
    """One direction between any two parts of pfpeople (a folder or a top-level module), and none back from
    gridbridge."""
    edges: dict[tuple[str, str], str] = {}
    for path in sorted((ROOT / "pfpeople").rglob("*.py")):
        module = ".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
        for name in _imports(path):
            if name.startswith("pfpeople.") and _unit(name) != _unit(module):
                edges.setdefault((_unit(module), _unit(name)), module)
    both = sorted((a, b, edges[(a, b)], edges[(b, a)]) for a, b in edges if (b, a) in edges and a < b)
    assert both == []
    for path in (ROOT / "gridbridge").rglob("*.py"):
        assert not any(n.startswith(("pfpeople", "evaluation")) for n in _imports(path)), path
