"""Sampled people and sensor motion against the analytic models (fixed seeds, tolerances scaling with N)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from gridbridge import GridSpec, Odometry, PeopleMotion, SensorMotionNoise, ego_motion_sigma_points
from pfpeople.particle.predictor.ego import apply_ego_motion, sample_ego_poses
from pfpeople.particle.predictor.paper import move_paper, redraw_in_cells, sample_speeds, sample_velocity_prior
from pfpeople.particle.predictor.persistent import PersistentMotion, move_persistent
from pfpeople.particle.state import ParticleState, uniform_in_cells

N = 200_000


def test_stationary_fraction_and_speed_moments() -> None:
    motion = PeopleMotion()
    rng = np.random.default_rng(1)
    vx, vy = sample_velocity_prior(motion, N, rng=rng)
    speed = np.hypot(vx, vy)
    moving = speed > 0
    frac = 1.0 - moving.mean()
    se = math.sqrt(motion.p_stationary * (1 - motion.p_stationary) / N)
    assert abs(frac - motion.p_stationary) < 5 * se
    # Exact moments of N(mu, sigma) truncated to [0, v_max] (scipy's truncnorm).
    a, b = -motion.mu / motion.sigma, (motion.v_max - motion.mu) / motion.sigma
    tn = stats.truncnorm(a, b, loc=motion.mu, scale=motion.sigma)
    s = speed[moving]
    assert abs(s.mean() - tn.mean()) < 5 * tn.std() / math.sqrt(s.size)
    assert abs(s.std() - tn.std()) < 5 * tn.std() / math.sqrt(2 * s.size) * 1.5
    assert s.min() >= 0.0 and s.max() <= motion.v_max
    # Kolmogorov-Smirnov against the exact CDF, alpha = 1e-3.
    assert stats.kstest(s, tn.cdf).pvalue > 1e-3


def test_speed_sampler_exact_distribution() -> None:
    motion = PeopleMotion(mu=0.5, sigma=1.0, v_max=2.0)  # heavy truncation on both sides
    s = sample_speeds(motion, N, rng=np.random.default_rng(2))
    tn = stats.truncnorm(-0.5, 1.5, loc=0.5, scale=1.0)
    assert stats.kstest(s, tn.cdf).pvalue > 1e-3
    assert abs(s.mean() - tn.mean()) < 5 * tn.std() / math.sqrt(N)


def test_heading_uniform_chi_square() -> None:
    vx, vy = sample_velocity_prior(PeopleMotion(), N, rng=np.random.default_rng(3))
    moving = np.hypot(vx, vy) > 0
    heading = np.arctan2(vy[moving], vx[moving])
    counts, _ = np.histogram(heading, bins=36, range=(-math.pi, math.pi))
    chi2, p = stats.chisquare(counts)
    assert p > 1e-3, chi2


def test_move_paper_displacement_is_velocity_times_dt() -> None:
    rng = np.random.default_rng(4)
    st = ParticleState(x=np.full(1000, 4.0), y=np.zeros(1000), vx=np.zeros(1000), vy=np.zeros(1000), w=np.ones(1000))
    move_paper(st, PeopleMotion(), 0.1, rng=rng)
    np.testing.assert_allclose(st.x - 4.0, st.vx * 0.1, atol=1e-15)
    np.testing.assert_allclose(st.y, st.vy * 0.1, atol=1e-15)


def test_persistent_model_keeps_heading_and_switches_state() -> None:
    motion = PeopleMotion()
    params = PersistentMotion(heading_noise=0.1, speed_noise=0.0, speed_reversion=0.0, p_stop=0.0, p_start=0.0)
    n = 20_000
    st = ParticleState(x=np.zeros(n), y=np.zeros(n), vx=np.full(n, 1.0), vy=np.zeros(n), w=np.ones(n))
    move_persistent(st, motion, params, 0.1, rng=np.random.default_rng(5))
    heading = np.arctan2(st.vy, st.vx)
    # heading sd after one step = heading_noise sqrt(dt); speed unchanged (no speed noise, no stopping).
    assert abs(heading.std() - 0.1 * math.sqrt(0.1)) < 5 * 0.1 * math.sqrt(0.1) / math.sqrt(2 * n)
    np.testing.assert_allclose(np.hypot(st.vx, st.vy), 1.0, rtol=1e-12)
    # Stop / start probabilities per second: per step 1 - (1 - p)^dt.
    params = PersistentMotion(p_stop=0.5, p_start=0.3)
    walk = np.r_[np.full(n, 1.0), np.zeros(n)]
    st = ParticleState(x=np.zeros(2 * n), y=np.zeros(2 * n), vx=walk, vy=np.zeros(2 * n), w=np.ones(2 * n))
    move_persistent(st, motion, params, 0.1, rng=np.random.default_rng(6))
    moving = np.hypot(st.vx, st.vy) > 0
    p_stop, p_start = 1 - 0.5**0.1, 1 - 0.7**0.1
    assert abs((~moving[:n]).mean() - p_stop) < 5 * math.sqrt(p_stop / n)
    assert abs(moving[n:].mean() - p_start) < 5 * math.sqrt(p_start / n)
    with pytest.raises(ValueError, match=r"PersistentMotion\.p_stop"):
        PersistentMotion(p_stop=1.5)


def test_ego_motion_moments_match_sigma_points() -> None:
    odo, dt = Odometry(v=1.0, omega=0.8), 0.1
    noise = SensorMotionNoise(alpha1=0.05, alpha2=0.01, alpha3=0.02, alpha4=0.05, alpha5=0.01, alpha6=0.01)
    poses = sample_ego_poses(odo, dt, noise, N, rng=np.random.default_rng(8))
    sp, w = ego_motion_sigma_points(odo, dt, noise)
    mean_sp = w @ sp
    sd_sp = np.sqrt(w @ (sp - mean_sp) ** 2)
    se = poses.std(axis=0) / math.sqrt(N)
    # Sampling error (5 SE) plus the sigma points' own approximation of a non-linear map (1 % of the sd).
    np.testing.assert_array_less(np.abs(poses.mean(axis=0) - mean_sp), 5 * se + 0.01 * sd_sp)
    np.testing.assert_allclose(poses.std(axis=0), sd_sp, rtol=0.02)


def test_zero_noise_straight_drive_shifts_one_cell() -> None:
    spec = GridSpec()
    dt = 0.1
    odo = Odometry(v=spec.resolution / dt, omega=0.0)
    rng = np.random.default_rng(9)
    cells = rng.integers(spec.ny, spec.n_cells, size=5000)  # not in the first row
    x, y = uniform_in_cells(spec, cells, rng=rng)
    st = ParticleState(x=x, y=y, vx=np.ones(5000), vy=np.zeros(5000), w=np.ones(5000))
    poses = sample_ego_poses(odo, dt, SensorMotionNoise.noiseless(), 5000, rng=rng)
    apply_ego_motion(st, poses)
    np.testing.assert_allclose(st.x - x, -spec.resolution, atol=1e-12)
    np.testing.assert_array_equal(st.y, y)
    np.testing.assert_array_equal(spec.flat_index(st.x, st.y), cells - spec.ny)
    np.testing.assert_array_equal(st.vx, 1.0)


def test_ego_rotation_rotates_positions_and_velocities() -> None:
    st = ParticleState(x=np.array([1.0]), y=np.array([0.0]), vx=np.array([1.0]), vy=np.array([0.0]), w=np.ones(1))
    apply_ego_motion(st, np.array([[0.0, 0.0, math.pi / 2]]))  # robot turns left 90 deg
    np.testing.assert_allclose([st.x[0], st.y[0], st.vx[0], st.vy[0]], [0.0, -1.0, 0.0, -1.0], atol=1e-15)
    for bad in (np.zeros((0, 3)), np.zeros((2, 3)), np.zeros(4)):  # none, more than N, not (S, 3)
        with pytest.raises(ValueError, match=r"poses must have shape \(S, 3\)"):
            apply_ego_motion(st, bad)


def test_redraw_stays_in_cell_and_is_uniform() -> None:
    spec = GridSpec()
    rng = np.random.default_rng(10)
    n = 50_000
    st = ParticleState(x=np.full(n, 1.01), y=np.full(n, 0.02), vx=np.zeros(n), vy=np.zeros(n), w=np.ones(n))
    cell = spec.flat_index(1.01, 0.02)
    redraw_in_cells(st, spec, rng=rng)
    assert np.all(spec.flat_index(st.x, st.y) == cell)
    u, _ = spec.to_fractional(st.x, st.y)
    frac = u - np.floor(u)
    assert stats.kstest(frac, "uniform").pvalue > 1e-3
