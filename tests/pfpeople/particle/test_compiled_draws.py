"""The draws the compiled particle step makes inside its kernels, against the distributions of the numpy path.

The paper's people motion, the births and the systematic resampling by cell draw from SplitMix64 streams in the kernels
(:mod:`pfpeople.particle.predictor.draws`), not from numpy's ``Generator``: the compiled path no longer gives the numpy
path's particles, only the same distributions. Tested here, with fixed seeds (deterministic) and stated tolerances:

* the generator's normal, speed and heading draws: Kolmogorov-Smirnov against the exact distributions, alpha =
  1e-3; the tail of the ziggurat (|z| > r = 3.654) within 5 binomial standard errors;
* the people motion of the compiled pass against :func:`pfpeople.particle.predictor.paper.move_paper` on the same
  particles: the fraction that stays within 5 binomial standard errors of ``p_stationary``, two-sample KS tests
  (alpha = 1e-3) of the walkers' speed, heading and displacement; the sensor motion is the numpy code's to 1e-12;
* the births: inside their cells, uniform within them (KS), the stationary fraction;
* the resampling (:func:`pfpeople.particle.resampling.resample_state`, systematic): counts and cell masses kept,
  one particle per cell with mass; mean offspring counts over 3000 repetitions equal ``E = [forced] w_i / M_c +
  (n - K) w_i / W`` within 5 standard errors and agree with the numpy code's; the forced ancestor within a cell
  drawn in proportion to weight (chi-square, alpha = 1e-3);
* the filter: same seed, same bits; the rasterised belief of a short scenario agrees with the numpy path's to the
  Monte Carlo noise (numbers in :func:`test_compiled_belief_agrees_with_numpy_within_monte_carlo_noise`).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from gridbridge import GridSpec, Odometry, PeopleMotion, jit
from pfpeople.particle.filter import ParticleFilter
from pfpeople.particle.predictor import PersistentSampling
from pfpeople.particle.predictor import draws as rk
from pfpeople.particle.predictor.births import born_particles
from pfpeople.particle.predictor.ego import apply_ego_motion, ego_rows
from pfpeople.particle.predictor.paper import move_paper, paper_move_ego_compact
from pfpeople.particle.predictor.persistent import persist_params, persistent_move_ego_compact
from pfpeople.particle.resampler import Resampling
from pfpeople.particle.resampler.by_cell import resample_by_cell, resample_scaled, resample_state
from pfpeople.particle.resampler.schemes import systematic
from pfpeople.particle.state import ParticleState

pytestmark = pytest.mark.skipif(not jit.AVAILABLE, reason="numba is not installed")

ALPHA = 1e-3
MOTION = PeopleMotion()
WALK = rk.walk_params(MOTION.p_stationary, MOTION.mu, MOTION.sigma, MOTION.v_max)
SPEED = stats.truncnorm(-MOTION.mu / MOTION.sigma, (MOTION.v_max - MOTION.mu) / MOTION.sigma, MOTION.mu, MOTION.sigma)
DETECTIONS = [np.array([[3.0, 0.5], [5.0, -1.0]]), np.array([[3.1, 0.4]]), np.array([[4.0, 0.0]])]


def _seeds(seed: int) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 2**64, size=4, dtype=np.uint64)


def _binomial_ok(k: int, n: int, p: float) -> bool:
    return abs(k / n - p) < 5.0 * math.sqrt(p * (1.0 - p) / n)


# ------------------------------------------------------------------------------------------------ the generator


def test_ziggurat_normal_is_standard_normal() -> None:
    from numba import njit

    @njit
    def draw(n: int, seed: int) -> np.ndarray:
        state, out = np.uint64(seed), np.empty(n)
        for i in range(n):
            state, out[i] = rk.standard_normal(state)
        return out

    z = draw(400_000, 12345)
    assert stats.kstest(z, "norm").pvalue > ALPHA
    assert abs(z.mean()) < 5.0 / math.sqrt(z.size) and abs(z.var() - 1.0) < 5.0 * math.sqrt(2.0 / z.size)
    r = 3.6541528853610088  # the tail beyond the base strip takes the exponential rejection
    assert _binomial_ok(int(np.count_nonzero(np.abs(z) > r)), z.size, 2.0 * stats.norm.sf(r))
    np.testing.assert_array_equal(draw(1000, 7), draw(1000, 7))


def test_walker_speed_and_heading_distributions() -> None:
    from numba import njit

    @njit
    def draw(n: int, seed: int, walk: rk.WalkParams) -> tuple[np.ndarray, np.ndarray]:
        state, vx, vy = np.uint64(seed), np.empty(n), np.empty(n)
        for i in range(n):
            state, vx[i], vy[i] = rk.walker_velocity(state, walk)
        return vx, vy

    vx, vy = draw(300_000, 99, WALK)
    speed = np.hypot(vx, vy)
    assert stats.kstest(speed, SPEED.cdf).pvalue > ALPHA
    assert speed.min() >= 0.0 and speed.max() <= MOTION.v_max
    assert stats.kstest(np.arctan2(vy, vx), stats.uniform(-math.pi, 2 * math.pi).cdf).pvalue > ALPHA
    c, s = (np.array(v) for v in zip(*(rk.direction(np.uint64(z)) for z in range(0, 2**64 - 1, 2**54)), strict=True))
    np.testing.assert_allclose(np.hypot(c, s), 1.0, rtol=0, atol=5e-16)  # the angle addition keeps unit length
    heavy = rk.walk_params(0.0, 0.5, 1.0, 2.0)  # heavy truncation on both sides: many rejections
    sp = np.hypot(*draw(100_000, 5, heavy))
    assert stats.kstest(sp, stats.truncnorm(-0.5, 1.5, loc=0.5, scale=1.0).cdf).pvalue > ALPHA


def test_sincos_agrees_with_the_c_library() -> None:
    from numba import njit

    @njit
    def both(xs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        s, c = np.empty(xs.size), np.empty(xs.size)
        for i in range(xs.size):
            s[i], c[i] = rk.sincos(xs[i])
        return s, c

    xs = np.concatenate((np.random.default_rng(3).uniform(-1000.0, 1000.0, 200_000), np.linspace(-7, 7, 20_001)))
    xs = np.concatenate((xs, [0.0, -0.0, math.pi, -math.pi / 2, 1000.0, -1000.5, 1e6, np.nan]))
    s, c = both(xs)
    np.testing.assert_allclose(s, np.sin(xs), rtol=0, atol=1e-15)
    np.testing.assert_allclose(c, np.cos(xs), rtol=0, atol=1e-15)


# ------------------------------------------------------------------------------------------------ people motion

SPEC = GridSpec()
GRID = (float(SPEC.x0), float(SPEC.y0), float(SPEC.resolution), SPEC.nx, SPEC.ny)


def _interior(n: int, seed: int) -> ParticleState:
    """Particles at least 1.5 m inside the paper's grid: none leaves in one step of the people motion."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(SPEC.x0 + 1.5, SPEC.x1 - 1.5, n)
    y = rng.uniform(SPEC.y0 + 1.5, SPEC.y1 - 1.5, n)
    return ParticleState(x=x, y=y, vx=np.zeros(n), vy=np.zeros(n), w=np.full(n, 1.0 / n))


def _paper_pass(st: ParticleState, seeds: np.ndarray, poses: np.ndarray, ego: bool) -> tuple[np.ndarray, ...]:
    n_cells = SPEC.n_cells
    out, cells = tuple(np.empty(st.size) for _ in range(5)), np.empty(st.size, dtype=np.intp)
    sums = (np.zeros(n_cells), np.zeros(n_cells), np.zeros(n_cells, dtype=np.intp), np.zeros(n_cells))
    j, n_in = paper_move_ego_compact(st.x, st.y, st.w, seeds, WALK, 0.1, poses, ego, GRID, out, cells, sums)
    assert j == n_in == st.size  # nobody left
    return (*out, cells, *sums)


def test_compiled_people_motion_matches_move_paper_in_distribution() -> None:
    n = 200_000
    st = _interior(n, 1)
    x, y, vx, vy, w, cells, prior, mass, counts, sq = _paper_pass(st, _seeds(2), np.zeros((4, 1)), False)
    moved = st.copy()
    move_paper(moved, MOTION, 0.1, rng=np.random.default_rng(3))
    walk_c, walk_n = np.hypot(vx, vy) > 0.0, np.hypot(moved.vx, moved.vy) > 0.0
    assert _binomial_ok(n - int(walk_c.sum()), n, MOTION.p_stationary)
    assert np.array_equal(x[~walk_c], st.x[~walk_c]) and np.array_equal(vx[~walk_c], np.zeros(n - walk_c.sum()))
    for a, b in [
        (np.hypot(vx, vy)[walk_c], np.hypot(moved.vx, moved.vy)[walk_n]),
        (np.arctan2(vy, vx)[walk_c], np.arctan2(moved.vy, moved.vx)[walk_n]),
        ((x - st.x)[walk_c], (moved.x - st.x)[walk_n]),
        ((y - st.y)[walk_c], (moved.y - st.y)[walk_n]),
    ]:
        assert stats.ks_2samp(a, b).pvalue > ALPHA
    np.testing.assert_allclose(x - st.x, vx * 0.1, rtol=0, atol=1e-12)  # the move is velocity x dt
    np.testing.assert_array_equal(cells, SPEC.flat_index(x, y))
    np.testing.assert_allclose(prior, np.bincount(cells, weights=w, minlength=SPEC.n_cells), rtol=1e-12)
    np.testing.assert_allclose(sq, np.bincount(cells, weights=w * w, minlength=SPEC.n_cells), rtol=1e-12)
    np.testing.assert_array_equal(counts, np.bincount(cells, minlength=SPEC.n_cells))
    np.testing.assert_array_equal(prior, mass)  # a standing robot: the same sums


def test_compiled_sensor_motion_is_the_numpy_code_and_seeds_repeat() -> None:
    """The same seeds give the same people motion with and without the sensor motion; that then is
    :func:`apply_ego_motion`'s (particle k uses pose k mod S) to round-off."""
    st = _interior(5000, 4)
    rows = ego_rows(np.random.default_rng(5).standard_normal((3, 700)), np.array([0.05, 0.05, 0.02]),
                            (0.5, 0.2, 0.0), 0.1, 1e-9)  # fmt: skip
    moved = _paper_pass(st, _seeds(6), rows, True)
    still = _paper_pass(st, _seeds(6), np.zeros((4, 1)), False)
    ref = ParticleState(x=still[0], y=still[1], vx=still[2], vy=still[3], w=still[4])
    poses = np.column_stack((rows[0], rows[1], np.arctan2(rows[3], rows[2])))
    apply_ego_motion(ref, poses)
    for a, b in zip(moved[:4], (ref.x, ref.y, ref.vx, ref.vy), strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
    again = _paper_pass(st, _seeds(6), rows, True)
    for a, b in zip(moved, again, strict=True):
        np.testing.assert_array_equal(a, b)


def test_compiled_cells_on_and_near_edges_are_flat_index() -> None:
    """The pass takes cells by a multiplication and re-checks the ones near an edge with the division: on edges,
    one ulp off them and outside, its cells are :meth:`GridSpec.flat_index`'s; the particles outside are dropped and
    their places taken by the last ones."""
    edges_x = SPEC.x0 + np.arange(-1, SPEC.nx + 2) * SPEC.resolution
    edges_y = SPEC.y0 + np.arange(-1, SPEC.ny + 2) * SPEC.resolution
    xs = np.concatenate((edges_x, np.nextafter(edges_x, -np.inf), np.nextafter(edges_x, np.inf)))
    ys = np.concatenate((edges_y, np.nextafter(edges_y, -np.inf), np.nextafter(edges_y, np.inf)))
    gx, gy = (a.ravel() for a in np.meshgrid(xs, ys))
    n, n_cells = gx.size, SPEC.n_cells
    out, cells = tuple(np.empty(n) for _ in range(5)), np.empty(n, dtype=np.intp)
    sums = (np.zeros(n_cells), np.zeros(n_cells), np.zeros(n_cells, dtype=np.intp), np.zeros(n_cells))
    stay = rk.walk_params(1.0, MOTION.mu, MOTION.sigma, MOTION.v_max)
    args = (gx, gy, np.arange(n, dtype=float), _seeds(0), stay, 0.1, np.zeros((4, 1)), False, GRID, out, cells, sums)
    j, _ = paper_move_ego_compact(*args)
    want = SPEC.flat_index(gx, gy)
    assert j == np.count_nonzero(want >= 0)
    np.testing.assert_array_equal(cells[:j], SPEC.flat_index(out[0][:j], out[1][:j]))
    np.testing.assert_array_equal(np.sort(cells[:j]), np.sort(want[want >= 0]))  # the survivors, in another order
    k = out[4][:j].astype(np.intp)  # the masses are the particles' indices: each survivor is one particle, whole
    np.testing.assert_array_equal(np.sort(k), np.flatnonzero(want >= 0))
    np.testing.assert_array_equal(out[0][:j], gx[k])
    np.testing.assert_array_equal(out[1][:j], gy[k])


def test_compiled_births_are_uniform_in_their_cells() -> None:
    cells_in = np.random.default_rng(7).integers(0, SPEC.n_cells, 100_000)
    x, y, vx, vy = born_particles(cells_in, _seeds(8), WALK, GRID)
    np.testing.assert_array_equal(SPEC.flat_index(x, y), cells_in)
    u, v = SPEC.to_fractional(x, y)
    for frac in (u - np.floor(u), v - np.floor(v)):
        assert stats.kstest(frac, "uniform").pvalue > ALPHA
    walking = np.hypot(vx, vy) > 0.0
    assert _binomial_ok(int(np.count_nonzero(~walking)), cells_in.size, MOTION.p_stationary)
    assert stats.kstest(np.hypot(vx, vy)[walking], SPEED.cdf).pvalue > ALPHA


# ------------------------------------------------------------------------------------------------ resampling


def _resample_case() -> tuple[np.ndarray, np.ndarray, int]:
    """300 particles in 20 cells (3 without mass), in no particular order; 250 to draw."""
    rng = np.random.default_rng(11)
    cells = rng.integers(0, 20, 300)
    w = rng.random(300) * (cells % 7 != 3)
    return cells, w, 250


def _ancestors(cells: np.ndarray, w: np.ndarray, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    idx = np.arange(cells.size, dtype=float)  # the particles' index as their x: the gather returns the ancestors
    out = resample_state(cells, w, n, (idx, idx, idx, idx), n_cells=20, rng=rng, resampler=systematic)
    return out[0].astype(np.intp), out[4]


def test_compiled_resampling_keeps_counts_cell_masses_and_one_per_cell() -> None:
    cells, w, n = _resample_case()
    anc, new_w = _ancestors(cells, w, n, np.random.default_rng(0))
    mass = np.bincount(cells, weights=w, minlength=20)
    occupied = np.flatnonzero(mass > 0)
    assert anc.size == n and np.all(w[anc] > 0.0)
    np.testing.assert_allclose(np.bincount(cells[anc], weights=new_w, minlength=20), mass, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(cells[anc[: occupied.size]], occupied)  # the forced ones first, by cell
    assert np.all(np.bincount(cells[anc], minlength=20)[occupied] >= 1)


def test_compiled_resampling_offspring_counts_are_unbiased_and_match_numpy() -> None:
    cells, w, n = _resample_case()
    mass = np.bincount(cells, weights=w, minlength=20)
    k = np.count_nonzero(mass > 0)
    forced = np.divide(w, mass[cells], out=np.zeros(w.size), where=w > 0.0)  # one per cell with mass, by weight
    expected = forced + (n - k) * w / w.sum()  # and the rest systematic
    reps, rng = 3000, np.random.default_rng(1)
    compiled = np.zeros(cells.size)
    with jit.override(False):
        numpy_counts = np.zeros(cells.size)
        for _ in range(reps):
            numpy_counts += np.bincount(resample_by_cell(cells, w, n, n_cells=20, rng=rng)[0], minlength=cells.size)
    for _ in range(reps):
        compiled += np.bincount(_ancestors(cells, w, n, rng)[0], minlength=cells.size)
    # A particle's count is its floor or ceiling plus a Bernoulli: its sd is at most 1, the mean's 1 / sqrt(reps).
    bound = 5.0 / math.sqrt(reps)
    assert np.max(np.abs(compiled / reps - expected)) < bound
    assert np.max(np.abs(numpy_counts / reps - expected)) < bound
    assert np.max(np.abs(compiled - numpy_counts) / reps) < bound * math.sqrt(2.0)


def test_compiled_forced_ancestor_is_drawn_by_weight_within_the_cell() -> None:
    cells = np.array([0, 1, 0, 2, 0, 1, 0])  # cell 0: particles 0, 2, 4, 6 of weights 1, 2, 3, 4
    w = np.array([1.0, 5.0, 2.0, 1.0, 3.0, 5.0, 4.0])
    rng, picks = np.random.default_rng(2), []
    for _ in range(4000):  # n = 3: the forced ancestors only, one per cell
        anc, _ = (a[:3] for a in _ancestors(cells, w, 3, rng))
        picks.append(anc[0])
    freq = np.bincount(picks, minlength=7)[[0, 2, 4, 6]]
    assert stats.chisquare(freq, 4000 * np.array([0.1, 0.2, 0.3, 0.4])).pvalue > ALPHA


def test_resample_scaled_falls_back_on_the_last_particle_when_the_sums_round_otherwise() -> None:
    """Cell masses given a little above the sums in particle order (as the filter's factor x mass may be): a draw
    beyond the running sum takes the cell's last particle of positive weight."""
    cells = np.array([0, 0, 0, 1])
    w = np.array([0.25, 0.5, 0.0, 1.0])
    idx = np.arange(4, dtype=float)

    class Highest:  # the largest uniforms below 1
        def random(self, size: int | None = None) -> np.ndarray | float:
            return 1.0 - 2.0**-53 if size is None else np.full(size, 1.0 - 2.0**-53)

    mass = np.array([0.75 * (1.0 + 1e-15), 1.0])
    rows = (idx, idx, idx, idx)
    out = resample_scaled(cells, w, np.ones(2), 2, rows, mass=mass, total=1.75, rng=Highest())  # type: ignore[arg-type]
    np.testing.assert_array_equal(out[0], [1.0, 3.0])


@pytest.mark.parametrize(
    ("cells", "w", "n", "match"),
    [
        ([0, 1], [0.5, np.nan], 4, "finite and non-negative"),
        ([0, 9], [0.5, 0.5], 4, r"cells must lie in \[0, 5\)"),
        ([0, 1], [0.0, 0.0], 4, "all zero"),
        ([0, 1, 2], [1.0, 1.0, 1.0], 2, "cannot keep one"),
    ],
)
def test_compiled_resampling_errors(cells: list, w: list, n: int, match: str) -> None:
    z = np.zeros(len(cells))
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match=match):
        resample_state(np.array(cells), np.array(w), n, (z, z, z, z), n_cells=5, rng=rng, resampler=systematic)


# ------------------------------------------------------------------------------------------------ the filter


def _steps(pf: ParticleFilter, steps: int) -> list:
    out = []
    for t in range(steps):
        odo = None if t % 3 == 2 else Odometry(v=0.5, omega=0.3)
        out.append(pf.step(DETECTIONS if t % 2 == 0 else [None, np.zeros((0, 2)), None], odo, 0.1))
    return out


def test_compiled_filter_same_seed_same_bits() -> None:
    runs = []
    with jit.override(True):
        for seed in (3, 3, 4):
            last = _steps(ParticleFilter(n_particles=2000, rng=np.random.default_rng(seed)), 6)[-1]
            runs.append((last.posterior, last.particles.x, last.particles.vx, last.particles.w))
    for a, b in zip(runs[0], runs[1], strict=True):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(runs[0][1], runs[2][1])


def test_compiled_update_resamples_from_the_predicted_sums_as_from_the_scaled_weights() -> None:
    """The default policy's resampling, decided from the prediction's per-cell sums and drawn from the unscaled
    weights, gives what scaling the weights first and resampling them gives (a policy that does not draw scaled
    weights: the update scales them in a pass first)."""

    class Scaled(Resampling):
        draws_scaled = False  # type: ignore[assignment]

    runs = []
    with jit.override(True):
        for policy in (Resampling(max_overflow=0.1), Scaled(max_overflow=0.1)):
            steps = _steps(ParticleFilter(n_particles=3000, rng=np.random.default_rng(5), resampling=policy), 8)
            runs.append(steps)
    assert any(s.resampled for s in runs[0]) and not all(s.resampled for s in runs[0])
    for a, b in zip(*runs, strict=True):
        assert a.resampled == b.resampled
        np.testing.assert_allclose(a.posterior, b.posterior, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(a.particles.x, b.particles.x)
        np.testing.assert_allclose(a.particles.w, b.particles.w, rtol=1e-12, atol=0)


def _assert_within_monte_carlo_noise(comp: list, ref: list, other: list) -> None:
    """Compiled beliefs ``comp`` against numpy's ``ref`` (the same seeds) as numpy's ``other`` (other seeds) against
    ``ref``: MAD of single runs below 1.2 times, of the seed averages below 1.3 times, mean belief within 0.002."""
    mad = lambda a, b: float(np.mean(np.abs(a - b)))  # noqa: E731
    cross = np.mean([mad(c, r) for c, r in zip(comp, ref, strict=True)])
    within = np.mean([mad(r, o) for r, o in zip(ref, other, strict=True)])
    assert cross < 1.2 * within, (cross, within)
    avg = mad(np.mean(comp, axis=0), np.mean(ref, axis=0))
    assert avg < 1.3 * mad(np.mean(ref, axis=0), np.mean(other, axis=0)), avg
    assert abs(np.mean(comp) - np.mean(ref)) < 0.002


def test_compiled_belief_agrees_with_numpy_within_monte_carlo_noise() -> None:
    """6 steps (moving, standing, detections or none), 20 000 particles; the posterior of the last step, seeds 0-3
    on the compiled path, seeds 0-7 on the numpy path; MAD = mean absolute difference over the 900 cells.

    Measured: a compiled and a numpy belief differ by 0.0264 (MAD, mean over seeds 0-3), two numpy beliefs (seeds s
    and s + 4) by 0.0260: the difference is the Monte Carlo noise. The compiled beliefs averaged over 4 seeds differ
    from the numpy ones averaged likewise by 0.0139, the numpy averages over seeds 0-3 and 4-7 by 0.0127 (a bias of
    the compiled draws would stay in the averages); the mean beliefs are 0.14888 and 0.14902. Bounds: 1.2 times the
    numpy-numpy MAD for single runs, 1.3 times for the averages, 0.002 for the mean belief.
    """
    beliefs: dict[bool, list[np.ndarray]] = {True: [], False: []}
    for on in (True, False):
        with jit.override(on):
            for seed in range(4 if on else 8):
                pf = ParticleFilter(n_particles=20_000, rng=np.random.default_rng(seed))
                beliefs[on].append(_steps(pf, 6)[-1].posterior)
    comp, ref, other = beliefs[True], beliefs[False][:4], beliefs[False][4:]
    _assert_within_monte_carlo_noise(comp, ref, other)


def test_compiled_persistent_filter_unaffected_by_the_paper_draws() -> None:
    """A sampler other than the paper's keeps the numpy path's births and motion (bit-identical, no resampling)."""
    outs = []
    for on in (True, False):
        with jit.override(False, "gridbridge"), jit.override(on, "pfpeople"):
            policy = Resampling(ess_threshold=0.0, max_overflow=1.0)
            pf = ParticleFilter(n_particles=1500, rng=np.random.default_rng(9), people_motion=PersistentSampling(),
                                resampling=policy)  # fmt: skip
            outs.append(_steps(pf, 3)[-1].particles.x)
    np.testing.assert_array_equal(*outs)


@pytest.mark.parametrize(
    "odo", [Odometry(v=0.5, omega=0.3), Odometry(v=0.4, omega=0.0), Odometry(v=0.2, omega=-0.5, vy=0.3)]
)
def test_sensor_noise_drawn_in_the_kernel_matches_numpy_draws(odo: Odometry) -> None:
    """The sensor motion's noise drawn in the kernel (the paper path) against numpy's draws: the displacements
    dx, dy and the rotation, two-sample KS (alpha = 1e-3), and their means and variances within 5 standard errors."""
    from pfpeople.particle.predictor import VelocityEgoSampling

    ego = VelocityEgoSampling(pool=100_000)
    drawn = ego.rows_drawn(odo, 0.1, 100_000, seed=17)
    ref = ego.rows(odo, 0.1, 100_000, rng=np.random.default_rng(18))
    for a, b in zip(
        (drawn[0], drawn[1], np.arctan2(drawn[3], drawn[2])), (ref[0], ref[1], np.arctan2(ref[3], ref[2])), strict=True
    ):
        assert stats.ks_2samp(a, b).pvalue > ALPHA
        se = math.sqrt((a.var() + b.var()) / a.size)
        assert abs(a.mean() - b.mean()) < 5.0 * se + 1e-15
        assert abs(a.var() - b.var()) < 5.0 * math.sqrt(2.0 / a.size) * max(a.var(), 1e-300) + 1e-30
    np.testing.assert_allclose(np.hypot(drawn[2], drawn[3]), 1.0, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(ego.rows_drawn(odo, 0.1, 1000, seed=17), drawn[:, :1000])  # a prefix: same stream


# ------------------------------------------------------------------ the persistent people motion, drawn inside


def _walkers_and_standers(n: int, seed: int) -> ParticleState:
    """Particles well inside the paper's grid: the first half walk (speeds 0.3-2.5 m/s, any heading), the rest
    stand."""
    st = _interior(n, seed)
    rng = np.random.default_rng(seed + 100)
    speed, heading = rng.uniform(0.3, 2.5, n // 2), rng.uniform(-math.pi, math.pi, n // 2)
    st.vx, st.vy = np.zeros(n), np.zeros(n)
    st.vx[: n // 2], st.vy[: n // 2] = speed * np.cos(heading), speed * np.sin(heading)
    return st


def test_compiled_persistent_motion_matches_move_persistent_in_distribution() -> None:
    """The compiled pass (persistent_move_ego_compact, no sensor motion) against move_persistent's numpy draws on
    the same particles, dt = 0.3 s: stop and start fractions within 5 binomial standard errors of the rates; the
    walkers' change of speed and turn and the starters' speed and heading, two-sample KS at alpha = 1e-3; standing
    particles do not move."""
    from pfpeople.particle.predictor.persistent import PersistentMotion, move_persistent

    n, dt, params = 200_000, 0.3, PersistentMotion()
    st = _walkers_and_standers(n, 4)
    out, cells = tuple(np.empty(n) for _ in range(5)), np.empty(n, dtype=np.intp)
    sums = (
        np.zeros(SPEC.n_cells),
        np.zeros(SPEC.n_cells),
        np.zeros(SPEC.n_cells, dtype=np.intp),
        np.zeros(SPEC.n_cells),
    )
    src = (st.x, st.y, st.vx, st.vy, st.w)
    persist = persist_params(params, dt)
    j, n_in = persistent_move_ego_compact(
        src, _seeds(5), WALK, persist, np.zeros((4, 1)), False, GRID, out, cells, sums
    )
    assert j == n_in == n  # nobody left: the pass keeps every particle in place
    x, vx, vy = out[0], out[2], out[3]
    moved = st.copy()
    move_persistent(moved, MOTION, params, dt, rng=np.random.default_rng(6))
    walkers = np.arange(n) < n // 2
    heading0, speed0 = np.arctan2(st.vy, st.vx), np.hypot(st.vx, st.vy)
    p_stop, p_start = 1.0 - (1.0 - params.p_stop) ** dt, 1.0 - (1.0 - params.p_start) ** dt
    got = {}
    for name, (gx, gvx, gvy) in {"compiled": (x, vx, vy), "numpy": (moved.x, moved.vx, moved.vy)}.items():
        s = np.hypot(gvx, gvy)
        assert _binomial_ok(int(np.sum(walkers & (s == 0.0))), n // 2, p_stop), name
        assert _binomial_ok(int(np.sum(~walkers & (s > 0.0))), n - n // 2, p_start), name
        np.testing.assert_array_equal(gx[~walkers & (s == 0.0)], st.x[~walkers & (s == 0.0)])
        turn = np.angle(np.exp(1j * (np.arctan2(gvy, gvx) - heading0)))
        go, start = walkers & (s > 0.0), ~walkers & (s > 0.0)
        got[name] = ((s - speed0)[go], turn[go], s[start], np.arctan2(gvy, gvx)[start])
        np.testing.assert_allclose(gx - st.x, gvx * dt, rtol=0, atol=1e-12)
    for a, b in zip(got["compiled"], got["numpy"], strict=True):
        assert stats.ks_2samp(a, b).pvalue > ALPHA
    assert stats.kstest(got["compiled"][2], SPEED.cdf).pvalue > ALPHA  # a starter's speed: the paper's prior


def test_compiled_persistent_filter_same_seed_same_bits_and_numpy_belief_within_monte_carlo_noise() -> None:
    """PersistentSampling(compiled_draws=True): the same seed gives the same bits; the posterior after 6 steps
    (20 000 particles) agrees with the numpy path's as two numpy runs agree (the bounds of
    :func:`test_compiled_belief_agrees_with_numpy_within_monte_carlo_noise`, seeds 0-3 against 0-3 and 4-7)."""

    def run(seed: int, on: bool) -> np.ndarray:
        with jit.override(on):
            pf = ParticleFilter(n_particles=20_000, rng=np.random.default_rng(seed),
                                people_motion=PersistentSampling(compiled_draws=True))  # fmt: skip
            return _steps(pf, 6)[-1].posterior

    comp = [run(seed, True) for seed in range(4)]
    np.testing.assert_array_equal(run(0, True), comp[0])
    ref, other = [run(seed, False) for seed in range(4)], [run(seed, False) for seed in range(4, 8)]
    _assert_within_monte_carlo_noise(comp, ref, other)


def test_compiled_draws_must_be_a_bool() -> None:
    with pytest.raises(TypeError, match=r"PersistentSampling\.compiled_draws must be a bool, got int"):
        PersistentSampling(compiled_draws=1)  # type: ignore[arg-type]
