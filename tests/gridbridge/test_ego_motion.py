"""Sensor-motion prediction (eqs. 10-11): velocity motion model and the belief warp."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gridbridge import (
    GridSpec,
    Odometry,
    SensorMotionNoise,
    ego_motion_sigma_points,
    predict_sensor,
    velocity_displacement,
    warp_belief,
)
from gridbridge.ego_motion import _sigma_points_cached


def test_velocity_displacement_hand_values() -> None:
    dx, dy, dth = velocity_displacement(1.0, math.pi / 2, 1.0)
    assert (float(dx), float(dy), float(dth)) == pytest.approx((2 / math.pi, 2 / math.pi, math.pi / 2))
    dx, dy, dth = velocity_displacement(0.35, 0.0, 0.1)
    assert (float(dx), float(dy), float(dth)) == pytest.approx((0.035, 0.0, 0.0))
    # Straight-line limit is continuous.
    dx2, dy2, _ = velocity_displacement(0.35, 1e-7, 0.1)
    assert float(dx2) == pytest.approx(0.035, abs=1e-12) and abs(float(dy2)) < 1e-9


def test_whole_cell_translation_without_noise_is_an_exact_shift() -> None:
    spec = GridSpec()
    rng = np.random.default_rng(1)
    bel = rng.random(spec.shape)
    # Drive forward two cells: what was at x is now at x - 0.6 m.
    out = predict_sensor(bel, spec, Odometry(v=6.0, omega=0.0), 0.1, noise=SensorMotionNoise.noiseless())
    np.testing.assert_allclose(out[:-2], bel[2:], rtol=0, atol=1e-12)  # 6.0 * 0.1 = 0.6 + 1 ulp
    np.testing.assert_allclose(out[-2:], 0.5, atol=1e-12)  # entering from outside the grid
    # Sideways: a pure translation of one cell to the left (+y) of the sensor.
    out = warp_belief(bel, spec, [0.0, 0.3, 0.0])
    np.testing.assert_allclose(out[:, :-1], bel[:, 1:], rtol=0, atol=1e-12)


def test_ninety_degree_turn_maps_cells() -> None:
    spec = GridSpec()
    bel = np.zeros(spec.shape)
    bel[7, 18] = 1.0  # centre (2.25, 1.05): ahead and to the left
    out = warp_belief(bel, spec, [0.0, 0.0, math.pi / 2], outside=0.5)
    # After turning left by 90 deg it lies on the right: (1.05, -2.25) = centre of cell [3, 7].
    assert out[3, 7] == pytest.approx(1.0, abs=1e-9)
    assert np.isclose(out[:15, :15], 0.0, atol=1e-9).sum() == 15 * 15 - 1
    # Cells on the left half now look at x < 0 in the old frame, cells beyond x = 4.5 m at y > 4.5 m:
    # both outside the old grid.
    np.testing.assert_allclose(out[:, 15:], 0.5, atol=1e-9)
    np.testing.assert_allclose(out[15:, :15], 0.5, atol=1e-9)


def test_noisy_warp_conserves_mass_away_from_border() -> None:
    spec = GridSpec()
    gx, gy = spec.cell_centres()
    bel = 0.9 * np.exp(-((gx - 5.0) ** 2 + (gy - 0.5) ** 2) / (2 * 0.6**2))
    noise = SensorMotionNoise(alpha1=0.05, alpha2=0.01, alpha3=0.01, alpha4=0.05, alpha5=0.01, alpha6=0.01)
    out = predict_sensor(bel, spec, Odometry(v=0.5, omega=0.4), 0.1, noise=noise, outside=0.0)
    assert out.sum() == pytest.approx(bel.sum(), rel=2e-3)
    # The blob moved towards the robot and to the right: its centroid follows the mean displacement.
    cx = (out * gx).sum() / out.sum()
    assert cx == pytest.approx(5.0 - 0.05, abs=0.02)
    assert out.max() < bel.max()  # noise spreads


def test_sigma_points_match_control_moments() -> None:
    noise = SensorMotionNoise(alpha1=0.04, alpha2=0.0, alpha3=0.0, alpha4=0.0, alpha5=0.0, alpha6=0.0)
    poses, w = ego_motion_sigma_points(Odometry(v=0.5, omega=0.0), 0.1, noise)
    assert w.sum() == pytest.approx(1.0)
    assert poses.shape == (3, 3)  # only v is noisy: centre and two nodes
    mean = w @ poses[:, 0]
    var = w @ (poses[:, 0] - mean) ** 2
    assert mean == pytest.approx(0.05)
    assert var == pytest.approx(0.04 * 0.25 * 0.01)
    poses, w = ego_motion_sigma_points(None, 0.1, SensorMotionNoise())
    np.testing.assert_array_equal(poses, [[0.0, 0.0, 0.0]])  # standing robot: no noise at all


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: warp_belief(np.zeros((3, 3)), GridSpec(), [0, 0, 0]), "belief"),
        (lambda: warp_belief(np.zeros((30, 30)), GridSpec(), [0, np.nan, 0]), "poses"),
        (lambda: warp_belief(np.zeros((30, 30)), GridSpec(), np.zeros((0, 3))), "poses"),  # was ZeroDivisionError
        (lambda: warp_belief(np.zeros((30, 30)), GridSpec(), [0.0, 0.1]), "poses"),
        (lambda: warp_belief(np.zeros((30, 30)), GridSpec(), [[0, 0, 0]], [-1.0]), "weights"),
        (lambda: predict_sensor(np.zeros((30, 30)), GridSpec(), Odometry(v=1.0), -0.1), "dt"),
        (lambda: Odometry(v=math.inf), "Odometry.v"),
        (lambda: SensorMotionNoise(alpha3=-1.0), "alpha3"),
    ],
)
def test_bad_input(call: object, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        call()  # type: ignore[operator]


def _reference_velocity_displacement(v, omega, dt, gamma=0.0, vy=0.0):  # type: ignore[no-untyped-def]
    """The velocity model as written before its sine and cosine were shared (the reference for bit identity)."""
    v, w = np.asarray(v, dtype=float), np.asarray(omega, dtype=float)
    turning = np.abs(w) > 1e-9
    w_safe = np.where(turning, w, 1.0)
    dx = np.where(turning, v / w_safe * np.sin(w * dt), v * dt)
    dy = np.where(turning, v / w_safe * (1.0 - np.cos(w * dt)), 0.0)
    lat = np.asarray(vy, dtype=float)
    if np.any(lat != 0.0):
        dx = dx - np.where(turning, lat / w_safe * (1.0 - np.cos(w * dt)), 0.0)
        dy = dy + np.where(turning, lat / w_safe * np.sin(w * dt), lat * dt)
    dtheta = (w + np.asarray(gamma, dtype=float)) * dt
    return dx, dy, np.broadcast_to(dtheta, np.broadcast(dx, dtheta).shape).copy()


def _reference_sigma_points(odo, dt, noise):  # type: ignore[no-untyped-def]
    """The sigma points as built before (numpy rows, a zero-weight centre dropped by a mask)."""
    variances = noise.variances(odo.v, odo.omega)
    mean = np.array([odo.v, odo.omega, 0.0])
    nodes, weights = [mean], [1.0]
    active = [k for k, var in enumerate(variances) if var > 0.0]
    weights[0] = 1.0 - len(active) / 3.0
    for k in active:
        step = math.sqrt(3.0 * variances[k])
        for sign in (1.0, -1.0):
            node = mean.copy()
            node[k] += sign * step
            nodes.append(node)
            weights.append(1.0 / 6.0)
    controls, w = np.array(nodes), np.array(weights)
    keep = w > 0.0
    controls, w = controls[keep], w[keep]
    dx, dy, dth = _reference_velocity_displacement(controls[:, 0], controls[:, 1], dt, controls[:, 2], vy=odo.vy)
    return np.column_stack((dx, dy, dth)), w / w.sum()


def test_sigma_points_and_velocity_model_are_bit_identical_to_the_reference() -> None:
    """The sigma points are built with Python floats and the velocity model computes its sine and cosine once:
    the same floats as before, bit for bit (straight lines, |omega| at the threshold, no lateral speed, one to
    three noisy controls)."""
    rng = np.random.default_rng(26)
    for _ in range(1500):
        v = float(rng.choice([0.0, -0.0, rng.normal(0.0, 1.0), rng.uniform(-3.0, 3.0)]))
        w = float(rng.choice([0.0, -0.0, 1e-10, 1e-9, -2e-9, rng.normal(0.0, 1.0)]))
        vy = float(rng.choice([0.0, -0.0, rng.normal(0.0, 0.3)]))
        dt = float(rng.choice([0.1, 0.1333333333, rng.uniform(0.001, 1.0)]))
        alphas = {f"alpha{k}": float(rng.choice([0.0, rng.uniform(0.0, 0.01)])) for k in range(1, 7)}
        noise = SensorMotionNoise(**alphas)
        odo = Odometry(v=v, omega=w, vy=vy)
        # uncached: the cache takes Odometry(v=-0.0) for Odometry(v=0.0) (equal), whose poses' zeros differ in sign
        ours, ref = _sigma_points_cached.__wrapped__(odo, dt, noise), _reference_sigma_points(odo, dt, noise)
        for got, want in zip(ours, ref, strict=True):
            assert got.shape == want.shape and got.tobytes() == want.tobytes()
        vv, ww, gg = rng.normal(0.0, 1.0, 7), rng.choice([0.0, 1e-10, 0.5, -2.0], 7), rng.normal(0.0, 0.1, 7)
        for lat in (0.0, vy, rng.normal(0.0, 0.2, 7)):
            got3 = velocity_displacement(vv, ww, dt, gg, vy=lat)
            want3 = _reference_velocity_displacement(vv, ww, dt, gg, vy=lat)
            assert all(g.tobytes() == r.tobytes() for g, r in zip(got3, want3, strict=True))


def test_node_displacement_is_velocity_displacement_per_control() -> None:
    """The sigma points' Python-float velocity model against the numpy one, element by element, bit for bit."""
    from gridbridge.ego_motion import _node_displacement

    rng = np.random.default_rng(27)
    for _ in range(3000):
        v = float(rng.choice([0.0, -0.0, rng.normal(0.0, 1.0), rng.uniform(-3.0, 3.0)]))
        w = float(rng.choice([0.0, -0.0, 1e-10, 1e-9, -1e-9, 2e-9, rng.normal(0.0, 1.0), rng.uniform(-40.0, 40.0)]))
        gamma = float(rng.choice([0.0, rng.normal(0.0, 0.1)]))
        vy = float(rng.choice([0.0, -0.0, rng.normal(0.0, 0.3)]))
        dt = float(rng.choice([0.1, 0.1333333333, rng.uniform(0.001, 1.0)]))
        want = velocity_displacement(np.array([v]), np.array([w]), dt, np.array([gamma]), vy=vy)
        got = np.array(_node_displacement(v, w, gamma, dt, vy))
        assert got.tobytes() == np.concatenate(want).tobytes(), (v, w, gamma, vy, dt)
