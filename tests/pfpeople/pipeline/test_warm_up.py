"""The back end's warm-up (:mod:`pfpeople.pipeline.warm_up`): it changes nothing of a run, and after
``Pipeline.prepare`` a run's frames load no compiled kernel."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import numpy as np
import pytest

from gridbridge import jit
from gridbridge.ego_motion import Odometry
from gridbridge.grid import GridSpec
from gridbridge.params import DetectorModel
from pfpeople.config import ClassifierConfig, FilterConfig
from pfpeople.pipeline.assembly import build_classifier
from pfpeople.pipeline.runner import make_filter
from pfpeople.pipeline.warm_up import warm_up_back_end

pytestmark = pytest.mark.skipif(not jit.AVAILABLE, reason="numba is not installed: nothing to warm up")

MODELS = [
    DetectorModel(name="legs", ppv=0.8, fnr=0.4, fov_min=-2.0, fov_max=2.0, max_range=8.0, mount_x=0.3, mount_yaw=0.2)
]


def _state(filt: object) -> bytes:
    """The bytes of a filter's belief, particles and random generator state (what a step reads)."""
    parts = [np.asarray(filt.belief).tobytes()]  # type: ignore[attr-defined]
    state = getattr(filt, "state", None)
    if state is not None:
        parts += [np.asarray(getattr(state, k)).tobytes() for k in ("x", "y", "vx", "vy")]
    rng = getattr(filt, "rng", None)
    if rng is not None:
        parts.append(repr(rng.bit_generator.state).encode())
    return b"".join(parts)


@pytest.mark.parametrize("kind", ["grid", "particle"])
def test_warm_up_leaves_the_filter_as_it_was(kind: str) -> None:
    """A warmed-up filter and a fresh twin give the same posteriors, bit for bit, over three steps."""
    spec = GridSpec()
    cfg = FilterConfig(kind=kind, n_particles=2000, seed=3) if kind == "particle" else FilterConfig(kind=kind)
    warmed, fresh = make_filter(cfg, spec, MODELS), make_filter(cfg, spec, MODELS)
    before = _state(warmed)
    assert warm_up_back_end(warmed, build_classifier(ClassifierConfig()), spec, MODELS)
    assert _state(warmed) == before
    dets = [np.array([[2.0, 0.5], [1.0, -1.0]])]
    for odometry in (None, Odometry(v=0.4, omega=0.1), Odometry(v=0.4, omega=-0.2)):
        a, b = warmed.step(dets, odometry, 0.1), fresh.step(dets, odometry, 0.1)
        assert np.asarray(a.posterior).tobytes() == np.asarray(b.posterior).tobytes()
    assert _state(warmed) == _state(fresh)


def test_warm_up_skips_a_filter_it_cannot_copy() -> None:
    """A caller's filter that cannot be deep-copied (it holds a lock) is left alone: False, no error."""

    class Locked:
        def __init__(self) -> None:
            self.lock = threading.Lock()

        def step(self, *args: object) -> None:
            raise AssertionError("the warm-up must not step the run's filter")

    assert warm_up_back_end(Locked(), build_classifier(ClassifierConfig(kind="blobs")), GridSpec(), MODELS) is False


def test_a_run_loads_no_kernel_in_its_frames(tmp_path: Path) -> None:
    """With the starter configuration of a simulated 768-beam scene (the README's way), every compiled kernel
    the frames call was loaded by ``Pipeline.prepare``: no numba dispatcher gains a signature during the frames,
    for either filter (a fresh interpreter, so earlier tests' loads do not hide a miss)."""
    from evaluation.scenarios.scan import write_scene_bag
    from pfpeople.io.bag.inspect import inspect_path, starter_config

    sb = write_scene_bag("wheelchair", tmp_path / "scene", frames=30)
    cfg = tmp_path / "starter.toml"
    cfg.write_text(starter_config(inspect_path(sb.bag)), encoding="utf-8")
    script = textwrap.dedent(
        f"""
        import gc
        from dataclasses import replace
        from numba.core.registry import CPUDispatcher
        from pfpeople.config import load_config
        from pfpeople.io.bag.reader import BagSource
        from pfpeople.pipeline.runner import Pipeline

        def signatures():
            return {{(d.py_func.__module__, d.py_func.__qualname__, s) for d in gc.get_objects()
                    if isinstance(d, CPUDispatcher) for s in d.signatures}}

        base = load_config({str(cfg)!r})
        for kind in ("grid", "particle"):
            cfg = replace(base, filter=replace(base.filter, kind=kind))
            with BagSource({str(sb.bag)!r}) as src:
                pipe = Pipeline(cfg, front_process=False)
                pipe.prepare(src)
                before = signatures()
                pipe.run(src, {str(tmp_path)!r} + "/run_" + kind)
            new = sorted(signatures() - before)
            print(kind, len(before), "NEW" if new else "none", *new, sep="\\n")
        """
    )
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    lines = out.stdout.split("\n")
    assert lines.count("none") == 2, out.stdout  # no kernel loaded in the frames, grid and particle


def test_warm_up_skips_a_filter_whose_step_is_wrapped() -> None:
    """A filter with a wrapper on its instance's ``step`` (the wrapper's closure holds the original's bound step,
    which a deep copy shares) is not warmed up: the original is never stepped."""
    spec = GridSpec()
    filt = make_filter(FilterConfig(kind="grid"), spec, MODELS)
    step, calls = filt.step, []

    def wrapped(*args: object) -> object:
        calls.append(1)
        return step(*args)

    filt.step = wrapped  # type: ignore[method-assign]
    assert warm_up_back_end(filt, build_classifier(ClassifierConfig()), spec, MODELS) is False
    assert calls == []
