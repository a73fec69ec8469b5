"""The grid filter's compiled kernels against their numpy twins (tolerances as gridbridge/kernels.py states)."""

from __future__ import annotations

import numpy as np
import pytest

from evaluation.bench.grid import scene
from gridbridge import (
    PAPER_DETECTORS,
    GridFilter,
    GridSpec,
    Odometry,
    SensorMotionNoise,
    detection_map,
    ego_motion_sigma_points,
    fuse_detectors,
    jit,
    likelihood_from_detections,
    people_motion_kernel,
    predict_people,
    warp_belief,
)
from gridbridge.components import Appearance, BeliefBounds, LinearPrediction, PaperPrediction, VelocityEgoMotion
from gridbridge.ego_motion import predict_sensor
from gridbridge.params import DetectorModel

pytestmark = pytest.mark.skipif(not jit.AVAILABLE, reason="numba is not installed")

SPEC = GridSpec(nx=23, ny=17, resolution=0.3, x0=0.0, y0=-2.55)


def _both(fn, *args, **kwargs):  # type: ignore[no-untyped-def]
    with jit.override(True):
        fast = fn(*args, **kwargs)
    with jit.override(False):
        slow = fn(*args, **kwargs)
    return fast, slow


@pytest.mark.parametrize("outside", [0.5, 0.0, 1.0])
def test_paper_prediction_is_bit_identical(outside: float) -> None:
    bel = np.random.default_rng(1).random(SPEC.shape)
    for dt in (0.1, 0.25):
        kernel = people_motion_kernel(SPEC, dt=dt, form="paper")
        fast, slow = _both(predict_people, bel, kernel, outside=outside, form="paper")
        assert fast.tobytes() == slow.tobytes()


def test_linear_prediction_agrees_to_1e12() -> None:
    bel = np.random.default_rng(2).random(SPEC.shape)
    kernel = people_motion_kernel(SPEC, dt=0.3, form="integrated")
    fast, slow = _both(predict_people, bel, kernel, outside=0.3, form="linear")
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-12)


def test_paper_kernel_check_is_the_same_on_both_paths() -> None:
    kernel = np.full((3, 3), 0.2)
    kernel[0, 0] = 1.0
    for on in (True, False):
        with jit.override(on), pytest.raises(ValueError, match="off-centre values must be below 1"):
            predict_people(np.full((5, 5), 0.5), kernel, form="paper")


@pytest.mark.parametrize(
    "odometry", [Odometry(v=0.35, omega=0.2), Odometry(v=-1.0, omega=-2.0, vy=0.3), Odometry(v=40.0, omega=0.0)]
)
def test_warp_agrees_to_1e12(odometry: Odometry) -> None:
    """Sigma-point warps (the last one moves everything off the grid: all taps read ``outside``)."""
    bel = np.random.default_rng(3).random(SPEC.shape)
    poses, w = ego_motion_sigma_points(odometry, 0.1, SensorMotionNoise())
    fast, slow = _both(warp_belief, bel, SPEC, poses, w, outside=0.25)
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-12)
    one_fast, one_slow = _both(warp_belief, bel, SPEC, poses[0], outside=0.25)  # one pose: no weighted sum
    np.testing.assert_allclose(one_fast, one_slow, rtol=0, atol=1e-12)


def test_detection_maps_and_fusion_are_bit_identical() -> None:
    rng = np.random.default_rng(4)
    pts = np.column_stack((rng.uniform(-1, 8, 12), rng.uniform(-3.5, 3.5, 12)))
    footprint = DetectorModel(name="wide-legs", ppv=0.8, fnr=0.3, footprint_radius=0.45)
    for model in (*PAPER_DETECTORS, footprint):
        fast, slow = _both(detection_map, SPEC, model, pts)
        assert fast.tobytes() == slow.tobytes(), model.name
    dets = [pts[:5], None, pts[5:]]
    fast, slow = _both(likelihood_from_detections, SPEC, PAPER_DETECTORS, dets)
    for name in ("fired", "covered", "detector_likelihoods", "likelihood"):
        assert getattr(fast, name).tobytes() == getattr(slow, name).tobytes(), name
    fired = rng.random((3, *SPEC.shape)) * (rng.random((3, *SPEC.shape)) < 0.3)
    covered = rng.random((3, *SPEC.shape)) < 0.7
    ppv, fnr = np.array([0.95, 0.5, 0.9]), np.array([0.3, 0.4, 0.5])
    a, b = _both(fuse_detectors, fired, ppv, fnr, covered=covered)
    assert a.tobytes() == b.tobytes()


def test_point_maps_with_footprints_are_bit_identical_off_the_grid_and_at_the_radius() -> None:
    """point_map (only the cells within the footprint's reach looked at) against detection_map's numpy path:
    footprints of 0.3-2 m, points inside, near and far off the grid, and points exactly one radius from
    a cell centre (the test's edge)."""
    rng = np.random.default_rng(41)
    for k in range(300):
        spec = GridSpec(
            nx=int(rng.integers(1, 30)), ny=int(rng.integers(1, 30)), resolution=float(rng.choice([0.1, 0.3]))
        )
        n = int(rng.integers(1, 6))
        pts = np.column_stack(
            (rng.normal(spec.x0 + spec.nx * spec.resolution / 2, spec.nx * spec.resolution, n), rng.normal(0, 3, n))
        )
        if k % 4 == 0:
            pts[0] = (spec.x0 + 3.5 * spec.resolution + 0.3, spec.y0 + 2.5 * spec.resolution)
        if k % 9 == 0:
            pts[-1, 1] = 1e3
        model = DetectorModel(name="wide", ppv=0.8, fnr=0.3, footprint_radius=float(rng.choice([0.3, 0.45, 2.0])))
        fast, slow = _both(detection_map, spec, model, pts)
        assert fast.tobytes() == slow.tobytes(), k


@pytest.mark.parametrize("form", ["paper", "linear"])
def test_grid_filter_steps_agree_to_1e12(form: str) -> None:
    spec = GridSpec.centred_on_edge(31, 29, 0.3)
    runs = []
    for on in (True, False):
        with jit.override(on):
            f = GridFilter(spec, form=form, appearance=Appearance(), bounds=BeliefBounds())  # type: ignore[arg-type]
            steps = []
            for t in range(6):
                odo = None if t == 3 else Odometry(v=0.4, omega=0.3 - 0.1 * t)
                steps.append(f.step(scene(spec, np.random.default_rng(t)), odo, 0.1))
            runs.append(steps)
    for a, b in zip(*runs, strict=True):
        for name in ("people_prior", "sensor_prior", "likelihood", "posterior"):
            np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=0, atol=1e-12, err_msg=name)


class _Paper(PaperPrediction):
    """The paper prediction through predict_people, the public function (checked, its kernel looked up each call)."""

    def predict(self, belief: np.ndarray, spec: GridSpec, dt: float) -> np.ndarray:
        return predict_people(belief, self.kernel(spec, dt), outside=self.outside, form="paper")


class _Linear(LinearPrediction):
    def predict(self, belief: np.ndarray, spec: GridSpec, dt: float) -> np.ndarray:
        return predict_people(belief, self.kernel(spec, dt), outside=self.outside, form="linear")


class _Ego(VelocityEgoMotion):
    def predict(self, belief: np.ndarray, spec: GridSpec, odometry: Odometry | None, dt: float) -> np.ndarray:
        return predict_sensor(belief, spec, odometry, dt, noise=self.noise, outside=self.outside)


@pytest.mark.parametrize(("builtin", "custom"), [(PaperPrediction, _Paper), (LinearPrediction, _Linear)])
def test_grid_filter_runs_its_builtin_components_as_their_functions_do(builtin: type, custom: type) -> None:
    """The built-in components' compiled forms (their kernel kept per step, the belief checked in one pass) give
    the public functions' results bit for bit, in a filter."""
    spec = GridSpec.centred_on_edge(19, 23, 0.3)
    runs = []
    for prediction, ego in ((builtin(), VelocityEgoMotion()), (custom(), _Ego())):
        f = GridFilter(spec, prediction=prediction, ego_motion=ego)
        runs.append([f.step(scene(spec, np.random.default_rng(t)), Odometry(v=0.3, omega=0.2), 0.1) for t in range(4)])
        runs[-1].append(f.step(scene(spec, np.random.default_rng(9)), None, 0.2))  # standing, another dt
    for a, b in zip(*runs, strict=True):
        for name in ("people_prior", "sensor_prior", "likelihood", "posterior"):
            assert getattr(a, name).tobytes() == getattr(b, name).tobytes(), name


@pytest.mark.parametrize("miss_weight", [1.0, 0.6])
def test_independent_likelihood_is_bit_identical(miss_weight: float) -> None:
    """IndependentLikelihood on its compiled terms (independent_terms, add_where) and on numpy: every stage."""
    from gridbridge.likelihoods import IndependentLikelihood

    rng = np.random.default_rng(9)
    pts = np.column_stack((rng.uniform(-1, 8, 14), rng.uniform(-3.5, 3.5, 14)))
    footprint = DetectorModel(name="wide-legs", ppv=0.8, fnr=0.3, footprint_radius=0.45)
    camera = DetectorModel(name="cam", ppv=0.7, fnr=0.4, uncertainty="gaussian", fov_min=-0.5, fov_max=0.5)
    models = (*PAPER_DETECTORS, footprint, camera)
    lik = IndependentLikelihood(base_rate=0.03, miss_weight=miss_weight)
    for dets in ([pts[:5], None, pts[5:9], pts[9:], pts[2:6]], [None, np.zeros((0, 2)), pts, None, pts[:1]]):
        fast, slow = _both(lik, SPEC, models, dets)
        for name in ("fired", "covered", "detector_likelihoods", "likelihood"):
            assert getattr(fast, name).tobytes() == getattr(slow, name).tobytes(), name


def test_border_inflow_is_the_warp_of_an_empty_grid_bit_for_bit() -> None:
    """warp_outside (the cells near the border only) against warp_bilinear of zeros and the numpy warp: small
    and large motions, rotations of any angle, shifts beyond the grid, whole-cell shifts, one pose or several."""
    from gridbridge import kernels
    from gridbridge.ego_motion import border_inflow

    rng = np.random.default_rng(12)
    specs = (SPEC, GridSpec(nx=58, ny=68, resolution=0.3, x0=-7.2, y0=-10.2), GridSpec(nx=5, ny=3, resolution=0.1))
    for k in range(400):
        spec = specs[k % 3]
        s = int(rng.integers(1, 8))
        scale = float(rng.choice([0.01, 0.1, 1.0, 20.0]))
        poses = np.column_stack(
            (rng.normal(0, scale, s), rng.normal(0, scale, s), rng.choice([0.0, 1e-4, 0.05, 1.0, np.pi / 2, 3.0], s))
        )
        if k % 7 == 0:
            poses[:, :2] = np.round(poses[:, :2] / spec.resolution) * spec.resolution
            poses[:, 2] = 0.0
        w = rng.random(s) + 0.1
        w = w / w.sum()
        outside = float(rng.choice([0.5, 0.02, 1.0]))
        grid = (float(spec.x0), float(spec.y0), float(spec.resolution))
        want = kernels.warp_bilinear(np.zeros(spec.shape), grid, poses, w, outside)
        got = kernels.warp_outside((spec.nx, spec.ny), grid, poses, w, outside)
        assert got.tobytes() == want.tobytes(), k
        fast, slow = _both(border_inflow, spec, poses, w, outside=outside)
        with jit.override(True):
            assert fast.tobytes() == warp_belief(np.zeros(spec.shape), spec, poses, w, outside=outside).tobytes()
        np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-12)
    zero = np.zeros((1, 3))
    assert not border_inflow(SPEC, zero).any() and border_inflow(SPEC, zero).shape == SPEC.shape
    with pytest.raises(ValueError, match="poses"):
        border_inflow(SPEC, np.zeros((2, 2)))


def test_warp_at_some_cells_is_the_whole_warp_there_bit_for_bit() -> None:
    """warp_at (each pose over the cells) against warp_bilinear(...)[cells] (each cell over the poses): the same sums
    in the same order, bit for bit; random beliefs and cells, motions small and large."""
    from gridbridge import kernels

    rng = np.random.default_rng(13)
    spec = GridSpec(nx=31, ny=24, resolution=0.3, x0=-4.0, y0=-3.6)
    grid = (float(spec.x0), float(spec.y0), float(spec.resolution))
    for k in range(200):
        bel = rng.random(spec.shape) * (rng.random(spec.shape) < 0.5)
        outside = float(rng.choice([0.5, 0.02]))
        s = int(rng.integers(1, 8))
        poses = np.column_stack((rng.normal(0, 0.3, s), rng.normal(0, 0.3, s), rng.normal(0, 0.3, s)))
        if k % 5 == 0:
            poses[:, :2] *= 30.0
        w = rng.random(s) + 0.1
        w = w / w.sum()
        cells = np.flatnonzero(rng.random(spec.n_cells) < float(rng.choice([0.02, 0.3, 1.0])))
        want = kernels.warp_bilinear(bel, grid, poses, w, outside).ravel()[cells]
        got = kernels.warp_at(bel, grid, poses, w, outside, cells)
        assert got.tobytes() == want.tobytes(), k


def _warp_taps_numpy(
    shape: tuple[int, int], grid: tuple[float, float, float], poses: np.ndarray, cells: np.ndarray
) -> np.ndarray:
    """warp_taps' numpy twin: the same source coordinates (products and sums in the same order), the clamped
    tap (0, 0) and its three neighbours, those inside the grid."""
    x0, y0, res = grid
    inv = 1.0 / res
    nx, ny = shape
    read = np.zeros(shape, dtype=bool)
    i, j = cells // ny, cells % ny
    px, py = x0 + (i + 0.5) * res, y0 + (j + 0.5) * res
    for tx, ty, th in poses.tolist():
        c, sn = np.cos(th), np.sin(th)
        u = (tx + c * px - sn * py - x0) * inv - 0.5
        v = (ty + sn * px + c * py - y0) * inv - 0.5
        fi = np.clip(np.floor(u), -2.0, float(nx)).astype(np.intp)
        fj = np.clip(np.floor(v), -2.0, float(ny)).astype(np.intp)
        for a in (0, 1):
            for b in (0, 1):
                ok = (fi + a >= 0) & (fi + a < nx) & (fj + b >= 0) & (fj + b < ny)
                read[fi[ok] + a, fj[ok] + b] = True
    return read


def test_warp_taps_are_the_cells_warp_at_reads() -> None:
    """warp_taps against its numpy twin (the same mask) and against warp_at itself: a belief that differs from
    the given one (NaN) everywhere else warps to the same floats, bit for bit; motions small and large (taps
    beyond the border), few to every cell."""
    from gridbridge import kernels

    rng = np.random.default_rng(17)
    spec = GridSpec(nx=31, ny=24, resolution=0.3, x0=-4.0, y0=-3.6)
    grid = (float(spec.x0), float(spec.y0), float(spec.resolution))
    for k in range(200):
        bel = rng.random(spec.shape)
        s = int(rng.integers(1, 8))
        poses = np.column_stack((rng.normal(0, 0.3, s), rng.normal(0, 0.3, s), rng.normal(0, 0.3, s)))
        if k % 5 == 0:
            poses[:, :2] *= 30.0
        w = rng.random(s) + 0.1
        w = w / w.sum()
        cells = np.flatnonzero(rng.random(spec.n_cells) < float(rng.choice([0.02, 0.3, 1.0])))
        taps = kernels.warp_taps(spec.shape, grid, poses, cells)
        assert taps.dtype == np.bool_ and np.array_equal(taps, _warp_taps_numpy(spec.shape, grid, poses, cells)), k
        want = kernels.warp_at(bel, grid, poses, w, 0.5, cells)
        got = kernels.warp_at(np.where(taps, bel, np.nan), grid, poses, w, 0.5, cells)
        assert got.tobytes() == want.tobytes(), k


@pytest.mark.parametrize("outside", [0.5, 0.0, 0.02])
def test_convolve_at_some_cells_is_the_whole_convolution_there_bit_for_bit(outside: float) -> None:
    """convolve_at against convolve_const (whose numpy twin is scipy's convolution) at the chosen cells, bit for
    bit, 0.0 at the others; the kernels of several time steps (radii), cells at the border included."""
    from gridbridge import kernels

    rng = np.random.default_rng(19)
    for k in range(60):
        spec = GridSpec(nx=int(rng.integers(1, 40)), ny=int(rng.integers(1, 40)), resolution=0.3)
        bel = rng.random(spec.shape) * (rng.random(spec.shape) < 0.5)
        kernel = people_motion_kernel(spec, dt=float(rng.choice([0.05, 0.133, 0.4])), form="integrated")
        at = rng.random(spec.shape) < float(rng.choice([0.05, 0.5, 1.0]))
        want = kernels.convolve_const(bel, kernel, outside)
        got = kernels.convolve_at(bel, kernel, outside, at)
        assert got[at].tobytes() == want[at].tobytes(), k
        blocks = np.repeat(at.reshape(spec.nx, -1, 4).any(axis=2), 4, axis=1) if spec.ny % 4 == 0 else None
        other = (got == 0.0) | (got == want)  # the rest of a computed block holds its value, other cells 0.0
        assert other.all() and (blocks is None or not got[~blocks].any()), k


def test_peak_candidates_are_the_maximum_filter_candidates() -> None:
    """classify_peaks' candidates by peak_candidates against peak_maxima's maximum filter: plateaus (ties), peaks
    at the border, windows of 1-4 cells, thresholds 0 to 0.9."""
    from gridbridge import kernels
    from gridbridge.classifiers import classify_peaks, maximum_window, ordered_candidates, peak_maxima

    rng = np.random.default_rng(14)
    for k in range(300):
        spec = GridSpec(nx=int(rng.integers(1, 30)), ny=int(rng.integers(1, 30)), resolution=0.3)
        q = float(rng.choice([4, 20, 1000]))  # few levels: plateaus of equal beliefs
        grid = np.round(rng.random(spec.shape) * q) / q
        threshold = float(rng.choice([0.0, 0.3, 0.5, 0.9]))
        sep = float(rng.choice([0.25, 0.6, 0.9, 1.2]))
        is_max, value = peak_maxima(grid, spec, sep)
        want = np.argwhere((value > threshold) & is_max)
        got = kernels.peak_candidates(grid, maximum_window(sep, spec.resolution), threshold)
        assert got.dtype == want.dtype and got.tobytes() == want.tobytes(), k
        fast, slow = _both(ordered_candidates, grid, spec, threshold, sep, 0.0)
        assert all(a.tobytes() == b.tobytes() for a, b in zip(fast, slow, strict=True))
        radius = float(rng.choice([0.0, 0.35, 0.7]))
        pf, ps = _both(classify_peaks, grid, spec, threshold=threshold, min_separation=sep, centroid_radius=radius)
        for name in ("positions", "scores", "sizes", "mask"):  # peak_centroids' sums and the numpy ones
            a, b = getattr(pf, name), getattr(ps, name)
            assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), name


def _convolve_reference(bel: np.ndarray, kernel: np.ndarray, outside: float) -> np.ndarray:
    """The linear prediction's sums as the compiled kernel adds them: per cell from 0.0 over the nonzero taps in
    row-major order, clipped (the order of the kernel before its cells were summed eight at a time)."""
    nx, ny = bel.shape
    rad = kernel.shape[0] // 2
    padded = np.full((nx + 2 * rad, ny + 2 * rad), outside)
    padded[rad : rad + nx, rad : rad + ny] = bel
    s = np.zeros((nx, ny))
    for a in range(kernel.shape[0]):
        for b in range(kernel.shape[1]):
            if kernel[a, b] != 0.0:
                s += kernel[a, b] * padded[2 * rad - a : 2 * rad - a + nx, 2 * rad - b : 2 * rad - b + ny]
    return np.clip(s, 0.0, 1.0)


def test_linear_prediction_sums_each_cell_in_tap_order_bit_for_bit() -> None:
    from gridbridge import kernels

    rng = np.random.default_rng(15)
    for k in range(60):
        spec = GridSpec(nx=int(rng.integers(1, 40)), ny=int(rng.integers(1, 40)), resolution=0.3)
        bel = rng.random(spec.shape) * (rng.random(spec.shape) < 0.6)
        kern = people_motion_kernel(spec, dt=float(rng.choice([0.05, 0.1333, 0.4])), form="integrated")
        outside = float(rng.choice([0.5, 0.02, 1.0]))
        got = kernels.convolve_const(bel, np.ascontiguousarray(kern), outside)
        assert got.tobytes() == _convolve_reference(bel, kern, outside).tobytes(), k


def test_bayes_update_is_the_numpy_update_bit_for_bit() -> None:
    """kernels.bayes_update against bayes_update_unchecked: random priors and likelihoods, the 0/0 cells (L = 1
    with prior 0, L = 0 with prior 1: the prior kept), exact 0, 1 and 0.5 values."""
    from gridbridge import kernels
    from gridbridge.measurement import bayes_update_unchecked

    rng = np.random.default_rng(23)
    for k in range(100):
        shape = (int(rng.integers(1, 40)), int(rng.integers(1, 40)))
        p, lik = rng.random(shape), rng.random(shape)
        for a in (p, lik):
            a[rng.random(shape) < 0.1] = rng.choice([0.0, 1.0, 0.5])
        got, want = kernels.bayes_update(p, lik), bayes_update_unchecked(p, lik)
        assert got.tobytes() == want.tobytes(), k
    p, lik = np.array([[0.0, 1.0, 0.0, 1.0]]), np.array([[1.0, 0.0, 0.0, 1.0]])
    assert kernels.bayes_update(p, lik).tobytes() == bayes_update_unchecked(p, lik).tobytes()


def test_appearance_compiled_is_the_numpy_one_bit_for_bit() -> None:
    """Appearance.apply with a field of view, compiled (kernels.appear) against its numpy path: random priors
    (0 and 1 included), masks and time steps."""
    rng = np.random.default_rng(29)
    for k in range(60):
        shape = (int(rng.integers(1, 40)), int(rng.integers(1, 40)))
        p = rng.random(shape)
        p[rng.random(shape) < 0.1] = rng.choice([0.0, 1.0])
        where = rng.random(shape) < 0.7
        app = Appearance(rate=float(rng.choice([0.0, 0.1, 2.0])))
        fast, slow = _both(app.apply, p, float(rng.uniform(0.01, 1.0)), where=where)
        assert fast.dtype == slow.dtype and fast.tobytes() == slow.tobytes(), k


@pytest.mark.parametrize("on", [True, False])
def test_grid_components_refuse_a_bad_belief_by_name_on_both_forms(on: bool) -> None:
    """The compiled forms check the belief in one pass (all_probabilities) and name it as the numpy forms do; a
    belief of another dtype or layout is converted and gives the same result."""
    spec = GridSpec.centred_on_edge(11, 9, 0.3)
    bel = np.random.default_rng(2).random(spec.shape)
    odo = Odometry(v=0.3, omega=0.2)
    with jit.override(on):
        for bad, match in ((np.full(spec.shape, np.nan), "belief contains NaN"), (bel + 1.0, r"belief must hold")):
            for call in (
                lambda b: PaperPrediction().predict(b, spec, 0.1),
                lambda b: LinearPrediction().predict(b, spec, 0.1),
                lambda b: VelocityEgoMotion().predict(b, spec, odo, 0.1),
            ):
                with pytest.raises(ValueError, match=match):
                    call(bad)
        with pytest.raises(ValueError, match="belief must have shape"):
            VelocityEgoMotion().predict(bel[:5], spec, odo, 0.1)
        with pytest.raises(ValueError, match="belief must be a 2-D array"):
            PaperPrediction().predict(bel.ravel(), spec, 0.1)
        with pytest.raises(ValueError, match="dt"):
            LinearPrediction().predict(bel, spec, 0.0)
        same = LinearPrediction().predict(np.asfortranarray(bel).astype(np.float32), spec, 0.1)
        want = LinearPrediction().predict(bel.astype(np.float32).astype(np.float64), spec, 0.1)
        assert same.tobytes() == want.tobytes()


def test_bayes_update_compiled_is_numpy_bit_for_bit_and_checks_by_name() -> None:
    """bayes_update of float64 probability arrays runs compiled (any shape), the same bits as the numpy form; a
    NaN, a value out of [0, 1] or differing shapes are refused by name on both forms."""
    from gridbridge import bayes_update

    rng = np.random.default_rng(4)
    for shape in ((30, 30), (900,), (3, 4, 5)):
        p, lik = rng.random(shape), rng.random(shape)
        p.flat[:3], lik.flat[:3] = (0.0, 1.0, 1.0), (1.0, 0.0, 1.0)  # 0/0 keeps the prior
        with jit.override(True):
            fast = bayes_update(p, lik)
        with jit.override(False):
            slow = bayes_update(p, lik)
        assert fast.shape == shape and fast.tobytes() == slow.tobytes()
    for on in (True, False):
        with jit.override(on):
            with pytest.raises(ValueError, match="prior contains NaN"):
                bayes_update(np.full(4, np.nan), np.full(4, 0.5))
            with pytest.raises(ValueError, match="likelihood must hold probabilities"):
                bayes_update(np.full(4, 0.5), np.full(4, 1.5))
            with pytest.raises(ValueError, match="shapes differ"):
                bayes_update(np.full(4, 0.5), np.full(5, 0.5))
