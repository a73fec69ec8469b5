"""Result bags (ROS 1, rosbag2 sqlite3, rosbag2 MCAP) written by ResultBagWriter and read back with AnyReader.

Every topic is read back and compared with what was written: grid cells, people and detection positions,
track ids, positions and velocities (people_msgs/People), marker ids, spheres, texts and arrow lengths, the
static TF; then the checks of a bad ``--bag-out`` before a run, and the pipeline writing tracks it is given.
The input copy, header stamps, metadata version and layout: ``tests/pfpeople/io/test_writer_share.py``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numpy.typing import NDArray
from rosbags.highlevel import AnyReader
from rosbags.interfaces import QosDurability

from evaluation.bench.batch import SYNTHETIC_CONFIG, write_synthetic_bag
from gridbridge.grid import GridSpec
from pfpeople.io.bag.reader import BagSource
from pfpeople.io.bag.writer import (
    GRID_ORIGIN_FRAME,
    MARKER_ARROW,
    MARKER_DELETEALL,
    MARKER_SPHERE,
    MARKER_TEXT_VIEW_FACING,
    TOPIC_BELIEF,
    TOPIC_PEOPLE,
    TOPIC_PEOPLE_MARKERS,
    TOPIC_TRACK_MARKERS,
    TOPIC_TRACKED_PERSONS,
    TOPIC_TRACKS,
    ResultBagWriter,
    bag_format_for,
    check_bag_out,
    detection_topic,
)
from pfpeople.pipeline.runner import Pipeline

SPEC = GridSpec()
T0 = 1_700_000_000_000_000_000
FORMATS = [("ros1", "out.bag", None), ("sqlite3", "out_db", None), ("mcap", "out_mcap", "mcap")]


@dataclass
class _Obj:
    id: int
    x: float
    y: float
    vx: float
    vy: float
    covariance: Any = None
    score: float = math.nan


@dataclass
class Written:
    beliefs: list[NDArray[np.float64]]
    people: list[NDArray[np.float64]]
    dets: list[list[NDArray[np.float64] | None]]
    tracks: list[NDArray[np.float64] | None]


def _write(path: Path, fmt: str | None, rng: np.random.Generator) -> Written:
    w = Written([], [], [], [])
    tracks: list[NDArray[np.float64] | None] = [
        np.array([[3, 2.0, 1.0, 1.0, 0.0], [7, 4.0, -1.5, -0.6, 0.8]]),
        np.array([[7, 3.5, -1.0, 0.0, 0.0]]),  # at rest: identity orientation, zero-length arrow
        None,  # no tracker output in this frame: nothing on the track topics
    ]
    with ResultBagWriter(
        path, spec=SPEC, frame_id="laser", detector_names=["laser_legs", "hog cam"], bag_format=fmt
    ) as bag:
        for k in range(3):
            belief = rng.uniform(0.0, 1.0, (SPEC.nx, SPEC.ny))
            people = rng.uniform(0.0, 4.0, (k + 1, 2))
            dets = [rng.uniform(0.0, 4.0, (2, 2)), None if k == 1 else rng.uniform(0.0, 4.0, (k, 2))]
            bag.write(T0 + k * 100_000_000 + 5, T0 + k * 100_000_000, belief, people, dets, tracks[k])
            w.beliefs.append(belief)
            w.people.append(people)
            w.dets.append(dets)
    w.tracks = tracks
    return w


def _read(path: Path) -> tuple[dict[str, list[tuple[int, Any]]], dict[str, Any]]:
    out: dict[str, list[tuple[int, Any]]] = {}
    with AnyReader([path]) as r:
        conns = {c.topic: c for c in r.connections}
        for conn, t, raw in r.messages():
            out.setdefault(conn.topic, []).append((t, r.deserialize(raw, conn.msgtype)))
    return out, conns


def _xy(pose_array: Any) -> NDArray[np.float64]:
    return np.array([[p.position.x, p.position.y] for p in pose_array.poses]).reshape(-1, 2)


def _pxy(people: Any) -> NDArray[np.float64]:
    return np.array([[p.position.x, p.position.y] for p in people.people]).reshape(-1, 2)


@pytest.mark.parametrize(("fmt", "name", "given"), FORMATS)
def test_round_trip_every_topic(tmp_path: Path, rng: np.random.Generator, fmt: str, name: str, given: Any) -> None:
    path = tmp_path / name
    w = _write(path, given, rng)
    if fmt == "ros1":
        assert path.is_file()
    else:
        suffix = ".mcap" if fmt == "mcap" else ".db3"
        assert (path / "metadata.yaml").is_file() and [p.suffix for p in path.iterdir() if p.suffix != ".yaml"] == [
            suffix
        ]
    msgs, conns = _read(path)
    assert set(msgs) == {
        "/tf_static",
        TOPIC_BELIEF,
        TOPIC_PEOPLE,
        TOPIC_PEOPLE_MARKERS,
        detection_topic("laser_legs"),
        "/pfpeople/detections/hog_cam",
        TOPIC_TRACKS,
        TOPIC_TRACKED_PERSONS,
        TOPIC_TRACK_MARKERS,
    }
    # Static TF: once, grid frame -> grid origin at the grid's lower corner; latched / transient_local.
    assert len(msgs["/tf_static"]) == 1
    (tf,) = msgs["/tf_static"][0][1].transforms
    assert (tf.header.frame_id, tf.child_frame_id) == ("laser", GRID_ORIGIN_FRAME)
    assert (tf.transform.translation.x, tf.transform.translation.y) == (SPEC.x0, SPEC.y0)
    ext = conns["/tf_static"].ext
    if fmt == "ros1":
        assert ext.latching == 1
    else:
        assert ext.offered_qos_profiles[0].durability == QosDurability.TRANSIENT_LOCAL
    # Belief: data[j * nx + i] = round(100 belief[i, j]); record times and stamps as written.
    grids = msgs[TOPIC_BELIEF]
    assert [t for t, _ in grids] == [T0 + k * 100_000_000 + 5 for k in range(3)]
    for (_, g), belief in zip(grids, w.beliefs, strict=True):
        assert g.header.frame_id == "laser" and g.header.stamp.nanosec + g.header.stamp.sec * 10**9 in {
            T0 + k * 100_000_000 for k in range(3)
        }
        assert (g.info.width, g.info.height, g.info.resolution) == (SPEC.nx, SPEC.ny, pytest.approx(SPEC.resolution))
        assert (g.info.origin.position.x, g.info.origin.position.y) == (SPEC.x0, SPEC.y0)
        data = np.asarray(g.data).reshape(SPEC.ny, SPEC.nx)
        np.testing.assert_array_equal(data.T, np.rint(belief * 100).astype(np.int8))
        assert data[4, 7] == round(100 * belief[7, 4])
    # People and detections: positions exact to float64; the detector without data has no message then.
    for (_, pa), people in zip(msgs[TOPIC_PEOPLE], w.people, strict=True):
        np.testing.assert_allclose(_pxy(pa), people, rtol=0, atol=1e-12)
        assert [(p.name, p.reliability) for p in pa.people] == [("", 1.0)] * len(people)
    for (_, ma), people in zip(msgs[TOPIC_PEOPLE_MARKERS], w.people, strict=True):
        assert ma.markers[0].action == MARKER_DELETEALL
        spheres = [(m.type, m.id, m.pose.position.x, m.pose.position.y) for m in ma.markers[1:]]
        assert spheres == [(MARKER_SPHERE, k, x, y) for k, (x, y) in enumerate(people)]
    legs = [_xy(m) for _, m in msgs[detection_topic("laser_legs")]]
    cam = [_xy(m) for _, m in msgs["/pfpeople/detections/hog_cam"]]
    assert len(legs) == 3 and len(cam) == 2 and cam[0].shape == (0, 2)
    np.testing.assert_allclose(legs[2], np.asarray(w.dets[2][0]), atol=1e-12)
    np.testing.assert_allclose(cam[1], np.asarray(w.dets[2][1]), atol=1e-12)
    # Tracks: two frames had them; ids in name, positions, velocities (zero at rest).
    tracks = msgs[TOPIC_TRACKS]
    assert len(tracks) == 2
    t0, t1 = (m for _, m in tracks)
    assert [p.name for p in t0.people] == ["3", "7"] and [p.name for p in t1.people] == ["7"]
    np.testing.assert_allclose(_pxy(t0), [[2.0, 1.0], [4.0, -1.5]], atol=1e-12)
    assert [(p.velocity.x, p.velocity.y) for p in t0.people] == [(1.0, 0.0), (-0.6, 0.8)]
    assert (t1.people[0].velocity.x, t1.people[0].velocity.y) == (0.0, 0.0)
    assert all(p.reliability == 1.0 and list(p.tagnames) == [] for p in t0.people)  # no score, no covariance
    # Markers: DELETEALL first, then per track a sphere, the id text and the velocity arrow (length = speed x 1 s).
    arrays = [m.markers for _, m in msgs[TOPIC_TRACK_MARKERS]]
    assert [len(a) for a in arrays] == [7, 4]
    assert [(m.id, m.ns) for m in arrays[0] if m.type == MARKER_SPHERE] == [
        (3, "pfpeople/tracks"),
        (7, "pfpeople/tracks"),
    ]
    first = arrays[0]
    assert first[0].action == MARKER_DELETEALL
    texts = [m for m in first if m.type == MARKER_TEXT_VIEW_FACING]
    arrows = [m for m in first if m.type == MARKER_ARROW and m.action == 0]
    assert [(m.id, m.text) for m in texts] == [(3, "3"), (7, "7")]
    assert [(m.pose.position.x, m.pose.position.y) for m in texts] == [(2.0, 1.0), (4.0, -1.5)]
    assert all(m.header.frame_id == "laser" for m in first)
    lengths = [math.dist((a.points[0].x, a.points[0].y), (a.points[1].x, a.points[1].y)) for a in arrows]
    assert [a.id for a in arrows] == [3, 7] and lengths == pytest.approx([1.0, 1.0], abs=1e-12)
    assert (arrows[1].points[1].x, arrows[1].points[1].y) == pytest.approx((3.4, -0.7), abs=1e-12)
    at_rest = next(m for m in arrays[1] if m.type == MARKER_ARROW and m.action == 0)
    assert math.dist((at_rest.points[0].x, at_rest.points[0].y), (at_rest.points[1].x, at_rest.points[1].y)) == 0


def test_format_from_suffix_and_bad_outputs(tmp_path: Path) -> None:
    assert bag_format_for(tmp_path / "a.bag") == "ros1"
    assert bag_format_for(tmp_path / "a") == "sqlite3"
    assert bag_format_for(tmp_path / "a", "sqlite3") == "sqlite3"
    with pytest.raises(ValueError, match=r"'.*x': unknown format 'hdf5'"):
        check_bag_out(tmp_path / "x", "hdf5")
    with pytest.raises(ValueError, match=r"ROS 1 bag must end in \.bag"):
        check_bag_out(tmp_path / "x", "ros1")
    with pytest.raises(ValueError, match="is a folder"):
        check_bag_out(tmp_path / "x.bag", "mcap")
    missing = tmp_path / "nope" / "out.bag"
    with pytest.raises(FileNotFoundError, match=r"nope/out\.bag.*parent folder .* does not exist"):
        check_bag_out(missing)
    (tmp_path / "old.bag").write_bytes(b"x")
    with pytest.raises(FileExistsError, match=r"old\.bag' already exists"):
        check_bag_out(tmp_path / "old.bag")
    assert check_bag_out(tmp_path / "old.bag", overwrite=True) == (tmp_path / "old.bag", "ros1")
    notabag = tmp_path / "results"
    notabag.mkdir()
    (notabag / "keep.txt").write_text("mine")
    with pytest.raises(ValueError, match="not a rosbag2 folder"):
        check_bag_out(notabag, overwrite=True)
    # overwrite replaces an existing rosbag2 folder.
    ResultBagWriter(tmp_path / "r2", spec=SPEC, frame_id="laser", detector_names=[]).close()
    with ResultBagWriter(tmp_path / "r2", spec=SPEC, frame_id="laser", detector_names=[], overwrite=True) as w:
        w.write(T0, T0, np.zeros((SPEC.nx, SPEC.ny)), np.zeros((0, 2)), [])
    msgs, _ = _read(tmp_path / "r2")
    assert len(msgs[TOPIC_BELIEF]) == 1
    # Track objects with id, x, y, vx, vy (and covariance, score) attributes are accepted as well as arrays; an
    # empty frame of tracks writes an empty People and a lone DELETEALL.
    with ResultBagWriter(tmp_path / "obj.bag", spec=SPEC, frame_id="laser", detector_names=[]) as w:
        obj = _Obj(id=4, x=1.0, y=2.0, vx=0, vy=-2.0, covariance=np.array([[0.1, 0.02], [0.02, 0.3]]), score=0.8)
        w.write(T0, T0, np.zeros((SPEC.nx, SPEC.ny)), np.zeros((0, 2)), [], [obj])
        w.write(T0 + 1, T0 + 1, np.zeros((SPEC.nx, SPEC.ny)), np.zeros((0, 2)), [], [])
    msgs, _ = _read(tmp_path / "obj.bag")
    assert [len(m.people) for _, m in msgs[TOPIC_TRACKS]] == [1, 0]
    (p,) = msgs[TOPIC_TRACKS][0][1].people
    assert (p.name, p.velocity.y, p.reliability) == ("4", -2.0, 0.8)
    assert dict(zip(p.tagnames, map(float, p.tags), strict=True)) == {"cov_xx": 0.1, "cov_xy": 0.02, "cov_yy": 0.3}
    actions = [[k.action for k in m.markers] for _, m in msgs[TOPIC_TRACK_MARKERS]]
    assert actions == [[MARKER_DELETEALL, 0, 0, 0], [3]]
    with pytest.raises(ValueError, match=r"tracks must have shape \(K, 5\)"):
        with ResultBagWriter(tmp_path / "t.bag", spec=SPEC, frame_id="laser", detector_names=[]) as w:
            w.write(T0, T0, np.zeros((SPEC.nx, SPEC.ny)), np.zeros((0, 2)), [], np.zeros((2, 4)))


def test_run_command_checks_bag_out_before_running(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from pfpeople.cli import main

    bag = write_synthetic_bag(tmp_path / "in.bag", n_scans=3, rng=np.random.default_rng(1))
    out = tmp_path / "run"
    args = ["run", str(bag), "--driver", "/scan", "--out", str(out), "--no-progress"]
    assert main([*args, "--bag-out", str(tmp_path / "missing" / "res")]) == 2
    assert "missing/res" in capsys.readouterr().err and not out.exists()
    (tmp_path / "taken.bag").write_bytes(b"")
    assert main([*args, "--bag-out", str(tmp_path / "taken.bag")]) == 2
    assert "taken.bag' already exists" in capsys.readouterr().err and not out.exists()
    assert main([*args, "--bag-out", str(tmp_path / "res"), "--bag-format", "sqlite3"]) == 0
    msgs, _ = _read(tmp_path / "res")
    assert len(msgs[TOPIC_BELIEF]) == 3 and len(msgs[TOPIC_TRACKS]) == 3  # tracking is on by default


def test_pipeline_passes_tracks_to_the_bag(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    bag = write_synthetic_bag(tmp_path / "in.bag", n_scans=4, rng=np.random.default_rng(2))
    plain = Pipeline.frames

    def frames(self: Pipeline, src: BagSource, *, max_frames: int | None = None) -> Any:
        for r in plain(self, src, max_frames=max_frames):
            k = r.frame.index
            yield replace(r, tracks=np.array([[k, 1.0, k, 0.5, 0]]))

    monkeypatch.setattr(Pipeline, "frames", frames)
    with BagSource(bag) as src:
        Pipeline(SYNTHETIC_CONFIG).run(src, None, bag_out=tmp_path / "res_mcap")
    msgs, _ = _read(tmp_path / "res_mcap")
    assert [_pxy(m)[0, 1] for _, m in msgs[TOPIC_TRACKS]] == [0.0, 1.0, 2.0, 3.0]
    assert [m.markers[2].text for _, m in msgs[TOPIC_TRACK_MARKERS]] == ["0", "1", "2", "3"]
