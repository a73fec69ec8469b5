"""Per-stage CPU time of a pipeline run, by wrapping the stages' functions with timers.

:func:`timed_stages` patches the functions that make up the stages of ``pfpeople run`` (bag reading, scan
decoding, segmentation, segment features, the segment classifiers, the clutter map, the filter, the
classification of the grid, the tracker and the run directory writer) with accumulators of the calling
thread's CPU time (``time.thread_time``: on a loaded machine far steadier than the wall clock; a one-process
pipeline runs in one thread), runs the body of the ``with`` block and restores them. Nested stages
(segmentation inside the detectors, the map update inside the clutter stage) are reported inclusive: a
parent's time contains its children's. The patch points are looked up by name and skipped when absent, so the
same code measures an older release (:mod:`evaluation.bench.release_baseline`). Timer overhead: about a microsecond
per call.
"""

from __future__ import annotations

import importlib
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

__all__ = ["STAGES", "module_exists", "timed_stages"]

_clock = time.thread_time

#: (stage, module, attribute path, generator): ``attribute path`` is ``"name"`` for a module function (patched in
#: every listed module that imported it) or ``"Class.method"``. Each module is listed by its name and, after it,
#: by its name before the folder layout of round three, so that the previous release is measured too. The indented stage
#: names are nested in the one above them.
STAGES: tuple[tuple[str, tuple[str, ...], str, bool], ...] = (
    ("reading", ("pfpeople.pipeline.runner", "pfpeople.pipeline"), "Pipeline._messages", True),
    ("ego-motion", ("pfpeople.pipeline.ego_stage",), "EgoMotionStage.begin", False),
    ("  scan matching", ("pfpeople.perception.scan_matching", "pfpeople.scanmatch"), "ScanOdometry.update", False),
    ("detectors", ("pfpeople.pipeline.detection",), "DetectionStage.detect", False),
    ("detectors ", ("pfpeople.pipeline.runner", "pfpeople.pipeline"), "Pipeline._detect", False),
    ("  decoding", ("pfpeople.detect.adapters", "pfpeople.adapters"), "laser_from_msg", False),
    (
        "  segmentation",
        ("pfpeople.detect.segments", "pfpeople.detect.legs", "pfpeople.detectors.segments", "pfpeople.detectors.legs"),
        "segment_scan",
        False,
    ),
    ("  features", ("pfpeople.detect.segments", "pfpeople.detectors.segments"), "segment_features", False),
    ("  leg classifier", ("pfpeople.detect.legs", "pfpeople.detectors.legs"), "LegDetector.leg_mask", False),
    ("  boosted classifier", ("pfpeople.detect.boosted", "pfpeople.detectors.boosted"), "boost_scores", False),
    (
        "clutter",
        ("pfpeople.pipeline.clutter_stage", "pfpeople.perception.clutter_stage", "pfpeople.suppression"),
        "ClutterStage.step",
        False,
    ),
    ("  map update", ("pfpeople.perception.clutter_map", "pfpeople.clutter"), "StaticClutterMap.update", False),
    (
        "  clutter queries",
        ("pfpeople.perception.clutter_map", "pfpeople.clutter"),
        "ClutterSuppressor.is_clutter",
        False,
    ),
    ("  moving people", ("pfpeople.perception.clutter_map", "pfpeople.clutter"), "MovingPeople.update", False),
    ("filter", ("gridbridge.filter",), "GridFilter.step", False),
    ("filter ", ("pfpeople.particle.filter", "pfpeople.particle_filter"), "ParticleFilter.step", False),
    (
        "classification",
        ("pfpeople.pipeline.back", "pfpeople.pipeline.runner", "pfpeople.pipeline"),
        "classify_frame",
        False,
    ),
    ("tracking", ("pfpeople.track.reported_people", "pfpeople.mot.people"), "PeopleTracker.step", False),
    ("writing", ("pfpeople.pipeline.sinks", "pfpeople.io.sinks", "pfpeople.sinks"), "RunDirSink.write", False),
)


def module_exists(name: str) -> bool:
    """Whether module ``name`` is a file of the packages imported now (``pfpeople`` of this checkout or of the
    previous release): a release's worker must not import a module it lacks, which an editable install of this
    checkout would otherwise supply from here."""
    top, _, rest = name.partition(".")
    path = Path(importlib.import_module(top).__file__ or "").parent.joinpath(*rest.split(".")) if rest else None
    return path is None or path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


def _timed(fn: Callable[..., Any], acc: list[float], generator: bool) -> Callable[..., Any]:
    """``fn`` adding its CPU seconds to ``acc[0]`` (for a generator: the time of every resumption)."""
    if generator:

        def gen(*args: Any, **kwargs: Any) -> Iterator[Any]:
            it = iter(fn(*args, **kwargs))
            while True:
                t0 = _clock()
                try:
                    item = next(it)
                except StopIteration:
                    acc[0] += _clock() - t0
                    return
                acc[0] += _clock() - t0
                yield item

        return gen

    def call(*args: Any, **kwargs: Any) -> Any:
        t0 = _clock()
        try:
            return fn(*args, **kwargs)
        finally:
            acc[0] += _clock() - t0

    return call


@contextmanager
def timed_stages() -> Iterator[dict[str, float]]:
    """Time the stages of :data:`STAGES` inside the ``with`` block.

    Yields
    ------
    dict of str to float
        Stage name (stripped; the two filters' entries merged into ``"filter"``) to seconds, filled while the
        block runs; stages whose function does not exist in the imported packages are left out.
    """
    undo: list[tuple[Any, str, Any]] = []
    accs: dict[str, list[float]] = {}
    out: dict[str, float] = {}
    try:
        for stage, modules, path, generator in STAGES:
            owner_name, _, attr = path.rpartition(".")
            acc = accs.setdefault(stage.strip(), [0.0])
            for mod_name in modules:
                if not module_exists(mod_name):
                    continue
                try:
                    owner: Any = importlib.import_module(mod_name)
                except ImportError:
                    continue
                if owner_name:
                    owner = getattr(owner, owner_name, None)
                if owner is None or not hasattr(owner, attr):
                    continue
                original = owner.__dict__.get(attr) if isinstance(owner, type) else getattr(owner, attr)
                if original is None:
                    continue
                undo.append((owner, attr, original))
                setattr(owner, attr, _timed(original, acc, generator))
        yield out
    finally:
        for owner, attr, original in reversed(undo):
            setattr(owner, attr, original)
        patched = {str(a) for _o, a, _f in undo}
        for stage, _m, path, _g in STAGES:
            if path.rpartition(".")[2] in patched:
                out[stage.strip()] = accs[stage.strip()][0]
