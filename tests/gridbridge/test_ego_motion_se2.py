"""Ego-motion as the full SE(2) motion of the grid frame: the lateral speed ``vy`` (issue 24, deliverable 3).

The closed form of :func:`gridbridge.velocity_displacement` against a numerical integration of the body
velocity, the exact inverse :func:`pfpeople.perception.odometry.odometry_between`, a sideways motion in both filters and
``vy_mps`` in the run directory.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from evaluation.harness.replay import log_from_run
from gridbridge import (
    GridFilter,
    GridSpec,
    Odometry,
    PeopleMotion,
    SensorMotionNoise,
    ego_motion_sigma_points,
    predict_sensor,
    velocity_displacement,
)
from gridbridge.ego_motion import odometry_pose
from gridbridge.geometry import Pose2D
from pfpeople.io.run_dir import RunWriter, load_run
from pfpeople.particle.filter import ParticleFilter
from pfpeople.particle.predictor.ego import VelocityEgoSampling, apply_ego_motion, sample_ego_poses
from pfpeople.particle.predictor.paper import PaperSampling
from pfpeople.particle.state import ParticleState, uniform_in_cells
from pfpeople.perception.odometry import odometry_between

NOISELESS = SensorMotionNoise.noiseless()


def _integrate(v: float, vy: float, w: float, dt: float, n: int = 200_000) -> tuple[float, float, float]:
    """The pose after ``dt`` s of the constant body velocity ``(v, vy, w)``: midpoint rule on ``n`` steps of
    the world-frame velocity ``R(w t) (v, vy)`` (error O((dt/n)^2))."""
    h = dt / n
    th = w * h * (np.arange(n) + 0.5)
    x = h * np.sum(v * np.cos(th) - vy * np.sin(th))
    y = h * np.sum(v * np.sin(th) + vy * np.cos(th))
    return float(x), float(y), w * dt


@pytest.mark.parametrize(
    ("v", "vy", "w", "dt"),
    [(0.8, 0.3, 0.6, 0.5), (-0.4, 1.2, -1.5, 0.3), (0.0, 1.0, 2.0, 0.4), (0.5, -0.7, 0.0, 0.2), (1.0, 0.5, 3.0, 1.0)],
)
def test_closed_form_matches_integrated_body_velocity(v: float, vy: float, w: float, dt: float) -> None:
    dx, dy, dth = velocity_displacement(v, w, dt, vy=vy)
    assert (float(dx), float(dy), float(dth)) == pytest.approx(_integrate(v, vy, w, dt), abs=1e-9)
    # Continuous at the straight-line switch.
    dx2, dy2, _ = velocity_displacement(v, 1e-7, dt, vy=vy)
    assert (float(dx2), float(dy2)) == pytest.approx((v * dt, vy * dt), abs=1e-7)


def test_zero_lateral_speed_is_bit_identical_to_the_velocity_model() -> None:
    rng = np.random.default_rng(3)
    v, w = rng.normal(0.0, 1.0, 500), rng.normal(0.0, 1.0, 500)
    w[:50] = 0.0
    gamma = rng.normal(0.0, 0.1, 500)
    old = velocity_displacement(v, w, 0.1, gamma)
    for got in (
        velocity_displacement(v, w, 0.1, gamma, vy=0.0),
        velocity_displacement(v, w, 0.1, gamma, np.zeros(500)),
    ):
        for a, b in zip(old, got, strict=True):
            assert a.tobytes() == b.tobytes()
    # The formula of Thrun's model as written before vy: v / w * sin(w dt), v / w * (1 - cos(w dt)).
    turning = w != 0.0
    np.testing.assert_array_equal(old[0][turning], v[turning] / w[turning] * np.sin(w[turning] * 0.1))
    np.testing.assert_array_equal(old[1][turning], v[turning] / w[turning] * (1.0 - np.cos(w[turning] * 0.1)))
    odo = Odometry(v=0.7, omega=0.4)
    sp, sw = ego_motion_sigma_points(odo, 0.1, SensorMotionNoise())
    sp0, sw0 = ego_motion_sigma_points(Odometry(v=0.7, omega=0.4, vy=0.0), 0.1, SensorMotionNoise())
    assert sp.tobytes() == sp0.tobytes() and sw.tobytes() == sw0.tobytes()


def test_odometry_checks_vy_and_sigma_points_carry_it_in_the_mean() -> None:
    with pytest.raises(ValueError, match=r"Odometry\.vy"):
        Odometry(vy=math.nan)
    odo, dt = Odometry(v=0.6, omega=0.5, vy=0.4), 0.2
    # Noise on v only: the centre and v +- sqrt(3) sd, all with omega = 0.5 and the same lateral term.
    noise = SensorMotionNoise(alpha1=0.05, alpha2=0.0, alpha3=0.0, alpha4=0.0, alpha5=0.0, alpha6=0.0)
    sp, w = ego_motion_sigma_points(odo, dt, noise)
    sp_fwd, w_fwd = ego_motion_sigma_points(Odometry(v=0.6, omega=0.5), dt, noise)
    assert len(sp) == len(sp_fwd) == 3 and np.array_equal(w, w_fwd)
    centre = odometry_pose(odo, dt)
    np.testing.assert_allclose(sp[0], [centre.x, centre.y, centre.yaw], rtol=0, atol=1e-15)
    lat = np.array([float(c) for c in velocity_displacement(0.0, 0.5, dt, vy=0.4)[:2]])
    np.testing.assert_allclose(sp[:, :2] - sp_fwd[:, :2], np.tile(lat, (3, 1)), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(sp[:, 2], sp_fwd[:, 2])  # vy leaves the rotation alone
    # All three controls noisy (the default): 6 points, the noise unchanged by vy.
    sp, w = ego_motion_sigma_points(odo, dt, SensorMotionNoise())
    sp_fwd, w_fwd = ego_motion_sigma_points(Odometry(v=0.6, omega=0.5), dt, SensorMotionNoise())
    assert len(sp) == 6 and np.array_equal(w, w_fwd) and np.array_equal(sp[:, 2], sp_fwd[:, 2])


def test_odometry_between_round_trip_includes_sideways_motion() -> None:
    rng = np.random.default_rng(11)
    for _ in range(300):
        p0 = Pose2D(x=rng.uniform(-20, 20), y=rng.uniform(-20, 20), yaw=rng.uniform(-math.pi, math.pi))
        step = Pose2D(x=rng.uniform(-0.5, 0.5), y=rng.uniform(-0.5, 0.5), yaw=rng.uniform(-2.5, 2.5))
        p1 = p0.compose(step)
        dt = rng.uniform(0.02, 0.5)
        odo, lateral = odometry_between(p0, p1, dt)
        d = p0.inverse().compose(p1)
        got = odometry_pose(odo, dt)
        assert (got.x, got.y) == pytest.approx((d.x, d.y), abs=1e-9)
        assert math.remainder(got.yaw - d.yaw, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
        half = 0.5 * d.yaw
        assert lateral == pytest.approx(-d.x * math.sin(half) + d.y * math.cos(half), abs=1e-12)
    odo, lateral = odometry_between(
        Pose2D(x=1.0, y=2.0, yaw=0.5), Pose2D(x=1.0 - 0.3 * math.sin(0.5), y=2.0 + 0.3 * math.cos(0.5), yaw=0.5), 0.3
    )
    assert (odo.v, odo.vy, odo.omega, lateral) == pytest.approx((0.0, 1.0, 0.0, 0.3), abs=1e-12)


def _blob(spec: GridSpec) -> tuple[np.ndarray, tuple[int, int]]:
    bel = np.full(spec.shape, 0.5)
    i, j = (int(c) for c in spec.to_cell(4.05, 0.15))
    bel[i - 1 : i + 2, j - 1 : j + 2] = 0.9
    bel[i, j] = 0.99
    return bel, (i, j)


def test_grid_filter_moves_a_blob_by_a_pure_sideways_motion() -> None:
    # v = 0, vy = 1 m/s for 0.3 s: the grid frame moves 0.3 m (one cell) to its left, so the blob lies 0.3 m
    # further in -y of the new frame: cell [i, j] -> [i, j - 1].
    spec = GridSpec()
    bel, (i, j) = _blob(spec)
    odo = Odometry(v=0.0, omega=0.0, vy=1.0)
    out = predict_sensor(bel, spec, odo, 0.3, noise=NOISELESS)
    np.testing.assert_allclose(out[:, :-1], bel[:, 1:], rtol=0, atol=1e-9)
    np.testing.assert_allclose(out[:, -1], 0.5, atol=1e-12)  # entering from outside the grid
    gf = GridFilter(spec, motion=PeopleMotion(p_stationary=1.0), noise=NOISELESS, form="linear")
    gf.reset(bel)
    pred = gf.predict(odo, 0.3)
    np.testing.assert_allclose(pred.sensor_prior, predict_sensor(pred.people_prior, spec, odo, 0.3, noise=NOISELESS))
    assert np.unravel_index(np.argmax(pred.sensor_prior), spec.shape) == (i, j - 1)
    # The default odometry noise grows with v and omega only: the same sideways motion, the same shift.
    np.testing.assert_allclose(predict_sensor(bel, spec, odo, 0.3), out, rtol=0, atol=1e-12)


def test_particle_ego_motion_moves_particles_by_a_pure_sideways_motion() -> None:
    spec = GridSpec()
    rng = np.random.default_rng(12)
    odo = Odometry(v=0.0, omega=0.0, vy=1.0)
    cells = rng.integers(0, spec.n_cells, size=4000)
    cells = cells[cells % spec.ny != 0]  # not in the first column (y): those leave the grid
    x, y = uniform_in_cells(spec, cells, rng=rng)
    n = len(x)
    st = ParticleState(x=x, y=y, vx=np.ones(n), vy=np.zeros(n), w=np.ones(n))
    apply_ego_motion(st, sample_ego_poses(odo, 0.3, NOISELESS, n, rng=rng))
    np.testing.assert_allclose(st.y - y, -0.3, atol=1e-12)
    np.testing.assert_array_equal(st.x, x)
    np.testing.assert_array_equal(spec.flat_index(st.x, st.y), cells - 1)
    # Through the particle filter: its rasterised sensor prior is the blob one cell further in -y.
    bel, (i, j) = _blob(spec)
    pf = ParticleFilter(
        spec,
        people_motion=PaperSampling(motion=PeopleMotion(p_stationary=1.0)),
        ego_motion=VelocityEgoSampling(noise=NOISELESS),
        rng=np.random.default_rng(13),
    )
    pf.reset(bel)
    pred = pf.predict(odo, 0.3)
    assert np.unravel_index(np.argmax(pred.sensor_prior), spec.shape) == (i, j - 1)
    assert pred.sensor_prior[i, j - 1] == pytest.approx(0.99, abs=0.01)


def _write_run(path: Path, odometry: list[object]) -> None:
    spec = GridSpec(nx=4, ny=3)
    w = RunWriter(path, spec=spec, detector_names=["a"], metadata={"detector_models": [], "detectors": ["a"]})
    for k, odo in enumerate(odometry):
        w.write_frame(
            frame=k,
            driver_index=k,
            stamp_ns=k * 100_000_000,
            bag_time_ns=k * 100_000_000,
            dt_s=0.1,
            odometry=odo,  # type: ignore[arg-type]
            forced=False,
            belief=np.full(spec.shape, 0.5),
            people=np.zeros((0, 2)),
            detections=[np.zeros((0, 2))],
        )
    w.close(status="complete")


def test_frames_csv_round_trip_with_lateral_speed(tmp_path: Path) -> None:
    odos = [None, Odometry(v=0.5, omega=0.1, vy=-0.25), (0.4, -0.2), (0.3, 0.2, 0.125)]
    _write_run(tmp_path / "run", odos)
    fr = load_run(tmp_path / "run").frames
    np.testing.assert_array_equal(fr["v_mps"], [0.0, 0.5, 0.4, 0.3])
    np.testing.assert_array_equal(fr["omega_radps"], [0.0, 0.1, -0.2, 0.2])
    np.testing.assert_array_equal(fr["vy_mps"], [0.0, -0.25, 0.0, 0.125])
    log = log_from_run(tmp_path / "run", nobody=True)
    assert log.odometry == [
        None,
        Odometry(v=0.5, omega=0.1, vy=-0.25),
        Odometry(v=0.4, omega=-0.2),
        Odometry(v=0.3, omega=0.2, vy=0.125),
    ]
    with RunWriter(tmp_path / "bad", spec=GridSpec(nx=4, ny=3), detector_names=["a"]) as w:
        with pytest.raises(ValueError, match="odometry must be"):
            w.write_frame(
                frame=0,
                driver_index=0,
                stamp_ns=0,
                bag_time_ns=0,
                dt_s=0.1,
                odometry=(1.0,),  # type: ignore[arg-type]
                forced=False,
                belief=np.full((4, 3), 0.5),
                people=np.zeros((0, 2)),
                detections=[None],
            )


def test_run_without_the_vy_column_loads_with_zero_lateral_speed(tmp_path: Path) -> None:
    _write_run(tmp_path / "run", [None, (0.5, 0.1, 0.3)])
    path = tmp_path / "run" / "frames.csv"
    rows = [line.split(",") for line in path.read_text().splitlines()]
    col = rows[0].index("vy_mps")
    path.write_text("".join(",".join(r[:col] + r[col + 1 :]) + "\n" for r in rows))  # a run written before vy_mps
    fr = load_run(tmp_path / "run").frames
    np.testing.assert_array_equal(fr["vy_mps"], [0.0, 0.0])
    np.testing.assert_array_equal(fr["v_mps"], [0.0, 0.5])
    assert log_from_run(tmp_path / "run", nobody=True).odometry == [None, Odometry(v=0.5, omega=0.1)]
    path.write_text("frame,nonsense\n")
    with pytest.raises(ValueError, match="expected columns"):
        load_run(tmp_path / "run")
