"""Replay logged detections through any filter and classifier, and score the people it finds.

Detectors are the slow part of a run; the filter and the classifier are what the benchmark compares. A
:class:`ReplayLog` holds, per frame, each detector's detections (grid frame), the odometry controls, ``dt`` and
the ground truth, taken either

* from a detection-level scenario (:mod:`evaluation.scenarios`: synthetic walkers or ETH/UCY replays), or
* from a run directory written by ``pfpeople run`` (``detections.csv``, ``frames.csv``, ``run.json``), with a
  ground-truth CSV (people annotated), or with ``nobody=True`` for a recording without people (every person
  found is a false positive), or ``recall_only=True`` when the ground truth does not annotate everybody.

:func:`replay` runs a filter factory and a classifier over the log; :func:`score_log` scores each detector and
the filter output with the one-to-one matching of :mod:`evaluation.metrics.detection` (gate 0.5 m by default), the same
rule ``pfpeople-eval score`` uses.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from evaluation.metrics.detection import DetectionAccumulator
from gridbridge.classifiers import Classifier, People, classify_frame
from gridbridge.ego_motion import Odometry, odometry_pose
from gridbridge.grid import GridSpec
from gridbridge.params import DetectorModel
from pfpeople.track.reported_people import point_like, support_positions

__all__ = [
    "ReplayLog",
    "ReplayResult",
    "log_from_run",
    "log_from_scenario",
    "replay",
    "score_log",
    "step_and_classify",
]

FilterFactory = Callable[[GridSpec, Sequence[DetectorModel]], Any]


@dataclass(frozen=True, eq=False)
class ReplayLog:
    """Per-frame inputs of a filter and the truth to score it against.

    Attributes
    ----------
    name : str
    spec : GridSpec
    models : tuple of DetectorModel
        One per detector, mounts included (grid frame).
    dt : ndarray, shape (F,)
        Seconds since the previous frame.
    odometry : list of Odometry or None, length F
    detections : list, length F
        Per frame, one ``(M, 2)`` array (m, grid frame) or None (no data) per detector.
    truth : list of ndarray, length F
        True people ``(P, 2)`` per frame (empty for a recording without people).
    recall_only : bool
        The truth does not annotate everybody: precision and false people are not meaningful.
    nobody : bool
        Nobody is there: every person found is a false positive.
    """

    name: str
    spec: GridSpec
    models: tuple[DetectorModel, ...]
    dt: NDArray[np.float64]
    odometry: list[Odometry | None]
    detections: list[list[NDArray[np.float64] | None]]
    truth: list[NDArray[np.float64]]
    recall_only: bool = False
    nobody: bool = False
    truth_ids: list[NDArray[np.int64]] | None = None
    stamps_s: NDArray[np.float64] | None = None
    #: Per frame, the support positions ``(K, 2)`` (m, grid frame) a run's tracker got (the laser detectors'
    #: single legs, static ones left out with ``suppressed``); None: the log has none.
    support: list[NDArray[np.float64]] | None = None

    def __len__(self) -> int:
        return len(self.dt)


def log_from_scenario(scenario: Any, *, noisy_odometry: bool = True, name: str | None = None) -> ReplayLog:
    """A log of a detection-level :class:`evaluation.scenarios.Scenario` (truth: people inside the grid)."""
    spec = scenario.spec
    frames = list(scenario.frames())
    truth, ids = [], []
    for fr in frames:
        inside = spec.contains(fr.people[:, 0], fr.people[:, 1])
        truth.append(np.asarray(fr.people[inside], dtype=float).reshape(-1, 2))
        ids.append(np.asarray(fr.person_ids[inside], dtype=np.int64))
    return ReplayLog(
        name=name or scenario.config.name,
        spec=spec,
        models=tuple(scenario.config.detector_models),
        dt=np.full(len(frames), float(scenario.dt)),
        odometry=[fr.odometry(noisy=noisy_odometry) for fr in frames],
        detections=[[np.asarray(d, dtype=float).reshape(-1, 2) for d in fr.detections] for fr in frames],
        truth=truth,
        truth_ids=ids,
        stamps_s=np.arange(len(frames), dtype=np.float64) * float(scenario.dt),
    )


def _model_from_json(fields: dict[str, Any]) -> DetectorModel:
    """A :class:`DetectorModel` from ``run.json`` ``detector_models``: an unbounded ``max_range`` is stored as the
    string ``"inf"`` (:mod:`pfpeople.io.jsonio`) and read back as a float."""
    text = {"name", "uncertainty"}
    values: dict[str, Any] = {k: float(v) if isinstance(v, str) and k not in text else v for k, v in fields.items()}
    return DetectorModel(**values)


def log_from_run(
    run_dir: str | Path,
    *,
    gt: str | Path | None = None,
    frame: str = "laser",
    nobody: bool = False,
    recall_only: bool = False,
    name: str | None = None,
    suppressed: bool = False,
    in_grid: bool = False,
) -> ReplayLog:
    """A log of a ``pfpeople run`` directory, with the truth of a GT CSV (or ``nobody``).

    ``in_grid``: keep only the true people inside the run's grid (the grid cannot show people outside it; as
    :func:`log_from_scenario` and the MOT scoring do); by default every annotated person.

    ``suppressed``: leave out the detections the run's static-clutter map suppressed (``static`` = 1), i.e. the
    detections its filter saw; by default every detection (each detector alone). The same holds for the
    support positions of ``support.csv`` (:attr:`ReplayLog.support`, when the run wrote it).
    """
    from evaluation.harness.run_truth import group_by_frame, truth_and_sources
    from pfpeople.io.ground_truth import read_gt_csv
    from pfpeople.io.run_dir import load_run

    run = load_run(run_dir)
    n = run.n_frames
    names = list(run.meta["detectors"])
    models = tuple(_model_from_json(m) for m in run.meta["detector_models"])
    fr = run.frames
    odo: list[Odometry | None] = [
        Odometry(v=float(v), omega=float(w), vy=float(vy)) if int(o) else None
        for v, w, vy, o in zip(fr["v_mps"], fr["omega_radps"], fr["vy_mps"], fr["odometry"], strict=True)
    ]
    no_data = [set(str(s).split(";")) if str(s) else set() for s in fr["no_data"]]
    det = run.detections
    per_name: dict[str, list[list[tuple[float, float]]]] = {nm: [[] for _ in range(n)] for nm in names}
    for f, nm, x, y, st in zip(det["frame"], det["detector"], det["x_m"], det["y_m"], det["static"], strict=True):
        if suppressed and int(st):
            continue
        per_name[str(nm)][int(f)].append((float(x), float(y)))
    detections: list[list[NDArray[np.float64] | None]] = []
    for k in range(n):
        row: list[NDArray[np.float64] | None] = []
        for nm in names:
            row.append(None if nm in no_data[k] else np.asarray(per_name[nm][k], dtype=float).reshape(-1, 2))
        detections.append(row)
    support = None
    if run.support is not None:
        s = run.support
        keep = ~s["static"].astype(bool) if suppressed else np.ones(len(s["frame"]), dtype=bool)
        support = group_by_frame(s["frame"][keep], np.column_stack((s["x_m"][keep], s["y_m"][keep])), n)
    if gt is not None:
        truth, _, _ = truth_and_sources(run, read_gt_csv(gt), frame=frame)
        if in_grid:
            spec = run.spec
            truth = [t[spec.contains(t[:, 0], t[:, 1])] if len(t) else t for t in truth]
    else:
        if not nobody:
            raise ValueError("log_from_run needs gt=CSV or nobody=True")
        truth = [np.zeros((0, 2)) for _ in range(n)]
    return ReplayLog(
        name=name or Path(run_dir).name,
        spec=run.spec,
        models=models,
        dt=np.asarray(fr["dt_s"], dtype=float),
        odometry=odo,
        detections=detections,
        truth=truth,
        recall_only=recall_only,
        nobody=nobody,
        stamps_s=np.asarray((fr["stamp_ns"] - fr["stamp_ns"][0]) * 1e-9, dtype=np.float64) if n else None,
        support=support,
    )


@dataclass
class ReplayResult:
    """People found per frame by one filter + classifier, and the time per frame."""

    people: list[NDArray[np.float64]]
    scores: list[NDArray[np.float64]]
    ms_per_frame: float
    beliefs: list[NDArray[np.float64]] = field(default_factory=list)


def step_and_classify(filt: Any, classifier: Any, log: ReplayLog, k: int, *, tracker: Any = None) -> tuple[Any, People]:
    """Frame ``k`` of ``log``: one filter step and the classification of its posterior (a stateful classifier
    also gets the grid's motion, from the frame's odometry); returns ``(step record, people)``.

    ``tracker``: a :class:`pfpeople.track.reported_people.PeopleTracker` built on ``classifier`` (as the pipeline's
    ``[tracking]``, :func:`pfpeople.pipeline.assembly.build_people_tracker`); the people are then the ones it reports
    (it gets the log's support positions and its point-like detectors' detections, as the run's tracker did)."""
    dt = float(log.dt[k])
    out = filt.step(log.detections[k], log.odometry[k], dt)
    observed = np.asarray(out.covered).any(axis=0)
    ego = odometry_pose(log.odometry[k], dt)
    found = classify_frame(classifier, out.posterior, log.spec, observed=observed, ego=ego)
    if tracker is not None:
        support = None if log.support is None else log.support[k]
        precise = support_positions([d for d, m in zip(log.detections[k], log.models, strict=True) if point_like(m)])
        found = tracker.step(
            found, out.posterior, log.spec, dt, observed=observed, ego=ego, support=support, detections=precise
        ).people
    return out, found


def replay(
    log: ReplayLog,
    make_filter: FilterFactory,
    classifier: Classifier,
    *,
    keep_beliefs: bool = False,
    post: Callable[[int, NDArray[np.float64], NDArray[np.float64]], tuple[Any, Any]] | None = None,
) -> ReplayResult:
    """Run a fresh filter from ``make_filter(spec, models)`` and ``classifier`` over every frame.

    ``post(k, positions, scores) -> (positions, scores)`` may post-process the people of frame k (a tracker).
    """
    filt = make_filter(log.spec, log.models)
    if hasattr(classifier, "reset"):  # a stateful classifier (hysteresis) starts afresh
        classifier.reset()
    people, scores, beliefs, times = [], [], [], []
    for k in range(len(log)):
        t0 = time.perf_counter()
        out, found = step_and_classify(filt, classifier, log, k)
        pos, sc = found.positions, found.scores
        if post is not None:
            pos, sc = post(k, pos, sc)
        times.append(time.perf_counter() - t0)
        people.append(np.asarray(pos, dtype=float).reshape(-1, 2))
        scores.append(np.asarray(sc, dtype=float))
        if keep_beliefs:
            beliefs.append(np.asarray(out.posterior))
    return ReplayResult(
        people=people,
        scores=scores,
        ms_per_frame=1e3 * float(np.median(times)) if times else math.nan,
        beliefs=beliefs,
    )


def _summary(acc: DetectionAccumulator, log: ReplayLog) -> dict[str, float]:
    s = acc.summary()
    out = {"recall": s["recall"], "precision": s["precision"], "fp_per_frame": acc.fp / max(acc.frames, 1)}
    if log.nobody:
        out["recall"] = out["precision"] = math.nan
    elif log.recall_only:
        out["precision"] = out["fp_per_frame"] = math.nan
    out.update(tp=acc.tp, fp=acc.fp, fn=acc.fn, frames=acc.frames)
    return out


def score_log(
    log: ReplayLog, people: Sequence[NDArray[np.float64]] | None = None, *, gate: float = 0.5
) -> dict[str, dict[str, float]]:
    """Recall, precision and false people per frame of each detector (and of ``people`` as ``"fused"``).

    Detections and people outside the grid are not counted (the grid cannot show them, and the truth of a
    scenario is limited to it); truth outside the grid counts as missed by everybody.
    """
    spec = log.spec
    out: dict[str, dict[str, float]] = {}
    for i, model in enumerate(log.models):
        acc = DetectionAccumulator(gate=gate)
        for k in range(len(log)):
            d = log.detections[k][i]
            d = np.zeros((0, 2)) if d is None else d
            d = d[spec.contains(d[:, 0], d[:, 1])] if len(d) else d
            acc.add(d, log.truth[k])
        out[model.name] = _summary(acc, log)
    if people is not None:
        acc = DetectionAccumulator(gate=gate)
        for k in range(len(log)):
            acc.add(people[k], log.truth[k])
        out["fused"] = _summary(acc, log)
    return out
