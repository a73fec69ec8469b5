"""A people-motion model a user writes (the extension example of docs/library.md) runs through the filter's one
loop: on the reference (numpy) filter its ``move``, on the compiled filter its ``move_compiled`` (the same particles,
bit for bit), and without a ``move_compiled`` its ``move`` inside the compiled step, said once in the log."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np
import pytest
from scipy import stats

from gridbridge import Odometry, PeopleMotion, jit
from pfpeople import ParticleFilter, ParticleState, PeopleSampler

numba = pytest.importorskip("numba", reason="the compiled form is a numba kernel")

DETECTIONS = [np.array([[3.0, 0.5], [5.0, -1.0]]), np.array([[3.1, 0.4]]), np.array([[4.0, 0.0]])]


@dataclass(frozen=True, kw_only=True)
class ConstantVelocityWalker:
    """People walk straight on at a constant velocity; someone standing starts walking with probability ``p_start``
    per step, at a speed uniform in ``[speed_min, speed_max]`` (m/s) in a uniform direction (not the paper's
    truncated normal). ``motion`` gives the newborns' velocities and the inflow across the grid's border."""

    motion: PeopleMotion = field(default_factory=PeopleMotion)
    redraw_in_cell: bool = False
    p_start: float = 0.2
    speed_min: float = 0.5
    speed_max: float = 1.5

    def move(self, state: ParticleState, dt: float, *, rng: np.random.Generator) -> None:
        """The reference form, in numpy: replace the state's velocities and positions after ``dt`` s."""
        n = state.size
        u = rng.random(n)
        speed = rng.uniform(self.speed_min, self.speed_max, n)
        heading = rng.uniform(0.0, 2.0 * math.pi, n)
        start = (state.vx == 0.0) & (state.vy == 0.0) & (u < self.p_start)
        state.vx = np.where(start, speed * np.cos(heading), state.vx)
        state.vy = np.where(start, speed * np.sin(heading), state.vy)
        state.x = state.x + state.vx * dt
        state.y = state.y + state.vy * dt


@dataclass(frozen=True, kw_only=True)
class CompiledWalker(ConstantVelocityWalker):
    """:class:`ConstantVelocityWalker` with its compiled form: the same draws from ``rng`` in the same order."""

    def move_compiled(self, state: ParticleState, dt: float, *, rng: np.random.Generator) -> None:
        """The compiled form: :meth:`move` in one numba kernel, the same particles bit for bit."""
        bounds = (self.p_start, self.speed_min, self.speed_max)
        state.x, state.y, state.vx, state.vy = _walk(rng, state.x, state.y, state.vx, state.vy, dt, bounds)


@numba.njit
def _walk(g, x, y, vx, vy, dt, bounds):
    p_start, lo, hi = bounds
    n = x.size
    u, speed, heading = np.empty(n), np.empty(n), np.empty(n)
    for k in range(n):  # numba's Generator runs numpy's algorithms: the draws of move(), in its order
        u[k] = g.random()
    for k in range(n):
        speed[k] = g.uniform(lo, hi)
    for k in range(n):
        heading[k] = g.uniform(0.0, 2.0 * math.pi)
    ox, oy, ovx, ovy = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    for k in range(n):
        a, b = vx[k], vy[k]
        if a == 0.0 and b == 0.0 and u[k] < p_start:
            a, b = speed[k] * math.cos(heading[k]), speed[k] * math.sin(heading[k])
        ovx[k], ovy[k], ox[k], oy[k] = a, b, x[k] + a * dt, y[k] + b * dt
    return ox, oy, ovx, ovy


def _run(model: object, compiled: bool, steps: int = 6) -> list[bytes]:
    # the grid code the filter calls (warp, empty cells' prior) on its numpy path in both runs: its kernels agree
    # with it to 1e-12, not bit for bit (tests/gridbridge/test_kernels_grid.py)
    with jit.override(False, "gridbridge"), jit.override(compiled, "pfpeople"):
        pf = ParticleFilter(n_particles=2000, rng=np.random.default_rng(7), people_motion=model)  # type: ignore[arg-type]
        out = []
        for t in range(steps):
            odo = None if t % 3 == 2 else Odometry(v=0.5, omega=0.3)
            step = pf.step(DETECTIONS if t % 2 == 0 else [None, None, None], odo, 0.1)
            p = step.particles
            out.append(b"".join(a.tobytes() for a in (step.posterior, p.x, p.y, p.vx, p.vy, p.w)))
        return out


def test_the_walker_is_a_people_sampler_and_moves_as_it_says() -> None:
    """Walkers keep their velocity, a fifth of the standing start at a speed uniform in [0.5, 1.5] m/s (KS), every
    particle moves by velocity x dt; the compiled form makes the same draws and particles."""
    assert isinstance(CompiledWalker(), PeopleSampler) and isinstance(ConstantVelocityWalker(), PeopleSampler)
    n = 100_000
    vx0 = np.where(np.arange(n) < n // 2, 0.8, 0.0)
    states = [ParticleState(x=np.ones(n), y=np.zeros(n), vx=vx0.copy(), vy=np.zeros(n), w=np.ones(n)) for _ in "ab"]
    rngs = [np.random.default_rng(3), np.random.default_rng(3)]
    CompiledWalker().move(states[0], 0.1, rng=rngs[0])
    CompiledWalker().move_compiled(states[1], 0.1, rng=rngs[1])
    for name in ("x", "y", "vx", "vy"):
        assert getattr(states[0], name).tobytes() == getattr(states[1], name).tobytes(), name
    assert rngs[0].random() == rngs[1].random()  # the same number of draws
    st = states[0]
    speed = np.hypot(st.vx, st.vy)
    np.testing.assert_array_equal(st.vx[: n // 2], 0.8)  # walkers keep their velocity
    started = speed[n // 2 :] > 0.0
    assert abs(started.mean() - 0.2) < 5.0 * math.sqrt(0.2 * 0.8 / (n // 2))
    assert stats.kstest(speed[n // 2 :][started], stats.uniform(0.5, 1.0).cdf).pvalue > 1e-3
    np.testing.assert_allclose(st.x - 1.0, st.vx * 0.1, rtol=0, atol=1e-15)


def test_a_compiled_user_model_runs_its_compiled_form_with_the_reference_particles(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """The compiled filter runs move_compiled (a model whose numpy move raises still runs there), with no notice,
    and gives the reference filter's particles bit for bit."""

    @dataclass(frozen=True, kw_only=True)
    class CompiledOnly(CompiledWalker):
        def move(self, state: ParticleState, dt: float, *, rng: np.random.Generator) -> None:
            raise AssertionError("the compiled filter must run move_compiled")

    with caplog.at_level(logging.WARNING, logger="pfpeople.particle.forms"):
        fast = _run(CompiledOnly(), compiled=True)
    assert "no compiled form" not in caplog.text
    assert fast == _run(CompiledWalker(), compiled=False)


def test_a_user_model_without_a_compiled_form_runs_in_the_compiled_filter_and_says_so_once(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Without move_compiled the compiled filter runs move inside its compiled step: the reference particles, and one
    log line naming the model however many filters are built."""

    @dataclass(frozen=True, kw_only=True)
    class Walker(ConstantVelocityWalker):  # a class of its own: not named in the log yet
        pass

    with caplog.at_level(logging.WARNING, logger="pfpeople.particle.forms"):
        fast = _run(Walker(), compiled=True)
        again = _run(Walker(), compiled=True, steps=1)
    notices = [r.getMessage() for r in caplog.records if "no compiled form" in r.getMessage()]
    assert len(notices) == 1 and "people motion Walker" in notices[0] and "move_compiled" in notices[0], notices
    assert again == fast[:1]
    assert fast == _run(Walker(), compiled=False)


def test_a_user_ego_model_and_resampler_without_compiled_forms_run_in_the_compiled_filter(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """An ego model with only ``noise`` and ``poses`` and a resampler with only the protocol's methods (their
    reference forms) run inside the compiled step: the reference filter's particles bit for bit, one log line each."""
    from gridbridge import SensorMotionNoise
    from pfpeople import EgoSampler, Resampler, Resampling
    from pfpeople.particle.predictor.ego import sample_ego_poses

    class Ego:
        noise = SensorMotionNoise()

        def poses(self, odometry: Odometry | None, dt: float, n: int, *, rng: np.random.Generator) -> np.ndarray:
            return sample_ego_poses(odometry, dt, self.noise, min(n, 500), rng=rng)

    class Stratified:  # stratified resampling every step, by cell
        inner = Resampling(scheme="stratified", ess_threshold=2.0)

        def capacity(self, n: int) -> int:
            return n

        def due_ess(self, size: int, ess: float, n: int) -> bool:
            return self.inner.due_ess(size, ess, n)

        def resample(
            self, cells: np.ndarray, weights: np.ndarray, n: int, *, n_cells: int, rng: np.random.Generator
        ) -> tuple[np.ndarray, np.ndarray]:
            return self.inner.resample(cells, weights, n, n_cells=n_cells, rng=rng)

    assert isinstance(Ego(), EgoSampler) and isinstance(Stratified(), Resampler)

    def run(compiled: bool) -> list[bytes]:
        with jit.override(False, "gridbridge"), jit.override(compiled, "pfpeople"):
            kw = {"people_motion": CompiledWalker(), "ego_motion": Ego(), "resampling": Stratified()}
            pf = ParticleFilter(n_particles=1500, rng=np.random.default_rng(5), **kw)  # type: ignore[arg-type]
            steps = [pf.step(DETECTIONS, Odometry(v=0.4, omega=0.2), 0.1) for _ in range(4)]
        assert all(s.resampled for s in steps)
        return [s.posterior.tobytes() + s.particles.x.tobytes() + s.particles.w.tobytes() for s in steps]

    with caplog.at_level(logging.WARNING, logger="pfpeople.particle.forms"):
        fast = run(True)
    notices = [r.getMessage() for r in caplog.records if "no compiled form" in r.getMessage()]
    assert any("ego motion Ego" in m and "rows" in m for m in notices), notices
    assert any("resampler Stratified" in m and "resample_compiled" in m for m in notices), notices
    assert fast == run(False)
