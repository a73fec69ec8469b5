"""Results in a fixed frame (``[output] frame``, pfpeople.pipeline.output_frame): run directory columns, result bag.

The scene of ``bag_fixtures.write_bag``: two people stand still in ``odom`` (``PEOPLE_ODOM``) while the robot drives
an arc; odometry ``odom -> base_link`` at 50 Hz, the laser on ``base_link`` by ``/tf_static``; the grid frame is the
laser's. In ``odom`` the people found must stand where they are, and the tracks must not move.
"""

from __future__ import annotations

import logging
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from bag_fixtures import MOUNT, PEOPLE_ODOM, config, laser_pose, write_bag
from rosbags.highlevel import AnyReader

from pfpeople.config import OutputConfig, config_from_mapping
from pfpeople.io.run_dir import load_run
from pfpeople.pipeline.output_frame import tracks_in
from pfpeople.pipeline.runner import Pipeline
from pfpeople.sensors import Pose2D
from pfpeople.track import Track

N = 20


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("out") / "scene.bag"
    write_bag(path, n_scans=N)
    return path


def _run(bag: Path, out: Path, frame: str, **kw: object) -> None:
    cfg = replace(config(), output=OutputConfig(frame=frame))
    Pipeline(cfg, front_process=False).run(bag, out, **kw)  # type: ignore[arg-type]


def test_people_and_tracks_in_odom_stand_where_the_people_stand(bag: Path, tmp_path: Path) -> None:
    _run(bag, tmp_path / "run", "odom")
    run = load_run(tmp_path / "run")
    assert run.meta["output_frame"] == "odom" and run.meta["stats"]["output_unplaced"] == 0
    f = run.frames
    for k in range(N):  # the grid frame (the laser's) in odom: the odometry pose, interpolated to the scan
        true = laser_pose(k * 0.1)
        got = (f["out_x_m"][k], f["out_y_m"][k], f["out_yaw_rad"][k])
        assert got == pytest.approx((true.x, true.y, true.yaw), abs=1e-6)
    p = run.people
    assert len(p["frame"]) >= N
    out = np.column_stack((p["out_x_m"], p["out_y_m"]))
    near = np.min(np.hypot(*(out[:, None, :] - PEOPLE_ODOM[None, :, :]).transpose(2, 0, 1)), axis=1)
    assert near.max() < 0.15
    for row, k in enumerate(p["frame"]):  # P p, row by row
        pose = Pose2D(x=f["out_x_m"][k], y=f["out_y_m"][k], yaw=f["out_yaw_rad"][k])
        grid = np.array([[p["x_m"][row], p["y_m"][row]]])
        assert np.allclose(pose.apply(grid)[0], out[row], atol=2e-5)
    t = run.tracks
    assert t is not None and len(t["id"]) > 0
    assert np.all(np.hypot(t["out_vx"], t["out_vy"]) < 0.3)  # standing
    for tid in set(t["id"].tolist()):  # each track stays put in odom while it sweeps through the moving grid frame
        mine = t["id"] == tid
        if mine.sum() > 5:
            assert np.ptp(t["out_x"][mine]) < 0.1 and np.ptp(t["out_y"][mine]) < 0.1
            assert max(np.ptp(t["x"][mine]), np.ptp(t["y"][mine])) > 0.2


def test_a_tf_frame_places_the_results_by_its_transform(bag: Path, tmp_path: Path) -> None:
    _run(bag, tmp_path / "run", "base_link")  # from /tf_static: the laser's mount on base_link
    run = load_run(tmp_path / "run")
    f, p = run.frames, run.people
    assert np.allclose(f["out_x_m"], MOUNT.x) and np.allclose(f["out_yaw_rad"], MOUNT.yaw)
    grid = np.column_stack((p["x_m"], p["y_m"]))
    assert np.allclose(np.column_stack((p["out_x_m"], p["out_y_m"])), MOUNT.apply(grid), atol=2e-6)


def test_an_unknown_output_frame_is_counted_warned_and_left_out(
    bag: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.WARNING):
        _run(bag, tmp_path / "run", "map", bag_out=tmp_path / "out.bag")
    run = load_run(tmp_path / "run")
    assert run.meta["stats"]["output_unplaced"] == N and np.isnan(run.people["out_x_m"]).all()
    assert caplog.text.count("[output] frame 'map'") == 1
    with AnyReader([tmp_path / "out.bag"]) as reader:
        topics = {c.topic for c in reader.connections if c.msgcount}
    assert "/pfpeople/belief" in topics and "/pfpeople/people" not in topics and "/pfpeople/tracks" not in topics


def test_the_result_bag_gives_people_and_tracks_in_the_output_frame(bag: Path, tmp_path: Path) -> None:
    _run(bag, tmp_path / "run", "odom", bag_out=tmp_path / "out.bag")
    with AnyReader([tmp_path / "out.bag"]) as reader:
        frames: dict[str, set[str]] = {}
        people = []
        for conn, _t, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            header = getattr(msg, "header", None)
            if header is not None and conn.topic.startswith("/pfpeople"):
                frames.setdefault(conn.topic, set()).add(header.frame_id)
            if conn.topic == "/pfpeople/people":
                people += [(q.position.x, q.position.y) for q in msg.people]
    assert frames["/pfpeople/people"] == frames["/pfpeople/tracks"] == {"odom"}
    assert frames["/pfpeople/belief"] == {"laser"}
    near = [min(math.hypot(x - a, y - b) for a, b in PEOPLE_ODOM) for x, y in people]
    assert len(near) >= N and max(near) < 0.15


def test_track_states_rotate_with_the_frame() -> None:
    """Position moved, velocity and covariance rotated: ``R C R^T`` with ``R = diag(rot, rot)``, by hand."""
    cov = np.diag([0.04, 0.01, 0.25, 0.09])
    cov[0, 1] = cov[1, 0] = 0.005
    t = Track(id=3, x=1.0, y=0.0, vx=1.0, vy=0.0, covariance=cov, score=0.9, hits=3, misses=0, age=3, confirmed=True)
    (moved,) = tracks_in(Pose2D(x=2.0, y=1.0, yaw=math.pi / 2), [t])
    assert (moved.x, moved.y, moved.vx, moved.vy) == pytest.approx((2.0, 2.0, 0.0, 1.0))
    assert moved.covariance[0, 0] == pytest.approx(0.01) and moved.covariance[1, 1] == pytest.approx(0.04)
    assert moved.covariance[0, 1] == pytest.approx(-0.005) and moved.covariance[2, 2] == pytest.approx(0.09)
    assert (moved.id, moved.score) == (3, 0.9)


def test_the_output_table_reads_writes_and_refuses_a_leading_slash() -> None:
    base = {"frames": {"driver": "/scan"}, "detectors": [{"name": "legs", "kind": "leg", "topic": "/scan"}]}
    assert config_from_mapping(base).to_dict()["output"] == {"frame": ""}  # the default: the grid frame only
    cfg = config_from_mapping({**base, "output": {"frame": "odom"}})
    assert cfg.output.frame == "odom" and config_from_mapping(cfg.to_dict()) == cfg
    with pytest.raises(ValueError, match=r"^\[output\] frame: a TF frame id has no leading '/'"):
        config_from_mapping({**base, "output": {"frame": "/odom"}})
    with pytest.raises(ValueError, match=r"^\[output\] topic: unknown key; allowed: \['frame'\]"):
        config_from_mapping({**base, "output": {"topic": "x"}})
