"""The particle filter's compiled kernels that draw as the numpy path does, against it: the same seed gives the same
bits.

The paper's people motion, the births and the systematic resampling by cell draw inside the compiled kernels (other
draws, the same distributions): they are tested in ``test_compiled_draws.py``. Every configuration without them (the
other people-motion samplers; the other resampling schemes, or no resampling) gives the numpy path's particles bit for
bit, tested here.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from evaluation.bench.particles import filterpy_systematic
from gridbridge import GridSpec, Odometry, PeopleMotion, jit
from gridbridge.components import Appearance, BeliefBounds
from pfpeople.particle.buffers import BufferPool
from pfpeople.particle.filter import ParticleFilter
from pfpeople.particle.predictor import PaperSampling, PersistentSampling
from pfpeople.particle.predictor.persistent import PersistentMotion, move_persistent, move_persistent_compiled
from pfpeople.particle.resampler import Resampling, resample_by_cell
from pfpeople.particle.state import ParticleState

pytestmark = pytest.mark.skipif(not jit.AVAILABLE, reason="numba is not installed")

DETECTIONS = [np.array([[3.0, 0.5], [5.0, -1.0]]), np.array([[3.1, 0.4]]), np.array([[4.0, 0.0]])]
EVERY_STEP = 2.0  # an ESS threshold above 1: every step resamples
NEVER = Resampling(ess_threshold=0.0, max_overflow=1.0)  # no resampling in these 7 steps
CONFIGS = [
    {"people_motion": PersistentSampling(), "resampling": NEVER},
    {"people_motion": PaperSampling(redraw_in_cell=True), "resampling": Resampling(scheme="stratified")},
    {"people_motion": PersistentSampling(redraw_in_cell=True), "resampling": NEVER},
    {"people_motion": PersistentSampling(), "resampling": Resampling(scheme="stratified", ess_threshold=EVERY_STEP)},
    {
        "people_motion": PaperSampling(redraw_in_cell=True),
        "resampling": Resampling(scheme="residual"),
        "appearance": Appearance(),
        "bounds": BeliefBounds(),
    },
    # a callable (returning fewer than asked)
    {"people_motion": PersistentSampling(), "resampling": Resampling(scheme=filterpy_systematic, ess_threshold=2.0)},
    {"people_motion": PersistentSampling(), "resampling": Resampling(scheme="multinomial", max_overflow=0.1)},
]


def _run(compiled: bool, n: int, steps: int, **kwargs: object) -> list[tuple[np.ndarray, ...]]:
    # the grid code the filter calls (warp, empty-cell prior) on its numpy path in both runs: its kernels agree
    # with it to 1e-12, not bit for bit (tests/gridbridge/test_kernels_grid.py)
    with jit.override(False, "gridbridge"), jit.override(compiled, "pfpeople"):
        pf = ParticleFilter(n_particles=n, rng=np.random.default_rng(11), **kwargs)  # type: ignore[arg-type]
        out = []
        for t in range(steps):
            odo = None if t % 3 == 2 else Odometry(v=0.5, omega=0.3)  # every third step the robot stands
            step = pf.step(DETECTIONS if t % 2 == 0 else [None, np.zeros((0, 2)), None], odo, 0.1)
            p = step.particles
            out.append((step.people_prior, step.sensor_prior, step.posterior, p.x, p.y, p.vx, p.vy, p.w))
        return [tuple(a.copy() for a in row) for row in out]


@pytest.mark.parametrize("kwargs", CONFIGS)
def test_compiled_particle_filter_draws_as_numpy_and_is_bit_identical(kwargs: dict) -> None:
    fast, slow = _run(True, 1200, 7, **kwargs), _run(False, 1200, 7, **kwargs)
    for t, (a, b) in enumerate(zip(fast, slow, strict=True)):
        for name, x, y in zip(("people", "sensor", "posterior", "x", "y", "vx", "vy", "w"), a, b, strict=True):
            assert x.tobytes() == y.tobytes(), f"step {t}: {name} differs"


def test_all_compiled_particle_filter_agrees_with_all_numpy() -> None:
    """Both packages compiled: the grid warp's 1e-16 differences reach the births' weights, nothing more."""
    runs = []
    for on in (True, False):
        with jit.override(on):
            pf = ParticleFilter(n_particles=1500, rng=np.random.default_rng(4), **CONFIGS[0])  # type: ignore[arg-type]
            runs.append([pf.step(DETECTIONS, Odometry(v=0.5, omega=0.3), 0.1).posterior for _ in range(5)])
    for a, b in zip(*runs, strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)


def test_a_state_with_particles_outside_the_grid_gives_the_same_bits() -> None:
    """A state set from outside with particles beyond the grid: a sampler other than the paper's counts the
    particles inside after the people motion in a pass first (its births need it), as the numpy path does."""
    outs = []
    for on in (True, False):
        with jit.override(False, "gridbridge"), jit.override(on, "pfpeople"):
            pf = ParticleFilter(n_particles=1000, rng=np.random.default_rng(8), **CONFIGS[0])  # type: ignore[arg-type]
            st = pf.state.copy()
            st.x[::50] = -3.0  # 20 particles beyond the grid's near edge
            pf.state = st
            step = pf.step(DETECTIONS, Odometry(v=0.3, omega=0.1), 0.1)
            outs.append((step.posterior, step.particles.x, step.particles.w, pf.rng.random()))
    for a, b in zip(*outs, strict=True):
        np.testing.assert_array_equal(a, b)


def test_step_records_are_never_written_by_later_steps() -> None:
    """The buffer pool reuses only arrays nothing else holds: a kept ParticleStep keeps its values."""
    with jit.override(True):
        pf = ParticleFilter(n_particles=1000, rng=np.random.default_rng(3), resampling=Resampling(ess_threshold=2.0))
        kept = [pf.step(DETECTIONS, Odometry(v=0.4, omega=0.1), 0.1) for _ in range(3)]
        copies = [(s.particles.x.copy(), s.particles.w.copy()) for s in kept]
        view = kept[-1].particles.vx[:5]
        view_copy = view.copy()
        for _ in range(6):
            pf.step(DETECTIONS, Odometry(v=0.4, omega=0.1), 0.1)
    for s, (x, w) in zip(kept, copies, strict=True):
        np.testing.assert_array_equal(s.particles.x, x)
        np.testing.assert_array_equal(s.particles.w, w)
    np.testing.assert_array_equal(view, view_copy)


@pytest.mark.parametrize("resampler", ["systematic", "stratified", "multinomial", "residual"])
def test_resample_by_cell_compiled_matches_numpy(resampler: str) -> None:
    rng = np.random.default_rng(5)
    cells = rng.integers(0, 40, 3000)
    w = rng.random(3000) * (cells % 3 != 0)  # a third of the cells hold no mass
    res = []
    for on in (True, False):
        with jit.override(on):
            res.append(resample_by_cell(cells, w, 2500, n_cells=50, rng=np.random.default_rng(9), resampler=resampler))
    np.testing.assert_array_equal(res[0][0], res[1][0])
    assert res[0][1].tobytes() == res[1][1].tobytes()


@pytest.mark.parametrize(
    ("cells", "w", "n", "match"),
    [
        ([0, 1], [0.5, np.nan], 4, "finite and non-negative"),
        ([0, 1], [0.5, -1.0], 4, "finite and non-negative"),
        ([0, 9], [0.5, 0.5], 4, r"cells must lie in \[0, 5\)"),
        ([0, 1], [0.0, 0.0], 4, "all zero"),
        ([0, 1, 2], [1.0, 1.0, 1.0], 2, "cannot keep one"),
    ],
)
def test_resample_by_cell_errors_are_the_same_on_both_paths(cells: list, w: list, n: int, match: str) -> None:
    for on in (True, False):
        with jit.override(on), pytest.raises(ValueError, match=match):
            resample_by_cell(np.array(cells), np.array(w), n, n_cells=5, rng=np.random.default_rng(0))


def test_buffer_pool_hands_out_only_arrays_nothing_else_holds() -> None:
    pool = BufferPool(max_items=4)
    held = np.arange(100.0)
    pool.give(held)
    other = pool.take(100)
    assert other.base is not held and other is not held  # ``held`` is still referenced here
    del held
    again = pool.take(90)  # now only the pool held it (1.25 x 90 + 1024 >= 100)
    assert again.size == 90 and again.base is not None and again.base.size == 100
    pool.give(again, again)  # offered twice, kept once
    assert len(pool) == 1
    for _ in range(6):
        pool.give(np.zeros(3))
    assert len(pool) == 4  # the oldest dropped


def test_numba_switch_reads_the_environment() -> None:
    code = "from gridbridge import jit; print(jit.enabled())"
    env = dict(os.environ, PFPEOPLE_NUMBA="0")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
    with jit.override(False):
        assert not jit.enabled() and not jit.enabled("pfpeople")
    with jit.override(False, "pfpeople"):
        assert not jit.enabled("pfpeople") and jit.enabled("gridbridge") == jit.enabled()
    assert jit.enabled("pfpeople") == (os.environ.get("PFPEOPLE_NUMBA", "1") != "0")


def test_grid_tuple_cells_match_flat_index() -> None:
    """The kernels' cell of a point is GridSpec.flat_index, on cell edges and outside too."""
    from pfpeople.particle.predictor.passes import cell

    spec = GridSpec(nx=7, ny=5, resolution=0.3, x0=-0.45, y0=-1.2)
    grid = (spec.x0, spec.y0, spec.resolution, spec.nx, spec.ny)
    edges_x = spec.x0 + np.arange(-1, 9) * spec.resolution
    xs = np.concatenate((edges_x, np.nextafter(edges_x, -np.inf), np.random.default_rng(0).uniform(-1, 3, 200)))
    ys = np.resize(np.concatenate((spec.y0 + np.arange(-1, 7) * spec.resolution, [-0.0, 1e-300])), xs.size)
    want = spec.flat_index(xs, ys)
    got = [cell(float(x), float(y), grid) for x, y in zip(xs, ys, strict=True)]
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize(
    "odo", [Odometry(v=0.5, omega=0.3), Odometry(v=0.4, omega=0.0), Odometry(v=0.2, omega=-0.5, vy=0.3), Odometry()]
)
def test_ego_rows_are_sample_ego_poses_bit_for_bit(odo: Odometry) -> None:
    from gridbridge import SensorMotionNoise
    from gridbridge.ego_motion import _OMEGA_EPS
    from pfpeople.particle.predictor.ego import VelocityEgoSampling, ego_rows, sample_ego_poses

    noise = SensorMotionNoise()
    poses = sample_ego_poses(odo, 0.1, noise, 500, rng=np.random.default_rng(2))
    e = np.random.default_rng(2).standard_normal((3, 500))
    sd = np.sqrt(np.asarray(noise.variances(odo.v, odo.omega), dtype=np.float64))
    rows = ego_rows(e, sd, (odo.v, odo.omega, odo.vy), 0.1, _OMEGA_EPS)
    want = np.stack((poses[:, 0], poses[:, 1], np.cos(poses[:, 2]), np.sin(poses[:, 2])))
    assert rows.tobytes() == want.tobytes()
    # The component's rows draw in the kernel from the generator (ego_rows_from): the same bits, and the generator
    # left where numpy's draws leave it.

    drawing, numpy_draws = np.random.default_rng(2), np.random.default_rng(2)
    assert VelocityEgoSampling(noise=noise).rows(odo, 0.1, 500, rng=drawing).tobytes() == want.tobytes()
    numpy_draws.standard_normal((3, 500))
    assert drawing.random(4).tobytes() == numpy_draws.random(4).tobytes()


@pytest.mark.parametrize(
    "params",
    [
        PersistentMotion(),
        PersistentMotion(heading_noise=3.0, speed_noise=2.0, speed_reversion=4.0, p_stop=0.9, p_start=0.9),
        PersistentMotion(speed_noise=0.0, p_stop=0.0, p_start=1.0),
    ],
)
def test_move_persistent_compiled_is_the_numpy_walk_bit_for_bit(params: PersistentMotion) -> None:
    """The compiled form (move_persistent_compiled: persistent_walk, persistent_velocities) against the reference
    form over several steps: walkers, standing particles (signed zeros too), speeds near v_max and beyond it."""
    rng = np.random.default_rng(21)
    n = 3000
    vx, vy = rng.normal(size=n) * 1.5, rng.normal(size=n) * 1.5
    vx[:800], vy[:800] = 0.0, 0.0
    vx[800:900], vy[900:1000] = -0.0, -0.0
    vx[1000:1100] = 2.9
    motion = PeopleMotion(v_max=3.0)
    out = []
    for move in (move_persistent_compiled, move_persistent):
        st = ParticleState(x=np.ones(n), y=np.zeros(n), vx=vx.copy(), vy=vy.copy(), w=np.ones(n))
        draws = np.random.default_rng(5)
        rows = []
        for dt in (0.1, 0.133, 0.5):
            move(st, motion, params, dt, rng=draws)
            rows.append(np.stack((st.x, st.y, st.vx, st.vy)).tobytes())
        rows.append(draws.random(3).tobytes())  # the same number of draws on both paths
        out.append(rows)
    assert out[0] == out[1]


@pytest.mark.parametrize("odo", [Odometry(v=0.5, omega=0.3), None])
def test_empty_cell_prior_at_the_empty_cells_is_the_whole_warp_there(odo: Odometry | None) -> None:
    """empty_cell_prior (compiled: the linear prior only at the cells warp_taps finds, convolve_at, warped only at
    the empty cells, warp_at) against the whole grid's linear prior warped by the compiled grid functions, read at
    those cells; standing (one pose at 0) too."""
    from gridbridge import ego_motion_sigma_points, people_motion_kernel, predict_people, warp_belief
    from pfpeople.particle.predictor.empty_cells import empty_cell_prior

    pf = ParticleFilter(n_particles=1500, rng=np.random.default_rng(3))
    for t in range(4):
        pf.step(DETECTIONS if t % 2 == 0 else [None, None, None], Odometry(v=0.4, omega=0.2), 0.1)
    poses, w = ego_motion_sigma_points(odo, 0.1, pf.noise)
    empty = np.random.default_rng(4).random(pf.spec.n_cells) < 0.2
    models = (pf.spec, pf.motion, pf.outside, 0.1, (poses, w), empty)
    with jit.override(True):
        got = empty_cell_prior(pf.belief, *models)
        kernel = people_motion_kernel(pf.spec, pf.motion, dt=0.1, form="integrated")
        people = predict_people(pf.belief, kernel, outside=pf.outside, form="linear")
        want = warp_belief(people, pf.spec, poses, w, outside=pf.outside).ravel()[empty]
    assert got.tobytes() == want.tobytes()
    with jit.override(False, "gridbridge"):
        np.testing.assert_allclose(empty_cell_prior(pf.belief, *models), want, rtol=0, atol=1e-12)
