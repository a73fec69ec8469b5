"""ParticleFilter: state, births, resampling inside the filter, reproducibility and bad input."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from gridbridge import FilterStep, GridFilter, GridSpec, Odometry, PeopleMotion, SensorMotionNoise, rasterise
from gridbridge.components import VelocityEgoMotion
from gridbridge.limits import ResourceLimitError
from pfpeople.particle.filter import ParticleFilter, ParticleStep
from pfpeople.particle.predictor import (
    PaperSampling,
    PeopleSampler,
    PersistentSampling,
    VelocityEgoSampling,
)
from pfpeople.particle.resampler import Resampling
from pfpeople.particle.state import ParticleState, uniform_in_cells

RNG = np.random.default_rng(0)
DETS = [np.array([[3.0, 0.5], [5.0, -1.0]]), np.array([[3.1, 0.4]]), np.array([[4.0, 0.0]])]


def test_initial_state_spreads_mass_evenly() -> None:
    pf = ParticleFilter(n_particles=2000, rng=np.random.default_rng(0))
    spec = pf.spec
    assert pf.state.size == 2000
    counts = np.bincount(spec.flat_index(pf.state.x, pf.state.y), minlength=spec.n_cells)
    assert counts.min() == 2 and counts.max() == 3
    np.testing.assert_allclose(pf.state.rasterise(spec), 0.5, rtol=1e-12)


def test_step_returns_filter_stages_and_particles_matching_posterior() -> None:
    pf = ParticleFilter(n_particles=20_000, rng=np.random.default_rng(1))
    for _ in range(4):
        out = pf.step(DETS, Odometry(v=0.5, omega=0.3), 0.1)
    assert isinstance(out, FilterStep) and isinstance(out, ParticleStep)
    for grid in (out.people_prior, out.sensor_prior, out.likelihood, out.posterior):
        assert grid.shape == pf.spec.shape
    assert out.fired.shape == (3, *pf.spec.shape) and out.covered.dtype == bool
    # The particles' rasterised mass is the posterior (resampling keeps each cell's mass).
    np.testing.assert_allclose(out.particles.rasterise(pf.spec), out.posterior, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(pf.belief, out.posterior)
    assert out.posterior.min() >= 0.0 and out.posterior.max() <= 1.0
    # Detected cell well above an undetected one.
    assert out.posterior[pf.spec.to_cell(3.0, 0.5)] > 0.9


def test_resampling_keeps_count_and_cell_mass() -> None:
    pf = ParticleFilter(n_particles=5000, rng=np.random.default_rng(2), resampling=Resampling(ess_threshold=2.0))
    for _ in range(3):
        out = pf.step(DETS, Odometry(v=0.4, omega=-0.2), 0.1)
        assert out.resampled
        assert out.particles.size == 5000
        np.testing.assert_allclose(out.particles.rasterise(pf.spec), out.posterior, rtol=1e-12, atol=1e-15)


def test_overflow_slack_lets_births_accumulate_up_to_the_bound() -> None:
    """With ``max_overflow`` births accumulate: the count grows above N between resamplings, never above
    (1 + max_overflow) N after a step, and a resampling restores exactly N; the mass stays the posterior."""
    n, slack = 5000, 0.1
    slack_policy = Resampling(ess_threshold=0.0, max_overflow=slack)
    pf = ParticleFilter(n_particles=n, rng=np.random.default_rng(2), resampling=slack_policy)
    sizes, resampled = [], []
    for _ in range(12):
        out = pf.step(DETS, Odometry(v=0.4, omega=-0.2), 0.1)
        sizes.append(out.particles.size)
        resampled.append(out.resampled)
        np.testing.assert_allclose(out.particles.rasterise(pf.spec), out.posterior, rtol=1e-12, atol=1e-15)
    assert max(sizes) <= (1 + slack) * n
    assert any(s > n for s in sizes)  # births kept without a resampling
    assert all(s == n for s, r in zip(sizes, resampled, strict=True) if r)
    assert 0 < sum(resampled) < len(resampled)
    # The memory limit counts the largest count between resamplings, and says so.
    with pytest.raises(ResourceLimitError, match=r"n_particles x \(1 \+ max_overflow\) = 300000000"):
        ParticleFilter(n_particles=150_000_000, rng=np.random.default_rng(0), resampling=Resampling(max_overflow=1.0))
    # Without the slack every step whose births overflow resamples back to N.
    pf0 = ParticleFilter(n_particles=n, rng=np.random.default_rng(2), resampling=Resampling(ess_threshold=0.0))
    for _ in range(4):
        out = pf0.step(DETS, Odometry(v=0.4, omega=-0.2), 0.1)
        assert out.particles.size <= n


def test_same_seed_same_output() -> None:
    outs = []
    for _ in range(2):
        pf = ParticleFilter(n_particles=3000, rng=np.random.default_rng(42), people_motion=PersistentSampling())
        for _ in range(3):
            out = pf.step(DETS, (0.3, 0.1), 0.1)
        outs.append(out)
    np.testing.assert_array_equal(outs[0].posterior, outs[1].posterior)
    np.testing.assert_array_equal(outs[0].particles.x, outs[1].particles.x)
    pf = ParticleFilter(n_particles=3000, rng=np.random.default_rng(43), people_motion=PersistentSampling())
    for _ in range(3):
        other = pf.step(DETS, (0.3, 0.1), 0.1)
    assert not np.array_equal(other.posterior, outs[0].posterior)


def test_reset_restores_initial_belief() -> None:
    pf = ParticleFilter(n_particles=1800, rng=np.random.default_rng(3))
    pf.step(DETS, None, 0.1)
    pf.reset()
    np.testing.assert_array_equal(pf.belief, np.full(pf.spec.shape, 0.5))
    assert pf.state.size == 1800


def _empty_block_filters(motion: PeopleMotion, n: int, seed: int) -> tuple[ParticleFilter, GridFilter, tuple]:
    spec = GridSpec()
    people = PaperSampling(motion=motion, redraw_in_cell=True)
    pf = ParticleFilter(spec, people_motion=people, n_particles=n, rng=np.random.default_rng(seed))
    gf = GridFilter(spec, motion=motion, form="linear")
    centre = spec.to_cell(4.05, 0.15)
    ci, cj = int(centre[0]), int(centre[1])
    i, j = spec.to_cell(pf.state.x, pf.state.y)
    far = (np.abs(i - ci) > 4) | (np.abs(j - cj) > 4)
    pf.state = pf.state.take(far)  # no particle within 4 cells: none can reach the centre cell in one step
    return pf, gf, (ci, cj)


@pytest.mark.parametrize(("p_stationary", "n", "tol"), [(1.0, 2000, 1e-12), (0.85, 100_000, 0.02)])
def test_birth_in_empty_cell_matches_grid(p_stationary: float, n: int, tol: float) -> None:
    # A person seen by detectors 1 and 3 in a cell that holds no particle. The cell's prior is the analytic
    # empty-cell prior, so the first posterior equals the grid's; the newborn then track the grid filter.
    # With p_stationary = 1 nothing moves and the match is exact; otherwise within Monte Carlo error (0.02).
    motion = PeopleMotion(p_stationary=p_stationary)
    pf, gf, cell = _empty_block_filters(motion, n, seed=5)
    dets = [np.array([[4.05, 0.15]]), np.zeros((0, 2)), np.array([[4.05, 0.15]])]
    for k in range(4):
        out, ref = pf.step(dets, None, 0.1), gf.step(dets, None, 0.1)
        if k == 0:
            assert out.sensor_prior[cell] == pytest.approx(ref.sensor_prior[cell], rel=1e-12)
            assert out.posterior[cell] == pytest.approx(ref.posterior[cell], rel=1e-12)
        assert abs(out.posterior[cell] - ref.posterior[cell]) <= tol
    assert ref.posterior[cell] > 0.99


def test_uniform_in_cells_stays_in_cells() -> None:
    spec = GridSpec()
    rng = np.random.default_rng(6)
    cells = rng.integers(0, spec.n_cells, size=10_000)
    x, y = uniform_in_cells(spec, cells, rng=rng)
    np.testing.assert_array_equal(spec.flat_index(x, y), cells)
    counts = rasterise(spec, np.column_stack((x, y)))
    assert counts.sum() == 10_000
    with pytest.raises(ValueError, match="flat_cells"):
        uniform_in_cells(spec, [spec.n_cells], rng=rng)


def test_particle_state_checks() -> None:
    with pytest.raises(ValueError, match=r"ParticleState.y has 2 entries"):
        ParticleState(x=np.zeros(3), y=np.zeros(2), vx=np.zeros(3), vy=np.zeros(3), w=np.zeros(3))
    st = ParticleState(x=np.zeros(2), y=np.zeros(2), vx=np.zeros(2), vy=np.zeros(2), w=np.array([0.1, np.nan]))
    with pytest.raises(ValueError, match=r"ParticleState.w contains NaN"):
        st.validate()
    st.w = np.array([0.1, -0.1])
    with pytest.raises(ValueError, match=r"ParticleState.w must be non-negative"):
        st.validate()
    both = ParticleState.concatenate([st, st.copy()])
    assert both.size == 4 and both.positions.shape == (4, 2)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_particles": 0}, "n_particles must be a positive integer"),
        ({"n_particles": -5}, "n_particles must be a positive integer"),
        ({"n_particles": 100}, "n_particles must be at least the number of grid cells"),
        ({"n_birth": 0}, "n_birth"),
        ({"outside": 1.5}, "outside"),
    ],
)
def test_bad_constructor_arguments(kwargs: dict, match: str) -> None:
    args = {"n_particles": 1000, "rng": np.random.default_rng(0), **kwargs}
    with pytest.raises(ValueError, match=match):
        ParticleFilter(**args)


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: Resampling(scheme="magic"), r"Resampling\.scheme must be one of"),
        (lambda: Resampling(ess_threshold=float("nan")), r"Resampling\.ess_threshold"),
        (lambda: Resampling(max_overflow=-0.1), r"Resampling\.max_overflow"),
        (lambda: VelocityEgoSampling(pool=0), r"VelocityEgoSampling\.pool"),
    ],
)
def test_bad_component_values(make: Callable[[], object], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        make()


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: ParticleFilter(n_particles=1000, rng=3), r"rng must be a numpy\.random\.Generator"),
        (lambda: ParticleFilter(rng=RNG, people_motion=PeopleMotion()), "people_motion must be a PeopleSampler"),
        (lambda: ParticleFilter(rng=RNG, people_motion="persistent"), "people_motion must be a PeopleSampler"),
        (lambda: ParticleFilter(rng=RNG, ego_motion=VelocityEgoMotion()), "ego_motion must be a VelocityEgoSampling"),
        (lambda: ParticleFilter(rng=RNG, resampling="systematic"), "resampling must be a Resampling"),
        (lambda: ParticleFilter(rng=RNG, likelihood=0.5), "likelihood must be a DetectionLikelihood"),
        (lambda: PaperSampling(motion=1.4), r"PaperSampling\.motion must be a PeopleMotion"),
        (lambda: PaperSampling(redraw_in_cell=1), r"PaperSampling\.redraw_in_cell must be a bool"),
        (lambda: PersistentSampling(persistent=PeopleMotion()), r"PersistentSampling\.persistent must be a Persis"),
        (lambda: VelocityEgoSampling(noise=0.1), r"VelocityEgoSampling\.noise must be a SensorMotionNoise"),
        (lambda: Resampling(scheme=3), r"Resampling\.scheme must be a name in .* or a callable, got int"),
    ],
)
def test_wrong_constructor_and_component_types_are_type_errors(make: Callable[[], object], match: str) -> None:
    with pytest.raises(TypeError, match=match):
        make()


def test_default_components_are_the_papers() -> None:
    pf = ParticleFilter(n_particles=1000, rng=np.random.default_rng(0))
    assert pf.people_motion == PaperSampling(motion=PeopleMotion(), redraw_in_cell=False)
    assert pf.ego_motion == VelocityEgoSampling(noise=SensorMotionNoise(), pool=4096)
    assert pf.resampling == Resampling(scheme="systematic", ess_threshold=0.5, max_overflow=0.0)
    assert pf.motion is pf.people_motion.motion and pf.noise is pf.ego_motion.noise


def test_a_new_people_sampler_plugs_in() -> None:
    """Any object with the PeopleSampler interface is a people motion; here everyone stands still."""

    class Standing:
        motion = PeopleMotion()
        redraw_in_cell = False

        def move(self, state: ParticleState, dt: float, *, rng: np.random.Generator) -> None:
            state.vx, state.vy = np.zeros(state.size), np.zeros(state.size)

    pf = ParticleFilter(n_particles=1000, rng=np.random.default_rng(0), people_motion=Standing())
    x0 = pf.state.x.copy()
    pf.predict(None, 0.1)
    assert isinstance(pf.people_motion, PeopleSampler)
    np.testing.assert_array_equal(pf.state.x[: x0.size], x0)  # nobody moved; the border's births follow


def test_bad_step_input_changes_nothing() -> None:
    pf = ParticleFilter(n_particles=1000, rng=np.random.default_rng(0))
    before = pf.state.x.copy()
    with pytest.raises(ValueError, match="dt"):
        pf.step(DETS, None, 0.0)
    with pytest.raises(ValueError, match="one entry per detector"):
        pf.step(DETS[:2], None, 0.1)
    with pytest.raises(ValueError, match="NaN"):
        pf.step([np.array([[np.nan, 0.0]]), None, None], None, 0.1)
    with pytest.raises(ValueError, match="odometry"):
        pf.step(DETS, "fast", 0.1)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="belief contains NaN"):
        pf.reset(np.full(pf.spec.shape, np.nan))
    np.testing.assert_array_equal(pf.state.x, before)
