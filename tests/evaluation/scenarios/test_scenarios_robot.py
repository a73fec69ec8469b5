"""Robot kinematics of the scenario simulator: speeds, turns, odometry that reproduces the path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from evaluation.scenarios import RobotProfile, Scenario, integrate_path, load_scenario_config, robot_controls
from evaluation.scenarios.robot import noisy_odometry, sensor_to_world, step_pose, world_to_sensor
from gridbridge.ego_motion import velocity_displacement
from gridbridge.params import SensorMotionNoise


def test_controls_respect_the_profile() -> None:
    prof = RobotProfile()
    v, w = robot_controls(3000, 0.1, profile=prof, rng=np.random.default_rng(1))
    assert v[0] == 0.0 and w[0] == 0.0
    assert v.min() >= 0.0 and v.max() <= prof.v_max + 1e-12
    assert np.abs(w).max() <= prof.omega_max + 1e-12
    # acceleration limits hold between frames
    assert np.abs(np.diff(v)).max() <= prof.accel * 0.1 + 1e-12
    assert np.abs(np.diff(w)).max() <= prof.yaw_accel * 0.1 + 1e-12
    # the robot stops, cruises and turns (left and right) somewhere in a long run
    assert np.any(v == 0.0) and v.max() > 0.5
    assert w.min() < -0.2 and w.max() > 0.2


def _euler(v: np.ndarray, w: np.ndarray, dt: float, substeps: int = 2000) -> np.ndarray:
    """Independent reference: fine forward-Euler integration of x' = v cos, y' = v sin, yaw' = w."""
    x = y = th = 0.0
    out = np.empty((v.size, 3))
    h = dt / substeps
    for k in range(v.size):
        for _ in range(substeps):
            x += v[k] * math.cos(th) * h
            y += v[k] * math.sin(th) * h
            th += w[k] * h
        out[k] = (x, y, th)
    return out


def test_integrating_the_odometry_reproduces_the_path() -> None:
    sc = Scenario(load_scenario_config("corridor", n_frames=120, seed=4))
    frames = list(sc)
    v = np.array([f.v for f in frames])
    w = np.array([f.omega for f in frames])
    poses = integrate_path(v, w, sc.dt)
    np.testing.assert_allclose(poses, np.array([f.robot_pose for f in frames]), atol=1e-12)
    assert np.linalg.norm(poses[-1, :2]) > 1.0  # the robot really moved
    assert np.ptp(poses[:, 2]) > 0.1  # and turned
    # against a brute-force integration of the unicycle ODE: the arc model is its exact solution
    ref = _euler(v, w, sc.dt)
    np.testing.assert_allclose(poses, ref, atol=2e-4)


def test_sensor_frame_people_follow_the_filter_ego_motion_convention() -> None:
    """A world-fixed point moves in the sensor frame as p_new = R(-dth) (p_old - t), t from the odometry."""
    sc = Scenario(load_scenario_config("corridor", n_frames=80, seed=2))
    point = np.array([[3.0, 1.0]])
    for k in range(1, len(sc)):
        old = world_to_sensor(point, sc.robot_poses[k - 1])[0]
        new = world_to_sensor(point, sc.robot_poses[k])[0]
        dx, dy, dth = (float(a) for a in velocity_displacement(sc.v[k], sc.omega[k], sc.dt))
        c, s = math.cos(dth), math.sin(dth)
        expect = np.array([c * (old[0] - dx) + s * (old[1] - dy), -s * (old[0] - dx) + c * (old[1] - dy)])
        np.testing.assert_allclose(new, expect, atol=1e-9)


def test_world_sensor_round_trip_and_step_pose() -> None:
    pose = np.array([1.0, -2.0, 0.7])
    pts = np.array([[0.0, 0.0], [3.0, 4.0]])
    np.testing.assert_allclose(sensor_to_world(world_to_sensor(pts, pose), pose), pts, atol=1e-12)
    # a quarter circle of radius 1: v = 1, w = pi/2 for 1 s from the origin ends at (1, 1) facing +y
    np.testing.assert_allclose(step_pose((0, 0, 0), 1.0, math.pi / 2, 1.0), [2 / math.pi, 2 / math.pi, math.pi / 2])


def test_noisy_odometry_statistics() -> None:
    noise = SensorMotionNoise(alpha1=0.01, alpha2=0.0, alpha3=0.02, alpha4=0.0, alpha5=0.0, alpha6=0.0)
    n = 20000
    v = np.full(n, 0.5)
    w = np.zeros(n)
    vo, wo = noisy_odometry(v, w, noise=noise, rng=np.random.default_rng(3))
    # var(v_odom - v) = alpha1 v^2 = 0.0025; sample variance has relative sd sqrt(2/n) = 1 %: 5 % tolerance
    assert np.var(vo - v) == pytest.approx(0.01 * 0.25, rel=0.05)
    assert np.var(wo - w) == pytest.approx(0.02 * 0.25, rel=0.05)
    assert abs(np.mean(vo - v)) < 4 * math.sqrt(0.0025 / n)
    still, _ = noisy_odometry(np.zeros(5), np.zeros(5), noise=noise, rng=np.random.default_rng(3))
    assert np.all(still == 0.0)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"v_max": -0.1}, "v_max"),
        ({"v_min_cruise": 0.9}, "v_min_cruise"),
        ({"accel": 0.0}, "accel"),
        ({"segment_min": 5.0, "segment_max": 1.0}, "segment_min"),
        ({"p_spin": -1.0}, "p_spin"),
        ({"p_cruise": 0.0, "p_curve": 0.0, "p_stop": 0.0, "p_spin": 0.0}, "p_cruise"),
    ],
)
def test_bad_robot_profile_names_the_field(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        RobotProfile(**kwargs)


def test_standing_robot_does_not_move() -> None:
    v, w = robot_controls(50, 0.1, profile=RobotProfile.standing(), rng=np.random.default_rng(0))
    assert np.all(v == 0) and np.all(w == 0)
