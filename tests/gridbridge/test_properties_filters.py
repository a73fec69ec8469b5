"""Property-based tests (Hypothesis) of both filters and the frame assembler on random input.

Random detection sets (each detector: no data, nobody, or up to 4 people anywhere, also outside the grid),
random odometry (or none) and time steps, through ``GridFilter`` and ``ParticleFilter`` on a small grid.
Invariants: no exception, beliefs in [0, 1] without NaN, the particles' rasterised mass equal to the belief
in every cell (as ``tests/pfpeople/particle/test_particles_filter.py`` checks it), and the same seed giving the same
bytes. Random stamp streams through :class:`~pfpeople.io.bag.sync.FrameAssembler`: frames strictly increasing in time
and every driver message either a frame or counted as skipped. Deterministic: ``derandomize=True``.
"""

from __future__ import annotations

import itertools

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gridbridge import GridFilter, GridSpec, Odometry
from gridbridge.params import DetectorModel
from pfpeople.io.bag.reader import BagMessage
from pfpeople.io.bag.sync import FrameAssembler
from pfpeople.particle.filter import ParticleFilter

SETTINGS = settings(
    max_examples=15, derandomize=True, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow]
)
SPEC = GridSpec(nx=10, ny=10, resolution=0.5, x0=0.0, y0=-2.5)
MODELS = (
    DetectorModel(name="a", ppv=0.95, fnr=0.3),
    DetectorModel(name="b", ppv=0.5, fnr=0.4, fov_min=-0.5, fov_max=0.5, max_range=4.0),
    DetectorModel(name="c", ppv=0.9, fnr=0.5, uncertainty="gaussian", sigma_lateral=0.5, sigma_range=0.8),
)

_xy = st.floats(min_value=-8.0, max_value=8.0)
_dets = st.one_of(
    st.none(), st.lists(st.tuples(_xy, _xy), max_size=4).map(lambda p: np.array(p, dtype=float).reshape(-1, 2))
)
_odo = st.one_of(
    st.none(),
    st.builds(Odometry, v=st.floats(min_value=-2.0, max_value=2.0), omega=st.floats(min_value=-2.0, max_value=2.0)),
)
# Time steps from a few values: every new dt costs the filters a new motion kernel (cached per dt).
_step = st.tuples(st.tuples(_dets, _dets, _dets), _odo, st.sampled_from([0.05, 0.1, 0.25]))
_steps = st.lists(_step, min_size=1, max_size=4)


def _check(belief: np.ndarray) -> None:
    assert belief.shape == SPEC.shape
    assert np.all(np.isfinite(belief)) and belief.min() >= 0.0 and belief.max() <= 1.0


@SETTINGS
@given(_steps)
def test_grid_filter_beliefs_stay_probabilities(steps: list) -> None:
    gf = GridFilter(SPEC, detectors=MODELS)
    for dets, odo, dt in steps:
        _check(gf.step(list(dets), odo, dt).posterior)


@SETTINGS
@given(_steps, st.integers(min_value=0, max_value=2**32 - 1))
def test_particle_filter_mass_is_the_belief_and_seeded(steps: list, seed: int) -> None:
    runs = []
    for _ in range(2):
        pf = ParticleFilter(SPEC, detectors=MODELS, n_particles=400, rng=np.random.default_rng(seed))
        for dets, odo, dt in steps:
            out = pf.step(list(dets), odo, dt)
            _check(out.posterior)
            np.testing.assert_allclose(out.particles.rasterise(SPEC), out.posterior, rtol=1e-12, atol=1e-15)
        runs.append((out.posterior.tobytes(), out.particles.x.tobytes(), out.particles.w.tobytes()))
    assert runs[0] == runs[1]  # same seed, same bytes


_msg = st.tuples(
    st.sampled_from(["/scan", "/scan", "/odom"]),
    st.integers(min_value=0, max_value=30),  # bag time step (10 ms units)
    st.one_of(st.just(0), st.integers(min_value=-200, max_value=200), st.sampled_from([3600 * 100, -3600 * 100])),
)


@SETTINGS
@given(st.lists(_msg, max_size=60))
def test_frame_assembler_on_random_stamps(stream: list) -> None:
    sync = FrameAssembler("/scan", {"/odom": "interpolate"}, tolerance_ns=50_000_000, max_pending=5)
    frames, bag_t, n_driver = [], 10**12, 0
    for k, (topic, step, jitter) in enumerate(stream):
        bag_t += step * 10_000_000
        stamp = bag_t + jitter * 10_000_000
        n_driver += topic == "/scan"
        frames += sync.push(BagMessage(topic, "t", k, bag_t, stamp, "f", None))
    frames += sync.finish()
    stamps = [f.stamp_ns for f in frames]
    assert all(b > a for a, b in itertools.pairwise(stamps))
    skipped = sum(sync.skipped_driver_messages.values())
    assert len(frames) + skipped == n_driver
    assert [f.index for f in frames] == list(range(len(frames)))
