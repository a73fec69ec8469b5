"""Scan-level simulator (evaluation.scenarios.scan): ray caster, legs, odometry, scenes, bags, end to end.

Reference values are worked by hand in the comments; statistical checks state their tolerance.
"""

from __future__ import annotations

import argparse
import csv
import math
import shlex
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from evaluation.commands import simulate_bag
from evaluation.scenarios.robot import integrate_path
from evaluation.scenarios.scan import (
    GaitParams,
    LaserConfig,
    OdometryNoise,
    PeopleConfig,
    RobotRoute,
    SceneConfig,
    beam_angles,
    builtin_scan_scenes,
    cast_rays,
    leg_positions,
    load_scene,
    measure_ranges,
    simulate_scene,
    write_scene_bag,
)
from evaluation.scenarios.scan.route import integrate_controls, odometry_from_controls
from evaluation.scenarios.scan.simulate import to_frame
from pfpeople.config import load_config
from pfpeople.io.bag.reader import BagSource, laser_from_msg, odometry_pose_from_msg, positions_from_msg
from pfpeople.io.bag.tf import yaw_from_quaternion
from pfpeople.io.ground_truth import read_gt_csv
from pfpeople.pipeline.runner import Pipeline

# -- ray caster --------------------------------------------------------------------------------------------------


def test_beam_at_circle_wall_and_nothing() -> None:
    a = np.array([0.0, math.pi / 2, math.pi, -math.pi / 2])
    # circle r = 0.1 at d = 3 ahead -> 2.9; wall y = 2 from x = -1 to 1 -> 2.0 at +90 deg; behind nothing -> inf;
    # -90 deg: circle of r = 0.5 at distance 4 -> 3.5 (the near one of the two on that bearing)
    circles = [(3.0, 0.0, 0.1), (0.0, -4.0, 0.5), (0.0, -6.0, 0.5)]
    segments = [(-1.0, 2.0, 1.0, 2.0)]
    r, hit = cast_rays(a, circles=circles, segments=segments)
    np.testing.assert_allclose(r, [2.9, 2.0, np.inf, 3.5], atol=1e-12)
    assert hit.tolist() == [0, 3, -1, 1]
    # a beam grazing the circle's edge: b = 3 cos(a), disc = 9 cos^2 a - 8.99 = 0 at sin(a) = 0.1 / 3
    graze = math.asin(0.1 / 3.0)
    r2, _ = cast_rays([graze - 1e-4, graze + 1e-4], circles=[(3.0, 0.0, 0.1)])
    assert math.isfinite(r2[0]) and r2[1] == math.inf
    # the same answers on an evenly spaced laser (the windowed fast path) as beam by beam
    beams = beam_angles(-math.pi, math.pi, 721)
    fast, fh = cast_rays(beams, circles=circles, segments=segments)
    slow, sh = zip(*(cast_rays([b], circles=circles, segments=segments) for b in beams), strict=True)
    np.testing.assert_allclose(fast, np.concatenate(slow))
    assert fh.tolist() == np.concatenate(sh).tolist()


def test_windowed_caster_equals_brute_force_on_random_scenes() -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        beams = beam_angles(-2.356, 2.356, 768)
        circles = np.column_stack((rng.uniform(-8, 8, (40, 2)), rng.uniform(0.02, 0.5, 40)))
        segments = rng.uniform(-8, 8, (30, 4))
        fast, fh = cast_rays(beams, circles=circles, segments=segments)
        uneven = np.append(beams, beams[0])  # not evenly spaced: every pair is tested
        slow, sh = cast_rays(uneven, circles=circles, segments=segments)
        np.testing.assert_allclose(fast, slow[:-1])
        assert np.array_equal(fh, sh[:-1])


@pytest.mark.parametrize(("kind", "expect"), [("inf", math.inf), ("above_max", 11.0)])
def test_measured_ranges_noise_dropout_and_codes(kind: str, expect: float) -> None:
    rng = np.random.default_rng(0)
    true = np.full(20000, 5.0)
    true[:10] = np.inf
    true[10:20] = 12.0  # beyond range_max = 10
    true[20:30] = 0.01  # closer than range_min = 0.05
    r = measure_ranges(true, range_min=0.05, range_max=10.0, noise_sd=0.02, dropout=0.1, no_return=kind, rng=rng)
    assert np.all(r[:20] == expect)
    assert np.all(r[20:30][r[20:30] != expect] == -math.inf)
    body = r[30:]
    lost = body == expect
    assert abs(lost.mean() - 0.1) < 0.01  # binomial sd 0.002
    assert abs(np.std(body[~lost]) - 0.02) < 0.001 and abs(np.mean(body[~lost]) - 5.0) < 0.001
    nan = measure_ranges([np.inf], range_min=0.0, range_max=1.0, noise_sd=0.0, dropout=0.0, no_return="nan", rng=rng)
    assert math.isnan(nan[0])
    with pytest.raises(ValueError, match="no_return"):
        measure_ranges([1.0], range_min=0.0, range_max=1.0, noise_sd=0.0, dropout=0.0, no_return="max", rng=rng)


def test_one_leg_hides_the_other() -> None:
    beams = beam_angles(-math.pi / 2, math.pi / 2, 721)  # 0.25 deg
    r_leg = 0.06
    # legs one behind the other on the line of sight: the far leg gets no beam
    behind = [(2.0, 0.0, r_leg), (2.3, 0.0, r_leg)]
    _, hit = cast_rays(beams, circles=behind)
    # near leg: 2 asin(0.06 / 2) = 3.44 deg -> about 13-14 beams of 0.25 deg
    assert 12 <= np.count_nonzero(hit == 0) <= 15
    assert np.count_nonzero(hit == 1) == 0
    # side by side 0.2 m apart: both legs fully visible
    side = [(2.0, 0.1, r_leg), (2.0, -0.1, r_leg)]
    _, hit = cast_rays(beams, circles=side)
    assert np.count_nonzero(hit == 0) >= 12 and np.count_nonzero(hit == 1) >= 12
    # half hidden: the far leg shifted 0.09 m sideways shows only its uncovered part
    half = [(2.0, 0.0, r_leg), (2.3, 0.09, r_leg)]
    _, hit = cast_rays(beams, circles=half)
    assert 1 <= np.count_nonzero(hit == 1) <= 8


# -- gait --------------------------------------------------------------------------------------------------------


def test_gait_separation_midpoint_stride_and_frequency() -> None:
    gait = GaitParams()
    t = np.arange(0.0, 20.0, 0.01)
    speed = 1.3
    centres = np.column_stack((speed * t, np.full(t.size, 1.0)))  # walking along +x
    legs = leg_positions(t, centres, params=gait, hip_width=0.18, phase0=0.3)
    np.testing.assert_allclose(0.5 * (legs[:, 0] + legs[:, 1]), centres, atol=1e-12)
    sep = legs[:, 0] - legs[:, 1]
    # lateral separation = hip width; along-track separation oscillates in [-A, A], A = 0.27 * 1.3 = 0.351 m
    np.testing.assert_allclose(sep[:, 1], 0.18, atol=1e-9)
    amp = 0.27 * 1.3
    assert np.max(np.abs(sep[:, 0])) == pytest.approx(amp, abs=2e-3)
    dist = np.hypot(sep[:, 0], sep[:, 1])
    assert dist.min() >= 0.18 - 1e-9 and dist.max() <= math.hypot(amp, 0.18) + 1e-9
    # each leg swings A peak to peak about the centre; one gait cycle = two steps at f = 1.35 + 0.45 * 1.3 Hz
    swing = legs[:, 0, 0] - centres[:, 0]
    assert np.ptp(swing) == pytest.approx(amp, abs=2e-3)
    crossings = np.count_nonzero(np.diff(np.sign(swing[1:-1])) != 0)
    steps_per_s = crossings / 20.0
    assert steps_per_s == pytest.approx(1.35 + 0.45 * 1.3, abs=0.1)


def test_gait_standing_legs_side_by_side_and_absent_rows() -> None:
    gait = GaitParams()
    t = np.arange(0.0, 4.0, 0.1)
    centres = np.full((t.size, 2), np.nan)
    centres[5:30] = (2.0, 3.0)  # present and standing from sample 5 to 29
    legs = leg_positions(t, centres, params=gait, hip_width=0.2, heading0=math.pi / 2)
    assert np.all(np.isnan(legs[:5])) and np.all(np.isnan(legs[30:]))
    # heading +y: legs side by side along x, 0.2 m apart, centred on the person
    np.testing.assert_allclose(legs[5:30, 0], np.tile([1.9, 3.0], (25, 1)), atol=1e-12)
    np.testing.assert_allclose(legs[5:30, 1], np.tile([2.1, 3.0], (25, 1)), atol=1e-12)
    with pytest.raises(ValueError, match="contiguous"):
        bad = centres.copy()
        bad[10] = np.nan
        leg_positions(t, bad, params=gait, hip_width=0.2)
    with pytest.raises(ValueError, match=r"GaitParams\.hip_width_min"):
        GaitParams(hip_width_min=0.3, hip_width_max=0.2)


# -- odometry ----------------------------------------------------------------------------------------------------


def test_vectorised_integration_equals_the_step_by_step_path() -> None:
    rng = np.random.default_rng(5)
    v, w = rng.uniform(0.0, 0.8, 200), rng.uniform(-1.0, 1.0, 200)
    w[::7] = 0.0  # straight steps too
    np.testing.assert_allclose(
        integrate_controls(v, w, 0.02, start=(1.0, -2.0, 0.4)),
        integrate_path(v, w, 0.02, start=(1.0, -2.0, 0.4)),
        atol=1e-9,
    )


def test_odometry_drift_statistics() -> None:
    """Straight drive at v = 0.5 m/s for N = 250 steps of 0.02 s with the velocity-model noise only:
    var(along-track error) = N dt^2 alpha1 v^2 and var(yaw error) = N dt^2 alpha3 v^2 (sums of independent steps).
    With 300 runs the sample variance has a relative sd of sqrt(2 / 300) = 8 %: tolerance 30 %."""
    noise = OdometryNoise(
        alpha1=0.01, alpha2=0.0, alpha3=0.02, alpha4=0.0, scale_sd_v=0.0, scale_sd_w=0.0, yaw_bias_sd=0.0, slip=0.0
    )
    n, dt, v = 250, 0.02, 0.5
    rng = np.random.default_rng(7)
    ends = np.array(
        [
            odometry_from_controls(np.full(n, v), np.zeros(n), dt, noise=noise, start=(0.0, 0.0, 0.0), rng=rng)[0][-1]
            for _ in range(300)
        ]
    )
    steps = n - 1  # control 0 is dropped: the odometry starts at rest
    true_x = v * dt * steps
    var_x = steps * dt**2 * noise.alpha1 * v**2
    var_yaw = steps * dt**2 * noise.alpha3 * v**2
    assert np.var(ends[:, 0] - true_x) == pytest.approx(var_x, rel=0.3)
    assert np.var(ends[:, 2]) == pytest.approx(var_yaw, rel=0.3)
    assert abs(np.mean(ends[:, 0] - true_x)) < 3 * math.sqrt(var_x / 300)
    # a systematic scale error makes the distance error grow with the distance driven
    scaled = OdometryNoise(
        alpha1=0.0, alpha2=0.0, alpha3=0.0, alpha4=0.0, scale_sd_v=0.05, scale_sd_w=0.0, yaw_bias_sd=0.0, slip=0.0
    )
    errs = [
        odometry_from_controls(np.full(n, v), np.zeros(n), dt, noise=scaled, start=(0, 0, 0), rng=rng)[0][-1, 0]
        - true_x
        for _ in range(200)
    ]
    assert np.std(errs) == pytest.approx(0.05 * true_x, rel=0.3)


def test_robot_route_stays_near_waypoints_and_odometry_drifts() -> None:
    sim = simulate_scene("wheelchair", frames=150, seed=1)
    route = sim.config.robot
    speeds = np.hypot(*np.diff(sim.robot[:, :2], axis=0).T) / np.diff(sim.step_times)
    assert speeds.max() <= route.v_max + 1e-6
    assert np.all((sim.robot[:, 0] > 0.3) & (sim.robot[:, 0] < 9.7) & (sim.robot[:, 1] > 0.3) & (sim.robot[:, 1] < 7.7))
    assert np.ptp(np.unwrap(sim.robot[:, 2])) > math.pi / 2  # it turns
    # the odometry starts at the origin and follows the true motion up to a small drift
    rel_true = to_frame(sim.robot[:, :2], sim.robot[0])
    drift = np.hypot(*(sim.odom[:, :2] - rel_true).T)
    assert drift[0] == 0.0 and 0.0 < drift[-1] < 0.05 * float(np.sum(speeds) * (sim.step_times[1]))


# -- scenes ------------------------------------------------------------------------------------------------------


def test_builtin_scenes_and_config_errors(tmp_path: Path) -> None:
    assert {"wheelchair", "crowd", "corridor"} <= set(builtin_scan_scenes())
    wc = load_scene("wheelchair")
    las = wc.lasers[0]
    assert (las.n_beams, las.rate_hz) == (768, 7.5)
    assert las.mount == pytest.approx((0.85, 0.24, math.radians(42.0)))
    assert math.degrees(las.angle_max - las.angle_min) == pytest.approx(270.0)
    assert wc.static_circles().shape[0] == 4 * (len(wc.chairs) + len(wc.tables)) + len(wc.poles)
    with pytest.raises(ValueError, match="no built-in scan scene 'nope'"):
        load_scene("nope")
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\n[[lasers]]\nrate_hz = -1.0\n')
    with pytest.raises(ValueError, match=r"bad.toml.*LaserConfig.rate_hz"):
        load_scene(bad)
    bad.write_text('name = "x"\n[robot]\nspeed = 1.0\n')
    with pytest.raises(ValueError, match=r"unknown keys \['speed'\] in \[robot\]"):
        load_scene(bad)
    with pytest.raises(ValueError, match=r"PeopleConfig\.source"):
        PeopleConfig(source="zombies")
    with pytest.raises(TypeError, match=r"LaserConfig\.n_beams"):
        LaserConfig(n_beams=1.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="topics and frames must be unique"):
        SceneConfig(name="x", lasers=(LaserConfig(), LaserConfig(topic="/scan2")))


def test_scan_points_land_on_the_world_through_the_mount() -> None:
    """Without people every returned beam, mapped by the laser's true world pose (base pose composed with the
    yawed, offset mount), lies on a wall, table leg, chair leg, pole or box edge: within 5 sd of the noise (mixed
    pixels, which lie between two surfaces by design, off)."""
    cfg = load_scene("wheelchair")
    # all beams at the stamp (no sweep), so one pose per scan maps them
    las0 = replace(cfg.lasers[0], sweep=False, mixed_pixel=0.0)
    cfg = replace(cfg, people=replace(cfg.people, source="none"), lasers=(las0,))
    sim = simulate_scene(cfg, frames=12, seed=2)
    rec = sim.lasers[0]
    las = rec.laser
    circles, segments = cfg.static_circles(), cfg.static_segments()
    angles = beam_angles(las.angle_min, las.angle_max, las.n_beams)
    n_points = 0
    for k in range(0, 12, 3):
        r = rec.ranges[k].astype(float)
        ok = np.isfinite(r) & (r >= las.range_min) & (r <= las.range_max)
        x, y, yaw = rec.poses[k]
        pts = np.column_stack(
            (x + r[ok] * np.cos(angles[ok] + yaw), y + r[ok] * np.sin(angles[ok] + yaw))
        )  # laser frame -> world
        d_c = np.abs(np.hypot(pts[:, None, 0] - circles[:, 0], pts[:, None, 1] - circles[:, 1]) - circles[:, 2])
        p0, e = segments[:, :2], segments[:, 2:] - segments[:, :2]
        s = np.clip(np.einsum("nsk,sk->ns", pts[:, None, :] - p0, e) / np.einsum("sk,sk->s", e, e), 0.0, 1.0)
        d_s = np.linalg.norm(pts[:, None, :] - (p0 + s[..., None] * e), axis=-1)
        dist = np.minimum(d_c.min(axis=1), d_s.min(axis=1))
        assert np.all(dist < 5 * las.noise_sd + 1e-4)
        n_points += int(ok.sum())
    # a closed room: every beam returns except dropouts (0.2 %) and beams below range_min
    assert n_points > 0.98 * 4 * las.n_beams


# -- bags --------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("fmt", "storage"), [("ros1", "sqlite3"), ("ros2", "sqlite3"), ("ros2", "mcap")])
def test_bag_round_trip(tmp_path: Path, fmt: str, storage: str) -> None:
    frames = 8
    out = write_scene_bag("wheelchair", tmp_path, frames=frames, seed=4, fmt=fmt, storage=storage)
    sim = simulate_scene("wheelchair", frames=frames, seed=4)  # same seed, same scene
    rec = sim.lasers[0]
    las = rec.laser
    assert out.bag == tmp_path / ("wheelchair.bag" if fmt == "ros1" else "wheelchair")
    with BagSource(out.bag) as src:
        assert src.topics["/scan"] == "sensor_msgs/msg/LaserScan"
        assert src.topics["/ground_truth_people"] == "geometry_msgs/msg/PoseArray"
        counts = src.message_counts
        assert counts["/scan"] == frames and counts["/ground_truth_people"] == frames
        assert counts["/odom"] == counts["/tf"] == sim.step_times.size and counts["/tf_static"] == 1
        scans = list(src.messages(["/scan"]))
        gts = list(src.messages(["/ground_truth_people"]))
        static = next(iter(src.messages(["/tf_static"])))
        odoms = list(src.messages(["/odom"]))
    for k, m in enumerate(scans):
        scan = laser_from_msg(m.msg, stamp_ns=m.stamp_ns, frame_id=m.frame_id, topic=m.topic)
        assert scan.stamp_ns == int(rec.stamps_ns[k]) and scan.frame_id == "laser"
        assert scan.angle_increment == pytest.approx(las.angle_increment)
        assert scan.ranges.size == 768 and scan.range_max == 25.0
        np.testing.assert_array_equal(scan.ranges, rec.ranges[k].astype(float))
        assert m.bag_time_ns > m.stamp_ns
    assert rec.stamps_ns[1] - rec.stamps_ns[0] == round(1e9 / 7.5)
    for k, m in enumerate(gts):
        assert m.stamp_ns == int(rec.stamps_ns[k]) and m.frame_id == "laser"
        np.testing.assert_allclose(positions_from_msg(m.msg), sim.gt_xy[sim.gt_scan == k], atol=1e-9)
    (tf,) = static.msg.transforms
    q, tr = tf.transform.rotation, tf.transform.translation
    assert (tf.header.frame_id, tf.child_frame_id) == ("base_link", "laser")
    assert (tr.x, tr.y, yaw_from_quaternion(q.x, q.y, q.z, q.w)) == pytest.approx(las.mount, abs=1e-9)
    pose, child = odometry_pose_from_msg(odoms[-1].msg)
    assert child == "base_link" and odoms[-1].frame_id == "odom"
    assert (pose.x, pose.y) == pytest.approx(tuple(sim.odom[-1, :2]), abs=1e-9)
    # the GT CSV reads back with pfpeople.io.ground_truth: rows in the laser frame, keyed by scan index
    gt = read_gt_csv(out.gt_csv)
    assert gt.key == "scan_index" and gt.frame == "laser" and len(gt) == sim.gt_scan.size
    np.testing.assert_allclose(gt.xy, sim.gt_xy, atol=1e-4)
    # people in the GT are within the laser's FOV and range
    ang = np.arctan2(gt.xy[:, 1], gt.xy[:, 0])
    assert np.all((ang >= las.angle_min) & (ang <= las.angle_max) & (np.hypot(*gt.xy.T) <= las.range_max))
    cfg = load_config(out.run_toml)
    assert cfg.driver == "/scan" and cfg.odometry == "/odom"
    assert [(d.name, d.kind, d.topic) for d in cfg.detectors] == [
        ("laser_legs", "leg", "/scan"),
        ("laser_boosted", "boosted", "/scan"),
        ("laser_single_legs", "single-legs", "/scan"),
    ]
    assert cfg.detectors[0].model.fov_min == pytest.approx(las.angle_min)
    assert cfg.detectors[1].model.max_range == 25.0
    with pytest.raises(FileExistsError, match="already exists"):
        write_scene_bag("wheelchair", tmp_path, frames=2, fmt=fmt, storage=storage)


def test_two_lasers_each_with_its_topic_rate_and_mount(tmp_path: Path) -> None:
    front = LaserConfig(mount=(0.3, 0.0, 0.0), rate_hz=10.0, n_beams=181)
    rear = LaserConfig(topic="/scan_rear", frame_id="laser_rear", mount=(-0.3, 0.1, math.pi), rate_hz=25.0, n_beams=91)
    cfg = SceneConfig(name="two", room=(6.0, 5.0), lasers=(front, rear), people=PeopleConfig(source="none"))
    cfg = replace(cfg, robot=replace(cfg.robot, waypoints=((1.0, 2.5), (5.0, 2.5))))
    out = write_scene_bag(cfg, tmp_path, frames=10, fmt="ros2")
    with BagSource(out.bag) as src:
        counts = src.message_counts
        (static,) = [m.msg for m in src.messages(["/tf_static"])]
        rear_scans = list(src.messages(["/scan_rear"]))
    # 10 scans at 10 Hz span 0.9 s: the 25 Hz laser scans 0.9 * 25 + 1 = 23 times in that time
    assert counts["/scan"] == 10 and counts["/scan_rear"] == 23 and counts["/ground_truth_people"] == 10
    assert {t.child_frame_id: t.transform.translation.x for t in static.transforms} == {
        "laser": 0.3,
        "laser_rear": -0.3,
    }
    assert rear_scans[0].frame_id == "laser_rear" and rear_scans[1].stamp_ns - rear_scans[0].stamp_ns == 40_000_000
    assert load_config(out.run_toml).driver == "/scan"


def test_swept_scan_of_a_spinning_robot_is_distorted_as_predicted() -> None:
    """The robot spins on the spot at |omega| = 0.5 rad/s before a pole 3 m away (world bearing 0). A 5 Hz 360 deg laser
    sweeping from -pi takes the beam at bearing ``a`` ``(a + pi) / (2 pi 5)`` s after the stamp, when the
    laser has turned ``omega * that`` further: the pole appears at ``a = -yaw(stamp) - omega (a + pi) / (10 pi)``
    instead of ``-yaw(stamp)``; 16 blocks quantise the time to about 6 ms (0.003 rad)."""
    las = LaserConfig(n_beams=1441, angle_min=-math.pi, angle_max=math.pi, rate_hz=5.0, noise_sd=0.0)
    route = RobotRoute(waypoints=((0.0, 0.0), (-5.0, 0.0)), start=(0.0, 0.0, 0.0), omega_max=0.5, yaw_accel=100.0)
    cfg = SceneConfig(
        name="spin", poles=((3.0, 0.0, 0.1),), robot=route, lasers=(las,), people=PeopleConfig(source="none")
    )
    assert las.time_increment == 0.0
    swept_las = replace(las, sweep=True)
    assert swept_las.time_increment == pytest.approx(las.angle_increment / (10 * math.pi))
    still = simulate_scene(cfg, frames=3).lasers[0]
    swept = simulate_scene(replace(cfg, lasers=(swept_las,)), frames=3).lasers[0]
    angles = beam_angles(-math.pi, math.pi, 1441)
    omega = float(still.poses[2, 2] - still.poses[1, 2]) * 5.0  # the spin direction is the controller's choice
    assert abs(omega) == pytest.approx(0.5, abs=1e-6)
    for k in (1, 2):
        yaw = float(still.poses[k, 2])
        a_still = float(np.mean(angles[np.isfinite(still.ranges[k])]))
        a_swept = float(np.mean(angles[np.isfinite(swept.ranges[k])]))
        assert a_still == pytest.approx(-yaw, abs=0.005)
        expect = -yaw - omega * (-yaw + math.pi) / (10 * math.pi)
        assert a_swept == pytest.approx(expect, abs=0.006)
        assert abs(a_swept - a_still) > 0.04  # the distortion is real, not rounding


def test_pipeline_leg_detector_finds_simulated_people(tmp_path: Path) -> None:
    """End to end: pfpeople's Pipeline with the written run config on 60 wheelchair scans (8 s, seed 0).

    Measured (swept scans, 2 cm range noise, mixed pixels): a detection within 0.3 m of the people with >= 3 beams
    on their legs, seeds 0 / 1 / 2 / 3: leg detector 0.20 / 0.15 / 0.13 / 0.16 (the curvature test fails on
    small legs at this noise), boosted detector (trained with noise) 0.46 / 0.46 / 0.41 / 0.44, single legs
    0.27 / 0.28 / 0.29 / 0.29, any of the three 0.74 / 0.75 / 0.71 / 0.75. Misses: far people have too few
    beams (4 beams need a range below ~4.5 m at 0.35 deg per beam). The mount comes from /tf_static."""
    out = write_scene_bag("wheelchair", tmp_path, frames=60, seed=0)
    pipe = Pipeline(load_config(out.run_toml))
    with BagSource(out.bag) as src:
        summary, results = pipe.run(src, None, keep=True)
    assert summary.frames == 60 and summary.frames_without_odometry == 0
    with BagSource(out.bag) as src:
        mount = Pipeline(load_config(out.run_toml)).prepare(src).lookup("base_link", "laser")
    assert (mount.x, mount.y, mount.yaw) == pytest.approx((0.85, 0.24, math.radians(42.0)), abs=1e-6)
    found = np.zeros(4)  # legs, boosted, single legs, any
    visible = 0
    with out.gt_csv.open() as fh:
        for row in csv.DictReader(fh):
            if int(row["hit_beams"]) < 3:
                continue
            visible += 1
            xy = np.array([float(row["x_laser_m"]), float(row["y_laser_m"])])
            hits = [
                d is not None and len(d) > 0 and bool(np.min(np.linalg.norm(d - xy, axis=1)) < 0.3)
                for d in results[int(row["scan_index"])].detections
            ]
            found += [*hits, any(hits)]
    assert visible > 100
    rates = found / visible
    assert 0.1 <= rates[0] <= 0.35 and 0.3 <= rates[1] <= 0.6 and 0.15 <= rates[2] <= 0.4
    assert 0.6 <= rates[3] <= 0.9 and rates[3] >= rates[:3].max() + 0.2


def test_simulate_bag_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # the subcommand's own parser (evaluation.cli discovers the module; building every command's parser
    # imports the whole evaluation package, which costs seconds)
    parser = argparse.ArgumentParser()
    simulate_bag.add_parser(parser.add_subparsers())
    argv = ["simulate-bag", "corridor", "--out", str(tmp_path), "--frames", "6", "--no-progress", "--format", "ros2"]
    args = parser.parse_args([*argv, "--storage", "mcap"])
    assert args.func(args) == 0
    text = capsys.readouterr().out
    assert "6 scans of /scan" in text and "people per scan" in text
    assert (tmp_path / "corridor" / "metadata.yaml").is_file()
    assert (tmp_path / "corridor_gt.csv").is_file() and (tmp_path / "corridor.toml").is_file()
    args = parser.parse_args(argv)
    with pytest.raises(FileExistsError, match="already exists"):  # refused before simulating
        args.func(args)
    with pytest.raises(ValueError, match="--frames must be >= 1"):
        args = parser.parse_args([*argv[:5], "0"])
        args.func(args)


def test_simulate_bag_next_commands_quote_paths(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    parser = argparse.ArgumentParser()
    simulate_bag.add_parser(parser.add_subparsers())
    out = tmp_path / "my runs"
    args = parser.parse_args(["simulate-bag", "corridor", "--out", str(out), "--frames", "2", "--no-progress"])
    assert args.func(args) == 0
    lines = capsys.readouterr().out.splitlines()
    run = shlex.split(next(t for t in lines if t.startswith("next: ")).removeprefix("next: "))
    assert run[run.index("--config") + 1] == str(out / "corridor.toml") and (out / "corridor.toml").is_file()
    score = shlex.split(next(t for t in lines if "pfpeople-eval score" in t))
    assert score[score.index("--gt") + 1] == str(out / "corridor_gt.csv")
