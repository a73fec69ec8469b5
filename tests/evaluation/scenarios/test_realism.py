"""Real-laser realism of the simulator (issue 24) and what the front end does with it: mixed pixels, the
no-return codes, standing people who shuffle, odometry drift; free space along no-return beams in the
static-clutter map."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from evaluation.scenarios.scan.raycast import measure_ranges
from evaluation.scenarios.scan.route import odometry_from_controls
from evaluation.scenarios.scan.scene import OdometryNoise, PeopleConfig, load_scene
from evaluation.scenarios.scan.simulate import simulate_scene
from evaluation.scenarios.scan.standing import standing_tracks
from pfpeople.detect.synthetic import render_scan
from pfpeople.perception.clutter_map import ClutterConfig, StaticClutterMap
from pfpeople.sensors import LaserScan

# -- simulator -----------------------------------------------------------------------------------------------


def test_mixed_pixels_lie_between_the_surfaces_at_the_stated_rate() -> None:
    """A step edge 2 m -> 5 m every 10 beams: with ``mixed_pixel = 0.5`` half of the edge beams (either side of
    each step) report a range strictly between 2 and 5 m (binomial, 398 edge beams: sd 0.025; tolerance 0.08);
    beams away from an edge and beams next to a no-return beam keep their surface."""
    true = np.tile(np.r_[np.full(10, 2.0), np.full(10, 5.0)], 100)
    true[-1] = np.inf
    rng = np.random.default_rng(3)
    out = measure_ranges(true, range_min=0.05, range_max=10.0, noise_sd=0.0, dropout=0.0, mixed_pixel=0.5, rng=rng)
    edge = np.zeros(true.size, dtype=bool)
    step = np.flatnonzero(np.abs(np.diff(true[:-1])) > 0.1)
    edge[step] = edge[step + 1] = True
    between = (out > 2.0 + 1e-9) & (out < 5.0 - 1e-9)
    assert np.mean(between[edge]) == pytest.approx(0.5, abs=0.08)
    assert not between[~edge].any()
    assert out[-2] == 5.0 and math.isinf(out[-1])
    none = measure_ranges(true, range_min=0.05, range_max=10.0, noise_sd=0.0, dropout=0.0, rng=rng)
    assert np.array_equal(none[:-1], true[:-1])


def test_no_return_at_range_max_is_free_space_for_the_map() -> None:
    """``no_return = "at_max"`` writes exactly range_max, which :attr:`LaserScan.no_return` reads as no return,
    as it does +inf and values above range_max; NaN and -inf (too close) are neither."""
    rng = np.random.default_rng(0)
    r = measure_ranges(
        [np.inf, 3.0], range_min=0.05, range_max=8.0, noise_sd=0.0, dropout=0.0, no_return="at_max", rng=rng
    )
    assert r.tolist() == [8.0, 3.0]
    scan = LaserScan(
        ranges=np.array([np.inf, 8.0, 9.5, 3.0, np.nan, -np.inf]), angle_min=0.0, angle_increment=0.1, range_max=8.0
    )
    assert scan.no_return.tolist() == [True, True, True, False, False, False]
    rays = scan.free_rays(5.0)  # cut at the map's range
    assert rays.shape == (3, 2)
    assert np.allclose(np.hypot(rays[:, 0], rays[:, 1]), 5.0)
    assert np.allclose(np.arctan2(rays[:, 1], rays[:, 0]), [0.0, 0.1, 0.2])


def test_standing_people_shuffle_near_their_spot_and_walk_in_and_out() -> None:
    """A group of 3 from t = 10 s to 40 s in a 10 x 6 m room: each arrives from the border at t = 10 s, stays
    within 0.6 m of its spot while standing (sway sd 0.08 m + shifts of at most 0.4 m each, 0.25 per s) and walks
    out after 40 s; the spots are 0.65 m apart on a circle."""
    rng = np.random.default_rng(1)
    region = (0.0, 10.0, 0.0, 6.0)
    tracks = standing_tracks(
        ((5.0, 3.0, 3, 10.0, 40.0),),
        (),
        region=region,
        speed=1.2,
        duration=60.0,
        first_id=7,
        shuffle_sd=0.08,
        step_rate=0.25,
        rng=rng,
    )
    assert [tr.person_id for tr in tracks] == [7, 8, 9]
    spots = np.array([tr.sample(np.array([10.0]))[0] for tr in tracks])
    gaps = np.hypot(*(spots - np.roll(spots, 1, axis=0)).T)
    assert gaps == pytest.approx(0.65, abs=0.35)  # sway moves the spots by a few cm
    for tr in tracks:
        t = np.linspace(10.0, 40.0, 301)
        xy = tr.sample(t)
        assert np.max(np.hypot(*(xy - xy[0]).T)) < 1.0
        assert tr.t_start < 10.0 and tr.t_end > 40.0
        x0, y0 = tr.xy[0]
        assert min(x0 - region[0], region[1] - x0, y0 - region[2], region[3] - y0) < 1e-9  # enters at the border


def test_scene_gt_speed_tells_standing_from_walking() -> None:
    """The lobby scene's ground truth: its standing people (groups, queue) move at under 0.3 m/s in most of
    their rows; its walkers at 0.5 m/s and more in most of theirs."""
    sim = simulate_scene("lobby", frames=150, seed=0)
    cfg = sim.config
    n_stand = int(sum(g[2] for g in cfg.people.groups) + sum(q[3] for q in cfg.people.queues))
    assert n_stand == 13
    finite = np.isfinite(sim.gt_speed)
    assert finite.mean() > 0.95
    slow = sim.gt_speed[finite] < 0.3
    assert 0.5 < slow.mean() < 1.0  # most rows are standing people, not all


def test_odometry_yaw_bias_and_slip() -> None:
    """Driving straight (w = 0) for 10 s the heading drifts by bias * t: over 400 runs var(yaw) = (sd t)^2
    (tolerance 25 %); slip only acts in turns: turning at 1 rad/s with slip 0.1 the odometry reports 10 % more
    rotation than made."""
    noise = OdometryNoise(
        alpha1=0.0, alpha2=0.0, alpha3=0.0, alpha4=0.0, scale_sd_v=0.0, scale_sd_w=0.0, yaw_bias_sd=0.01, slip=0.1
    )
    n, dt = 501, 0.02
    rng = np.random.default_rng(4)
    yaws = [
        odometry_from_controls(np.full(n, 0.5), np.zeros(n), dt, noise=noise, start=(0, 0, 0), rng=rng)[0][-1, 2]
        for _ in range(400)
    ]
    assert np.var(yaws) == pytest.approx((0.01 * (n - 1) * dt) ** 2, rel=0.25)
    no_bias = replace(noise, yaw_bias_sd=0.0)
    turn = odometry_from_controls(np.zeros(n), np.ones(n), dt, noise=no_bias, start=(0, 0, 0), rng=rng)[0]
    assert turn[-1, 2] == pytest.approx(1.1 * (n - 1) * dt, rel=1e-9)


def test_lobby_scene_config() -> None:
    cfg = load_scene("lobby")
    las = cfg.lasers[0]
    assert las.noise_sd == 0.02 and las.mixed_pixel == 0.3 and las.range_max == 10.0
    assert isinstance(cfg.people, PeopleConfig) and len(cfg.people.groups) == 3 and len(cfg.people.queues) == 1
    with pytest.raises(ValueError, match="t_end must exceed t_start"):
        replace(cfg.people, groups=((1.0, 1.0, 2, 5.0, 5.0),))
    with pytest.raises(ValueError, match="whole number"):
        replace(cfg.people, queues=((1.0, 1.0, 0.0, 2.5, 0.0, 5.0),))


# -- static-clutter map: free space along beams without a return ---------------------------------------------


def _object_after_open_floor(free: bool, *, far_wall: bool = False) -> bool:
    """4 s of open floor seen by beams that return nothing (or a wall 15 m away, beyond the map's 10 m), then a
    small object at 3 m for 1.5 s: is it static? (0.1 s scans, a 0.35 deg laser over +-45 deg)."""
    cfg = ClutterConfig()
    m = StaticClutterMap(cfg)
    wall = [(15.0, -20.0, 15.0, 20.0)] if far_wall else []
    empty = render_scan(
        segments=wall, angle_min=-0.8, angle_max=0.8, angle_increment=math.radians(0.35), range_max=20.0
    )
    obj = render_scan(
        circles=[(3.0, 0.0, 0.06)],
        segments=wall,
        angle_min=-0.8,
        angle_max=0.8,
        angle_increment=math.radians(0.35),
        range_max=20.0,
    )
    for k in range(55):
        scan = empty if k < 40 else obj
        rays = scan.free_rays(cfg.max_range) if free else None
        m.update(scan.points(), dt=0.1, free=rays)
    return bool(m.is_static(np.array([[3.0, 0.0]]))[0])


def test_open_floor_seen_through_no_return_beams_is_free() -> None:
    """Unknown floor (prior 1 s of evidence) makes an object static after 0.6 s; floor seen free by no-return
    beams for 4 s (down to s_min = -1 s) needs 2.6 s: after 1.5 s the object is static only without the rays."""
    assert _object_after_open_floor(False)
    assert not _object_after_open_floor(True)


def test_returns_beyond_the_map_range_free_the_beam_up_to_it() -> None:
    """A wall at 15 m (beyond ``max_range`` = 10 m): its beams cross free floor up to 10 m."""
    assert not _object_after_open_floor(False, far_wall=True)
