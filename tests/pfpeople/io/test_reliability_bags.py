"""Issue 11: damaged input gives a clear error naming it, or a stated, logged and counted handling.

Bags are written here as ``tests/pfpeople/pipeline/test_pipeline_bags.py`` writes them (its ``write_bag`` and message
helpers); ``write_scan_bag`` writes a LaserScan-only ROS1 bag whose scan fields (increment, range interval) are free.
"""

from __future__ import annotations

import json
import logging
import math
import zipfile
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from bag_fixtures import INC, MOUNT, PEOPLE, T0_NS, Msgs, config, legs, legs_only, typestore, write_bag, write_scan_bag

from gridbridge.grid import GridSpec
from gridbridge.limits import ResourceLimitError
from gridbridge.params import DetectorModel
from pfpeople.config import BagConfig, DetectorConfig, config_from_mapping, load_config
from pfpeople.detect.synthetic import render_scan, reversed_scan
from pfpeople.io.bag import archive
from pfpeople.io.bag.reader import BagReadError, BagSource, laser_from_msg, odometry_pose_from_msg
from pfpeople.io.run_dir import load_run
from pfpeople.pipeline.runner import Pipeline
from pfpeople.sensors import Pose2D


def _close(a: np.ndarray, b: np.ndarray) -> bool:
    """Same set of positions up to order (1e-9 m)."""
    if a.shape != b.shape:
        return False
    order_a, order_b = np.lexsort(a.T[::-1]), np.lexsort(b.T[::-1])
    return bool(np.allclose(a[order_a], b[order_b], atol=1e-9))


# -- silent wrong results --------------------------------------------------------------------------------------


def test_one_scan_an_hour_ahead_is_skipped_not_the_rest_of_the_run(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    def hook(k: int, stamp: int, ranges: np.ndarray) -> tuple[int, np.ndarray]:
        return (stamp + 3600 * 10**9 if k == 3 else stamp), ranges

    bag = tmp_path / "jump.bag"
    write_bag(bag, n_scans=12, scan_hook=hook)
    with caplog.at_level(logging.WARNING), BagSource(bag) as src:
        summary, results = Pipeline(config()).run(src, tmp_path / "run", keep=True)
    # Before: every later scan was dropped as non-monotonic (exit 0, "complete"). Now only the outlier is.
    assert summary.frames == 11
    assert summary.sync["clock_jump"] == {"/scan": 1} and summary.sync["non_monotonic"] == {}
    assert [r.frame.driver.index for r in results] == [k for k in range(12) if k != 3]
    legs = [r.detections[0] for r in results]
    assert summary.frames_without_odometry == 0 and all(d is not None and len(d) == 2 for d in legs)
    assert summary.filter_restarts == 0
    assert "outlier stamp" in caplog.text
    meta = load_run(tmp_path / "run").meta
    assert meta["status"] == "complete" and meta["skipped_frames"] == {"clock_jump": 1}


def test_a_clock_that_jumps_for_good_is_resynchronised(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    def hook(k: int, stamp: int, ranges: np.ndarray) -> tuple[int, np.ndarray]:
        return (stamp + 3600 * 10**9 if k >= 4 else stamp), ranges

    bag = tmp_path / "resync.bag"
    write_bag(bag, n_scans=10, scan_hook=hook, odometry=False)
    with caplog.at_level(logging.WARNING), BagSource(bag) as src:
        summary, results = Pipeline(config(odometry=False)).run(src, None, keep=True)
    # scans 4 and 5 are held until scan 6 makes three messages agreeing on the new clock: none is lost
    assert summary.sync["clock_jump"] == {} and summary.sync["resync"] == {"/scan": 1}
    assert summary.frames == 10 and [r.frame.driver.index for r in results] == list(range(10))
    assert summary.filter_restarts == 1  # the hour-long gap restarts the filter
    assert "following the new clock" in caplog.text


def test_negative_angle_increment_gives_the_same_people(tmp_path: Path) -> None:
    fwd, rev = tmp_path / "fwd.bag", tmp_path / "rev.bag"
    write_scan_bag(fwd, 3)
    write_scan_bag(rev, 3, reverse=True)
    out = {}
    for name, bag in (("fwd", fwd), ("rev", rev)):
        with BagSource(bag) as src:
            out[name] = Pipeline(legs_only()).run(src, None, keep=True)[1]
    for a, b in zip(out["fwd"], out["rev"], strict=True):
        da, db = a.detections[0], b.detections[0]
        assert da is not None and db is not None
        assert len(da) == 2  # both people
        assert _close(da, db)
    np.testing.assert_allclose(out["fwd"][-1].belief, out["rev"][-1].belief, atol=1e-12)


def test_boosted_detector_on_a_reversed_scan() -> None:
    from pfpeople.detect import BoostedSegmentDetector, LegDetector

    scan = render_scan(circles=legs(PEOPLE), angle_increment=INC)
    rev = reversed_scan(scan)
    for det in (LegDetector(), BoostedSegmentDetector()):
        a, b = det.detect(scan), det.detect(rev)
        assert len(a) >= 1 and _close(a, b)


@pytest.mark.parametrize(("attr", "value"), [("fnr", 0.0), ("fnr", 1.0), ("ppv", 1.0), ("ppv", 0.0)])
def test_ppv_fnr_at_0_or_1_are_refused_with_the_reason(attr: str, value: float) -> None:
    kwargs = {"name": "d", "ppv": 0.9, "fnr": 0.2, attr: value}
    with pytest.raises(ValueError, match=rf"DetectorModel\(d\)\.{attr} must be strictly between 0 and 1.*no later"):
        DetectorModel(**kwargs)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"ppv must be a number"):
        DetectorModel(name="d", ppv="high", fnr=0.2)  # type: ignore[arg-type]


def test_calibrated_zero_fnr_is_clamped_when_made_a_model(caplog: pytest.LogCaptureFixture) -> None:
    from evaluation.harness.calibration import PROBABILITY_MARGIN, calibrate_detector

    truth = [np.array([[2.0, 0.0]])] * 5
    res = calibrate_detector(truth, truth, model=DetectorModel(name="d", ppv=0.9, fnr=0.2))
    assert (res.ppv, res.fnr) == (1.0, 0.0)
    with caplog.at_level(logging.WARNING):
        model = res.to_model(DetectorModel(name="d", ppv=0.9, fnr=0.2))
    assert (model.ppv, model.fnr) == (1.0 - PROBABILITY_MARGIN, PROBABILITY_MARGIN)
    assert "FNR = 0 clamped to 0.01" in caplog.text


@pytest.mark.parametrize("front_process", [False, True])
def test_all_nan_scan_is_warned_and_counted_as_no_data(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, front_process: bool
) -> None:
    """In one process and with the front-end process (pfpeople.pipeline.front_end), whose warnings and counters reach
    this
    process: warned once, counted once."""

    def hook(k: int, stamp: int, ranges: np.ndarray) -> tuple[int, np.ndarray]:
        return stamp, (np.full_like(ranges, np.nan) if k == 4 else ranges)

    bag = tmp_path / "nan.bag"
    write_bag(bag, n_scans=6, scan_hook=hook, odometry=False)
    with caplog.at_level(logging.WARNING), BagSource(bag) as src:
        summary, results = Pipeline(config(odometry=False), front_process=front_process).run(src, None, keep=True)
    assert summary.bad_messages == {"laser_legs": 1} and summary.no_data == {"laser_legs": 1}
    assert results[4].detections[0] is None  # no data (covers no cell), not "saw nobody"
    assert caplog.text.count("all 361 ranges are NaN") == 1 and "'/scan'" in caplog.text


@pytest.mark.parametrize(("rmin", "rmax"), [(20.0, 10.0), (0.05, math.nan)])
def test_bad_range_interval_names_the_topic(tmp_path: Path, caplog: pytest.LogCaptureFixture, rmin, rmax) -> None:
    bag = tmp_path / "range.bag"
    write_scan_bag(bag, 3, range_min=rmin, range_max=rmax)
    with caplog.at_level(logging.WARNING), BagSource(bag) as src:
        summary, _ = Pipeline(legs_only()).run(src, None)
    assert summary.no_data == {"legs": 3} and summary.bad_messages == {"legs": 3}
    assert "topic '/scan'" in caplog.text and "range_min" in caplog.text and "range_max" in caplog.text


def test_zip_with_two_bags_names_both(tmp_path: Path) -> None:
    bag = tmp_path / "a.bag"
    write_bag(bag, n_scans=2)
    z = tmp_path / "two.zip"
    with zipfile.ZipFile(z, "w") as zf:
        zf.write(bag, "first/a.bag")
        zf.write(bag, "second/b.bag")
    with pytest.raises(BagReadError, match=r"holds 2 bags \(first/a\.bag, second/b\.bag\)"):
        BagSource(z, cache_dir=tmp_path / "cache")
    assert not (tmp_path / "cache").exists() or not any((tmp_path / "cache").iterdir())


# -- unbounded resources ---------------------------------------------------------------------------------------


def test_zip_bomb_is_refused_before_extraction(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(archive, "ZIP_RATIO_MIN_BYTES", 2**20)  # the real threshold is 64 MiB: a small bomb here
    z = tmp_path / "bomb.bag.zip"
    with zipfile.ZipFile(z, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("bomb.bag", b"\0" * (8 * 2**20))
    assert z.stat().st_size < 40_000
    with pytest.raises(BagReadError, match=r"member 'bomb\.bag' is 8388608 bytes uncompressed .*zip bomb"):
        BagSource(z, cache_dir=tmp_path / "cache")
    assert not list((tmp_path / "cache").rglob("*.bag"))
    monkeypatch.setenv("PFPEOPLE_MAX_ZIP_BYTES", "1000")
    with pytest.raises(BagReadError, match=r"member 'bomb\.bag' is 8388608 bytes .*limit of 1000 bytes"):
        BagSource(z, cache_dir=tmp_path / "cache")


def test_zip_cache_is_bounded_and_old_copies_are_evicted(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import os

    monkeypatch.setattr(archive, "MAX_CACHE_ENTRIES", 2)
    bag = tmp_path / "s.bag"
    write_bag(bag, n_scans=2)
    cache = tmp_path / "cache"
    zips = []
    for k in range(3):
        z = tmp_path / f"z{k}.bag.zip"
        with zipfile.ZipFile(z, "w") as zf:
            zf.write(bag, "s.bag")
        zips.append(z)
        with BagSource(z, cache_dir=cache):
            pass
        os.utime(cache / next(p.name for p in cache.iterdir() if p.name.startswith(f"z{k}")) / ".complete", (k, k))
    names = sorted(p.name.split("-")[0] for p in cache.iterdir())
    assert names == ["z1.bag", "z2.bag"]  # least recently used (z0) evicted
    # The same zip changed (new mtime): its old copy is evicted at once.
    os.utime(zips[2], ns=(10**9, 10**9))
    with BagSource(zips[2], cache_dir=cache):
        pass
    assert sorted(p.name.split("-")[0] for p in cache.iterdir()) == ["z1.bag", "z2.bag"]
    assert len(list(cache.rglob("s.bag"))) == 2


@pytest.mark.parametrize(
    ("grid", "filt", "match"),
    [
        ({"resolution": 1e-300}, {}, r"\[grid\]: resolution 1e-300 m .*neighbourhood"),
        ({"nx": 100000, "ny": 100000}, {}, r"\[grid\]: 100000 x 100000 = 10000000000 cells"),
        ({"nx": 100000, "ny": 100000, "x0": 0.0, "y0": 0.0}, {}, r"GridSpec: 100000 x 100000 = 10000000000 cells"),
        ({"nx": 2000, "ny": 2000, "resolution": 0.01}, {}, r"operations per frame"),
        ({"nx": 30}, {"kind": "particle", "n_particles": 10**9}, r"\[filter\] n_particles = 1000000000 is more"),
    ],
)
def test_resource_limits_are_checked_before_allocation(grid: dict, filt: dict, match: str) -> None:
    data = {"frames": {"driver": "/scan"}, "detectors": [{"name": "l", "kind": "leg", "topic": "/scan"}]}
    with pytest.raises(ResourceLimitError, match=match):
        config_from_mapping({**data, "grid": grid, "filter": filt})


def _filters() -> list[Any]:
    from gridbridge import GridFilter
    from pfpeople.particle.filter import ParticleFilter

    spec = GridSpec(nx=20, ny=20)
    return [GridFilter(spec), ParticleFilter(spec, n_particles=2000, rng=np.random.default_rng(0))]


@pytest.mark.parametrize("k", [0, 1], ids=["grid", "particle"])
def test_dt_beyond_the_bound_or_not_a_number_is_refused_before_anything_is_allocated(k: int) -> None:
    from gridbridge.limits import MAX_DT_S, check_dt

    f = _filters()[k]
    before = f.belief.copy()
    dets = [np.zeros((0, 2))] * len(f.detectors)
    with pytest.raises(ResourceLimitError, match=r"dt = 100 s is more than the limit of 10 s \(a time in ms"):
        f.step(dets, None, dt=100)  # ms passed as seconds: minutes and gigabytes (grid), 555 GiB (particles)
    with pytest.raises(ResourceLimitError, match=r"dt = 10\.5 s is more than the limit"):
        f.predict(None, 10.5)
    bad_types = (("0.1", "str"), (0.1 + 0j, "complex"), (True, "bool"), (np.bool_(True), "bool"), (None, "NoneType"))
    for bad, name in bad_types:
        with pytest.raises(TypeError, match=rf"dt must be a real number of seconds, got {name}"):
            f.step(dets, None, dt=bad)
    with pytest.raises(ValueError, match=r"dt must be a finite positive number of seconds, got nan"):
        f.step(dets, None, dt=math.nan)
    np.testing.assert_array_equal(f.belief, before)  # nothing changed
    assert check_dt(MAX_DT_S) == 10.0 and check_dt(np.float32(0.1)) == pytest.approx(0.1)  # the bound is allowed
    f.step(dets, None, dt=0.1)
    assert np.all(np.isfinite(f.belief)) and not np.array_equal(f.belief, before)


def test_particle_filter_checks_its_size_and_the_memory_budget(monkeypatch: pytest.MonkeyPatch) -> None:
    from gridbridge.grid import GridSpec
    from pfpeople.particle.filter import ParticleFilter

    rng = np.random.default_rng(0)
    with pytest.raises(ResourceLimitError, match=r"n_particles = 1000000000 is more than the limit"):
        ParticleFilter(GridSpec(), n_particles=10**9, rng=rng)
    monkeypatch.setenv("PFPEOPLE_MAX_MEMORY_BYTES", str(2**20))
    with pytest.raises(ResourceLimitError, match=r"needs about .* more than the budget of 1 MiB"):
        ParticleFilter(GridSpec(), n_particles=50_000, rng=rng)


def test_calibrate_truth_with_stamps_as_frames_is_refused_early(tmp_path: Path, capsys) -> None:
    from evaluation.cli import main as eval_main
    from evaluation.harness.calibration import calibrate_sparse

    truth, dets = tmp_path / "t.csv", tmp_path / "d.csv"
    truth.write_text("frame,person_id,x_m,y_m\n0,1,2.0,0.0\n1700000000123456789,1,2.0,0.0\n")
    dets.write_text("frame,x_m,y_m\n0,2.0,0.0\n")
    args = ["calibrate", "--truth", str(truth), "--detections", str(dets)]
    assert eval_main(args) == 2
    assert "t.csv:3: frame 1700000000123456789 is beyond 100000000 frames" in capsys.readouterr().err
    # Sparse frame numbers are matched without a list up to the largest one; empty frames still count.
    res = calibrate_sparse({0: [[2.0, 0.0]]}, {0: [[2.0, 0.0]], 5_000_000: [[3.0, 0.0]]})
    assert res.counts.n_frames == 5_000_001 and res.counts.n_people == 2 and res.counts.n_true_positives == 1


# -- tracebacks and unclear messages ---------------------------------------------------------------------------


def test_detector_param_of_the_wrong_type_is_named(tmp_path: Path) -> None:
    bag = tmp_path / "p.bag"
    write_scan_bag(bag, 2)
    cfg_path = tmp_path / "c.toml"
    cfg_path.write_text(
        '[frames]\ndriver = "/scan"\n[[detectors]]\nname = "b"\nkind = "boosted"\ntopic = "/scan"\n'
        '[detectors.params]\nthreshold = "high"\n'
    )
    with BagSource(bag) as src, pytest.raises(ValueError, match=r"detectors\.params\.threshold must be a number"):
        Pipeline(load_config(cfg_path)).run(src, None)
    bad = replace(
        legs_only(),
        detectors=(DetectorConfig(name="l", kind="leg", topic="/scan", params={"params": {"min_width": "x"}}),),
    )
    with BagSource(bag) as src, pytest.raises(ValueError, match=r"detectors\.params\.params\.min_width must be"):
        Pipeline(bad).run(src, None)
    not_model = tmp_path / "model.yml"
    not_model.write_bytes(b"\x89PNG\r\n not a model")
    det = DetectorConfig(name="b", kind="boosted", topic="/scan", params={"model_path": str(not_model)})
    with BagSource(bag) as src, pytest.raises(ValueError, match=r"boosted model file '.*model\.yml' is not a trained"):
        Pipeline(replace(legs_only(), detectors=(det,))).run(src, None)


def test_not_a_bag_folder_empty_topic_and_truncated_bag(tmp_path: Path) -> None:
    junk = tmp_path / "random.bag"
    junk.write_bytes(np.random.default_rng(1).integers(0, 256, 4096, dtype=np.uint8).tobytes())
    with pytest.raises(BagReadError, match=r"random\.bag.*not a ROS1 bag"):
        BagSource(junk)
    folder = tmp_path / "folder"
    folder.mkdir()
    (folder / "notes.txt").write_text("hello")
    with pytest.raises(BagReadError, match=r"folder '.*folder' is not a ROS2 bag \(no metadata\.yaml"):
        BagSource(folder)
    empty = tmp_path / "empty.bag"
    write_scan_bag(empty, 2, topics=("/scan", "/scan_rear"))
    cfg = replace(
        legs_only(), driver="/scan_rear", detectors=(DetectorConfig(name="l", kind="leg", topic="/scan_rear"),)
    )
    with BagSource(empty) as src, pytest.raises(ValueError, match=r"topic '/scan_rear' .* has no messages"):
        Pipeline(cfg).run(src, None)
    full = tmp_path / "full.bag"
    write_scan_bag(full, 30)
    cut = tmp_path / "cut.bag"
    cut.write_bytes(full.read_bytes()[: full.stat().st_size // 2])
    with pytest.raises(BagReadError, match=r"cut\.bag.*rosbag reindex"):
        with BagSource(cut) as src:
            list(src.messages(["/scan"]))


def test_implausible_odometry_is_named_and_counted(tmp_path: Path) -> None:
    m = Msgs(typestore(False), False)
    msg = m.odom(T0_NS, Pose2D(x=1e200, y=0.0, yaw=0.0))
    with pytest.raises(ValueError, match=r"topic '/odom': odometry position \(1e\+200, 0\) m is beyond"):
        odometry_pose_from_msg(msg, topic="/odom")
    assert odometry_pose_from_msg(m.odom(T0_NS, MOUNT), topic="/odom")[0].x == pytest.approx(MOUNT.x)


def test_zero_quaternion_in_odometry_or_tf_is_refused_naming_the_topic() -> None:
    from pfpeople.io.bag.tf import TfBuffer

    m = Msgs(typestore(False), False)
    msg = m.odom(T0_NS, MOUNT)
    q = msg.pose.pose.orientation
    q.x = q.y = q.z = q.w = 0.0
    with pytest.raises(
        ValueError, match=r"topic '/odom': odometry: orientation quaternion \(0\.0, 0\.0, 0\.0, 0\.0\) is zero"
    ):
        odometry_pose_from_msg(msg, topic="/odom")  # a MessageDataError: the run counts it and does not use it
    tf = m.tf(T0_NS, "base_link", "laser", MOUNT)
    rot = tf.transforms[0].transform.rotation
    rot.x = rot.y = rot.z = rot.w = 0.0
    buf = TfBuffer()
    with pytest.raises(ValueError, match=r"topic '/tf_static': transform base_link -> laser: .* is zero \(never set\)"):
        buf.add_message(tf, topic="/tf_static")
    rot.w = math.nan
    with pytest.raises(ValueError, match=r"topic '/tf': transform base_link -> laser: .* is not finite"):
        buf.add_message(tf)
    assert buf.frames == []  # nothing was added
    ok = m.tf(T0_NS, "base_link", "laser", MOUNT)
    assert buf.add_message(ok) == 1 and buf.lookup("base_link", "laser").yaw == pytest.approx(MOUNT.yaw)


def test_laser_from_msg_nan_range_max_names_the_topic() -> None:
    m = Msgs(typestore(False), False)
    msg = m.scan(T0_NS, np.ones(10), -0.5, 0.1)
    msg.range_max = math.nan
    with pytest.raises(ValueError, match=r"topic '/front': LaserScan at stamp .* NaN bound"):
        laser_from_msg(msg, stamp_ns=T0_NS, frame_id="laser", topic="/front")


def test_run_directory_errors_name_the_file(tmp_path: Path) -> None:
    bag = tmp_path / "r.bag"
    write_scan_bag(bag, 4)
    out = tmp_path / "run"
    with BagSource(bag) as src:
        Pipeline(legs_only()).run(src, out)
    meta = json.loads((out / "run.json").read_text())
    assert not list(out.glob(".run.json.*"))  # the atomic replacement leaves no temporary file
    del meta["grid"]
    (out / "run.json").write_text(json.dumps(meta))
    with pytest.raises(ValueError, match=r"run\.json': key 'grid' must be an object"):
        load_run(out)
    (out / "run.json").write_text("{not json")
    with pytest.raises(ValueError, match=r"run\.json' is not valid JSON"):
        load_run(out)


def test_frame_assembler_outliers_steps_and_the_end_of_the_stream() -> None:
    from pfpeople.io.bag.reader import BagMessage
    from pfpeople.io.bag.sync import FrameAssembler

    hour = 3600 * 10**9

    def stream(jumps: dict[int, int], n: int = 8) -> tuple[list[int], FrameAssembler]:
        sync = FrameAssembler("/scan", {}, tolerance_ns=10**7)
        frames = []
        for k in range(n):
            t = T0_NS + k * 10**8
            frames += sync.push(BagMessage("/scan", "t", k, t, t + jumps.get(k, 0), "laser", None))
        frames += sync.finish()
        return [f.driver.index for f in frames], sync

    # two consecutive outliers: both skipped, the run goes on
    got, sync = stream({2: hour, 3: hour})
    assert got == [0, 1, 4, 5, 6, 7] and sync.skipped_driver_messages == {"clock_jump": 2}
    # an outlier and then one far the other way: both skipped
    got, sync = stream({2: hour, 3: -hour})
    assert got == [0, 1, 4, 5, 6, 7] and sync.stats["clock_jump"] == {"/scan": 2}
    # a held message at the very end has nothing to tell it an outlier: it is released, not lost
    got, sync = stream({7: hour})
    assert got == list(range(8)) and sync.stats["clock_jump"] == {}
    # a clock stepping backwards for good cannot be followed: skipped as non-monotonic, counted
    got, sync = stream({k: -hour for k in range(4, 8)})
    assert got == [0, 1, 2, 3] and sync.skipped_driver_messages == {"non_monotonic": 4}


@pytest.mark.realdata
def test_rewritten_training_bags_with_gaps_in_their_stamps_lose_no_frame(shared_data: Path) -> None:
    bag = shared_data / "leg_tracker" / "positive_1_extracted.bag"
    if not bag.is_file():
        pytest.skip(f"{bag.name} is absent")
    det = DetectorConfig(name="l", kind="leg", topic="/training_scan")
    cfg = BagConfig(driver="/training_scan", detectors=(det,), grid=GridSpec(nx=6, ny=6, resolution=0.5, y0=-1.5))
    with BagSource(bag) as src:
        summary, _ = Pipeline(cfg).run(src, None)
    # Stamps advance 0.133 s per scan, record times 1 ms, with three gaps of 7-10 s in the stamps (measured):
    # followed as clock steps, every scan is a frame.
    assert summary.frames == 197 and summary.sync["resync"] == {"/training_scan": 3}
    assert summary.sync["clock_jump"] == {} and summary.sync["non_monotonic"] == {}


@pytest.mark.parametrize("two_processes", [False, True])
def test_an_odometry_jump_in_a_bag_restarts_the_filter_and_is_in_run_json(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture, two_processes: bool
) -> None:
    """Issue 27: odometry relocalised by 100 m at 1 s was taken as a 1000 m/s motion (no warning, no count)."""
    import bag_fixtures as scene

    smooth = scene.base_pose
    monkeypatch.setattr(scene, "base_pose", lambda t: replace(smooth(t), x=smooth(t).x + 100.0 * (t >= 1.0)))
    bag = tmp_path / "jump.bag"
    write_bag(bag, n_scans=20)
    with BagSource(bag) as src, caplog.at_level(logging.WARNING):
        summary, _ = Pipeline(config(), front_process=two_processes).run(src, tmp_path / "run")
    assert (summary.odometry_jumps, summary.filter_restarts) == (1, 1)
    stats = load_run(tmp_path / "run").meta["stats"]
    assert (stats["odometry_jumps"], stats["filter_restarts"], stats["odometry_other_child"]) == (1, 1, 0)
    assert "topic '/odom': odometry jumps by 100 m and 0.015 rad in 0.100 s before frame 10" in caplog.text


@pytest.mark.parametrize("two_processes", [False, True])
def test_a_panning_mount_is_warned_once_naming_the_tf_edge_and_counted(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, two_processes: bool
) -> None:
    """Issue 27: a mount whose TF changes during the run (a panning laser) was used at its first value, silently.

    The change is warned once naming the edge and counted per edge in ``stats.mount_changes``; the run follows
    it (``tests/pfpeople/pipeline/test_reliability_mounts.py``).
    """
    bag = tmp_path / "pan.bag"
    write_scan_bag(bag, 30, tf_mount=lambda k: Pose2D(x=0.2, y=0.1, yaw=0.3 + (0.05 if k >= 20 else 0.0)))
    with BagSource(bag) as src, caplog.at_level(logging.WARNING):
        summary, _ = Pipeline(legs_only(), front_process=two_processes).run(src, tmp_path / "run")
    assert summary.mount_changes == {"base_link -> laser": 10}
    assert load_run(tmp_path / "run").meta["stats"]["mount_changes"] == {"base_link -> laser": 10}
    warned = [r.getMessage() for r in caplog.records if "changes during the run" in r.getMessage()]
    assert len(warned) == 1 and "TF base_link -> laser (topic '/tf')" in warned[0]
    assert "0.05 rad" in warned[0] and "The run follows it" in warned[0]
    still = tmp_path / "still.bag"  # 5 mm and 5 mrad of jitter: below 1 cm / 0.01 rad
    write_scan_bag(still, 10, tf_mount=lambda k: Pose2D(x=0.2 + 0.005 * (k % 2), y=0.1, yaw=0.3 + 0.005 * (k % 2)))
    with BagSource(still) as src:
        summary, _ = Pipeline(legs_only()).run(src, None)
    assert summary.mount_changes == {}
