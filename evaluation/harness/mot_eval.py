"""Multi-person tracking evaluation: the tracker on fused filter output vs tracking-by-detection, CLEAR-MOT.

Two harnesses, one tracker (:class:`pfpeople.track.MultiPersonTracker`) and one scorer
(:func:`evaluation.metrics.clear_mot.clear_mot`):

- **Scenario** (:func:`evaluate_scenario`): the detection-level simulator (:mod:`evaluation.scenarios`), with
  true person ids per frame. Sources: each filter (:class:`evaluation.harness.ab.FilterSpec`: the grid filter, the
  particle filter) followed by a classifier ``classify(belief, spec) -> (positions (K, 2), scores (K,))``
  (default :func:`peak_classifier`), and the baseline: the tracker fed with each detector's raw detections and
  with all detectors' detections merged (:func:`merge_detections`). Ego-motion for the tracker: the reported
  (noisy) odometry of the frame, ``odometry_pose(odometry, dt)``, as the filters get. Ground truth and
  hypotheses are restricted to the grid (the grid cannot show people outside it).
- **Run directory** (:func:`evaluate_run`): a ``pfpeople run`` output (``people.csv``: the filter's people;
  ``detections.csv``: each detector) against a GT CSV with person ids (:mod:`pfpeople.io.ground_truth`), with the
  followed-person figure: the fraction of the annotated frames of one person where a confirmed track lies
  within ``gate`` of it (CLEAR-MOT matching, so a matched track is one-to-one), and the identity switches on
  that person. Ego-motion: ``frames.csv`` (``v_mps``, ``omega_radps``, ``vy_mps``, ``dt_s``; frames without
  odometry count as standing).

- **Replay log** (:func:`evaluate_log`, the MOT table of ``pfpeople-eval benchmark``): a scenario's log, the
  recommended filter and the tracker fed exactly as ``pfpeople run`` feeds it (the people plus the weaker belief
  peaks, :func:`pfpeople.track.tracker_inputs`), against tracking-by-detection on each detector and all merged.

Bag runs are also scored on the run's own ``tracks.csv`` (:func:`read_tracks_csv`: the shipped output), and,
for a GT with a ``hit_beams`` column (the scan-level scenes), optionally on the people a laser can see only
(``min_hit_beams``; the others are don't-care). The tracker's hypotheses in a frame are its confirmed tracks
after the update (coasting ones included).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from evaluation.harness.ab import FilterSpec
from evaluation.harness.replay import ReplayLog
from evaluation.harness.run_truth import group_by_frame, gt_to_grid
from evaluation.metrics.clear_mot import MotScores, clear_mot, hota
from evaluation.scenarios.scenario import Frame, Scenario
from gridbridge.classifiers import classify_frame, classify_peaks
from gridbridge.ego_motion import Odometry, odometry_pose
from gridbridge.geometry import Pose2D
from gridbridge.grid import GridSpec
from gridbridge.params import DetectorModel
from pfpeople.io.ground_truth import GroundTruth
from pfpeople.io.run_dir import RunData
from pfpeople.track import MultiPersonTracker, PeopleTracker, TrackerConfig
from pfpeople.track.reported_people import point_like, support_positions

__all__ = [
    "FUSED_SOURCES",
    "Classifier",
    "MotRow",
    "detector_config",
    "evaluate_log",
    "evaluate_run",
    "evaluate_scenario",
    "format_rows",
    "merge_detections",
    "peak_classifier",
    "read_tracks_csv",
    "run_tracker",
]

Positions = NDArray[np.float64]
Classifier = Callable[[NDArray[np.float64], GridSpec], tuple[Positions, NDArray[np.float64]]]
HypFrames = list[tuple[NDArray[np.int64], Positions]]


def peak_classifier(
    belief: NDArray[np.float64], spec: GridSpec, *, threshold: float = 0.5, nms_radius: float = 0.6
) -> tuple[Positions, NDArray[np.float64]]:
    """People from a belief grid with the recommended classifier (:func:`gridbridge.classifiers.classify_peaks`):
    local maxima above ``threshold`` with non-maximum suppression within ``nms_radius`` (m); positions (K, 2) in
    the grid frame and scores (K,) (the peak beliefs)."""
    found = classify_peaks(belief, spec, threshold=threshold, min_separation=nms_radius)
    return found.positions, found.scores


def merge_detections(detections: Sequence[Positions], *, radius: float = 0.4) -> Positions:
    """All detectors' detections as one set: greedy clustering within ``radius`` (m), cluster means.

    Detections are taken in the given order (detector by detector); each joins the first cluster whose mean is
    within ``radius``, else starts one. The usual way a tracking-by-detection tracker merges detectors.
    """
    pts = [np.asarray(d, dtype=float).reshape(-1, 2) for d in detections]
    allp = np.concatenate(pts) if pts else np.zeros((0, 2))
    sums: list[NDArray[np.float64]] = []
    counts: list[int] = []
    for p in allp:
        best, best_d = -1, radius
        for c, (s, n) in enumerate(zip(sums, counts, strict=True)):
            d = float(np.hypot(*(s / n - p)))
            if d <= best_d:
                best, best_d = c, d
        if best < 0:
            sums.append(p.copy())
            counts.append(1)
        else:
            sums[best] += p
            counts[best] += 1
    if not sums:
        return np.zeros((0, 2))
    return np.array([s / n for s, n in zip(sums, counts, strict=True)])


def run_tracker(
    positions: Sequence[Positions],
    dts: Sequence[float],
    *,
    scores: Sequence[NDArray[np.float64] | None] | None = None,
    egos: Sequence[Pose2D | None] | None = None,
    config: TrackerConfig | None = None,
    support: Sequence[Positions] | None = None,
) -> HypFrames:
    """Run a fresh tracker over a sequence; per frame the confirmed tracks' ``(ids, positions)``.

    ``support``: per frame, support positions (single legs, :class:`pfpeople.track.multi_person.MultiPersonTracker`
    step 4c) that continue confirmed tracks."""
    tracker = MultiPersonTracker(config)
    out: HypFrames = []
    for k, z in enumerate(positions):
        tr = tracker.update(
            z,
            dts[k],
            scores=None if scores is None else scores[k],
            ego=None if egos is None else egos[k],
            support=None if support is None else support[k],
        )
        ids = np.array([t.id for t in tr], dtype=np.int64)
        pos = np.array([[t.x, t.y] for t in tr], dtype=float).reshape(-1, 2)
        out.append((ids, pos))
    return out


@dataclass
class MotRow:
    """One row of the tracking table: a sequence, a source, its scores (``extra``: ``hota``, ``deta``, ``assa``
    from :func:`evaluation.metrics.clear_mot.hota`, and for some rows ``followed``)."""

    sequence: str
    source: str
    scores: MotScores
    extra: dict[str, Any] = field(default_factory=dict)


def hota_extra(
    gt: Sequence[tuple[Any, Any]], hyp: Sequence[tuple[Any, Any]], *, gate: float, **region: Any
) -> dict[str, float]:
    """``{"hota", "deta", "assa"}`` of :func:`evaluation.metrics.clear_mot.hota` (NaN without trackeval)."""
    h = hota(gt, hyp, gate=gate, **region)
    return {"hota": h.hota, "deta": h.deta, "assa": h.assa}


def _in_grid(spec: GridSpec, ids: NDArray[np.int64], pos: Positions) -> tuple[NDArray[np.int64], Positions]:
    keep = spec.contains(pos[:, 0], pos[:, 1]) if len(pos) else np.zeros(0, dtype=bool)
    return ids[keep], pos[keep]


def _ego(frame: Frame, dt: float) -> Pose2D:
    return odometry_pose(frame.odometry(noisy=True), dt)


def evaluate_scenario(
    scenario: Scenario,
    *,
    filters: Sequence[FilterSpec] = (),
    classify: Classifier = peak_classifier,
    classifier_name: str = "peaks",
    detectors: bool = True,
    merged: bool = True,
    config: TrackerConfig | None = None,
    gate: float = 0.75,
    seed: int = 0,
    n_frames: int | None = None,
) -> list[MotRow]:
    """CLEAR-MOT of the tracker on each source over a scenario (see the module docstring).

    Parameters
    ----------
    scenario : Scenario
    filters : sequence of FilterSpec
        Filters whose posterior is classified and tracked (``FilterSpec.build``; particle filters seeded with
        ``seed``).
    classify : callable
        ``classify(belief, spec) -> (positions (K, 2), scores (K,))``.
    classifier_name : str
        Label of the classifier in the source column.
    detectors, merged : bool
        Add the tracking-by-detection rows: each detector alone, all detectors merged.
    config : TrackerConfig, optional
        Tracker parameters; default ``TrackerConfig(region=grid extent)``.
    gate : float
        Matching distance (m).
    n_frames : int, optional
        Only the first ``n_frames`` frames.
    """
    spec = scenario.spec
    if config is None:
        config = TrackerConfig(region=spec.extent)
    n = len(scenario) if n_frames is None else min(n_frames, len(scenario))
    frames = list(scenario.frames(0, n))
    dt = scenario.dt
    dts = [dt] * n
    egos = [_ego(fr, dt) for fr in frames]
    gt = [_in_grid(spec, fr.person_ids, fr.people) for fr in frames]
    name = scenario.config.name
    rows: list[MotRow] = []

    def score(source: str, hyp: HypFrames, **extra: Any) -> None:
        hyp = [_in_grid(spec, i, p) for i, p in hyp]
        rows.append(MotRow(name, source, clear_mot(gt, hyp, gate=gate), {**extra, **hota_extra(gt, hyp, gate=gate)}))

    models = scenario.config.detector_models
    for fs in filters:
        filt = fs.build(spec, models, seed)
        pos: list[Positions] = []
        sc: list[NDArray[np.float64]] = []
        for fr in frames:
            out = filt.step(fr.detections, fr.odometry(noisy=True), dt)
            p, s = classify(out.posterior, spec)
            pos.append(np.asarray(p, dtype=float).reshape(-1, 2))
            sc.append(np.clip(np.asarray(s, dtype=float).reshape(-1), 0.0, 1.0))
        score(f"{fs.name} + {classifier_name}", run_tracker(pos, dts, scores=sc, egos=egos, config=config))
    if detectors:
        for i, m in enumerate(models):
            det = [fr.outputs[i].positions.reshape(-1, 2) for fr in frames]
            score(f"{m.name} (raw)", run_tracker(det, dts, egos=egos, config=detector_config(config, m)))
    if merged:
        det = [merge_detections(fr.detections) for fr in frames]
        score("all detectors merged (raw)", run_tracker(det, dts, egos=egos, config=config))
    return rows


#: The fused sources of :func:`evaluate_log`: row label -> filter kind (the recommended mode of each).
FUSED_SOURCES = {"recommended (tracker)": "grid", "recommended particles (tracker)": "particle"}


def evaluate_log(
    log: ReplayLog,
    *,
    gate: float = 0.75,
    config: TrackerConfig | None = None,
    fused: Sequence[str] = tuple(FUSED_SOURCES),
    particle: Mapping[str, Any] | None = None,
) -> list[MotRow]:
    """CLEAR-MOT of a replay log with person ids (:func:`evaluation.harness.replay.log_from_scenario`): the recommended
    filters and tracker as ``pfpeople run`` runs them, and tracking-by-detection on each detector and all merged.

    Row ``"recommended (tracker)"``: the recommended grid filter (:func:`pfpeople.pipeline.assembly.build_filter` with
    the default :class:`~pfpeople.config.FilterConfig`), its peaks classifier, and the tracker fed as the pipeline
    feeds it (:class:`~pfpeople.config.TrackingConfig`: the peaks above ``peak_threshold`` update tracks,
    those above the classifier's threshold start them; the belief grid passed along). Row ``"recommended
    particles (tracker)"``: the same with the recommended particle filter (``FilterConfig(kind="particle")``, its
    seed 0). ``fused``: which of these rows (:data:`FUSED_SOURCES`). Ego-motion: the log's odometry controls.
    Detector rows as :func:`evaluate_scenario`. Truth and hypotheses inside the grid only. ``config``: tracker
    parameters (default ``TrackerConfig()``; the recommended rows confirm by evidence as a run does,
    ``TrackingConfig.confirm_evidence``, unless ``config`` sets ``confirm_evidence``; the detector rows by M of N).
    ``particle``: :class:`~pfpeople.config.FilterConfig` fields that replace the particle row's defaults (e.g.
    ``{"seed": 3}``).
    """
    if log.truth_ids is None:
        raise ValueError(f"log {log.name!r} has no person ids (truth_ids): CLEAR-MOT needs them")
    unknown = sorted(set(fused) - set(FUSED_SOURCES))
    if unknown:
        raise ValueError(f"fused sources {unknown} are none of {sorted(FUSED_SOURCES)}")
    spec = log.spec
    config = TrackerConfig() if config is None else config
    n = len(log)
    dts = [float(v) for v in log.dt]
    egos: list[Pose2D | None] = []
    for odo, dt in zip(log.odometry, dts, strict=True):
        egos.append(None if odo is None else odometry_pose(odo, dt))
    gt = [_in_grid(spec, log.truth_ids[k], log.truth[k]) for k in range(n)]
    rows: list[MotRow] = []

    def score(source: str, hyp: HypFrames) -> None:
        hyp = [_in_grid(spec, i, p) for i, p in hyp]
        rows.append(MotRow(log.name, source, clear_mot(gt, hyp, gate=gate), hota_extra(gt, hyp, gate=gate)))

    for source in fused:
        kind = FUSED_SOURCES[source]
        score(source, _fused_tracks(log, kind, config, dts, egos, particle if kind == "particle" else None))
    for i, m in enumerate(log.models):
        det: list[Positions] = []
        for k in range(n):
            d = log.detections[k][i]
            det.append(np.zeros((0, 2)) if d is None else d)
        score(f"{m.name} (raw)", run_tracker(det, dts, egos=egos, config=detector_config(config, m)))
    merged = [merge_detections([d for d in log.detections[k] if d is not None]) for k in range(n)]
    score("all detectors merged (raw)", run_tracker(merged, dts, egos=egos, config=config))
    return rows


def _fused_tracks(
    log: ReplayLog,
    kind: str,
    config: TrackerConfig,
    dts: Sequence[float],
    egos: Sequence[Pose2D | None],
    overrides: Mapping[str, Any] | None = None,
) -> HypFrames:
    """The confirmed tracks per frame of the recommended ``kind`` filter (``overrides``: other
    :class:`~pfpeople.config.FilterConfig` fields) + classifier + tracker over ``log``."""
    from pfpeople.config import ClassifierConfig, FilterConfig, TrackingConfig
    from pfpeople.pipeline.assembly import build_classifier, build_filter

    spec = log.spec
    filt = build_filter(FilterConfig(kind=cast(Any, kind), **dict(overrides or {})), spec, log.models)
    classifier = build_classifier(ClassifierConfig())
    tracking = TrackingConfig()
    tcfg = config
    if tcfg.confirm_evidence is None and tracking.confirm_evidence != "off":  # confirmed by evidence, as a run's
        tcfg = replace(tcfg, confirm_evidence=float(tracking.confirm_evidence))
    if tracking.peaks_above is not None:  # tracks start only from people, as the pipeline's
        tcfg = replace(tcfg, birth_min_score=max(tcfg.birth_min_score, float(getattr(classifier, "threshold", 0.0))))
    tracker = PeopleTracker(
        classifier,
        config=tcfg,
        peak_threshold=tracking.peaks_above,
        people="classified",
        snap_radius=tracking.snap_radius,
        observed_tracks_only=tracking.observed_tracks_only,
    )
    hyp: HypFrames = []
    for k in range(len(log)):
        dets = [np.zeros((0, 2)) if d is None else d for d in log.detections[k]]
        out = filt.step(dets, log.odometry[k], dts[k])
        belief = np.asarray(out.posterior, dtype=float)
        observed = np.asarray(out.covered).any(axis=0)
        found = classify_frame(classifier, belief, spec, observed=observed, ego=egos[k])
        precise = support_positions([d for d, m in zip(dets, log.models, strict=True) if point_like(m)])
        tr = tracker.step(found, belief, spec, dts[k], observed=observed, ego=egos[k], detections=precise).tracks
        hyp.append((np.array([t.id for t in tr], dtype=np.int64), np.array([[t.x, t.y] for t in tr]).reshape(-1, 2)))
    return hyp


def detector_config(config: TrackerConfig, model: DetectorModel) -> TrackerConfig:
    """The tracker configuration for one detector's raw detections: a detector whose model has a Gaussian
    position uncertainty (the camera) gets that uncertainty as measurement noise (RMS of its lateral and
    range standard deviations) and a metric gate of at least three of them; others keep ``config``."""
    if model.uncertainty != "gaussian":
        return config
    sigma = math.sqrt(0.5 * (model.sigma_lateral**2 + model.sigma_range**2))
    return replace(
        config,
        measurement_sigma=max(config.measurement_sigma, sigma),
        gate_distance=max(config.gate_distance, 3.0 * sigma),
    )


def _run_egos(run: RunData) -> tuple[list[float], list[Pose2D | None]]:
    fr = run.frames
    dts = [float(v) for v in fr["dt_s"]]
    egos: list[Pose2D | None] = []
    for k in range(run.n_frames):
        if int(fr["odometry"][k]) == 0:
            egos.append(None)
            continue
        odo = Odometry(v=float(fr["v_mps"][k]), omega=float(fr["omega_radps"][k]), vy=float(fr["vy_mps"][k]))
        egos.append(odometry_pose(odo, dts[k]))
    return dts, egos


def _gt_frames(
    run: RunData, gt: GroundTruth, frame: str, tolerance_ns: int | None
) -> list[tuple[NDArray[np.int64], Positions]]:
    fr = run.frames
    rows_frame, _ = gt.assign(fr["driver_index"], fr["stamp_ns"], fr["bag_time_ns"], tolerance_ns=tolerance_ns)
    xy = gt_to_grid(run, gt, frame)
    out: list[list[tuple[int, float, float]]] = [[] for _ in range(run.n_frames)]
    for f, pid, p in zip(rows_frame, gt.person_id, xy, strict=True):
        if 0 <= f < run.n_frames:
            out[int(f)].append((int(pid), float(p[0]), float(p[1])))
    res = []
    for rows in out:
        # one row per person and frame: a later GT row of the same person in the same frame replaces the earlier
        d = {pid: (x, y) for pid, x, y in rows}
        res.append((np.array(list(d), dtype=np.int64), np.array(list(d.values()), dtype=float).reshape(-1, 2)))
    return res


def evaluate_run(
    run: RunData,
    gt: GroundTruth,
    *,
    frame: str = "laser",
    config: TrackerConfig | None = None,
    gate: float = 0.75,
    sector: tuple[float, float] | None = None,
    max_range: float | None = None,
    follow_id: int | None = None,
    tolerance_ns: int | None = None,
    sources: Sequence[str] | None = None,
    classify: Classifier | None = peak_classifier,
    classifier_name: str = "peaks",
    in_grid: bool = True,
    min_hit_beams: int | None = None,
    followed: bool = True,
) -> list[MotRow]:
    """CLEAR-MOT of the tracker on a run's filter output and on each detector's detections.

    Parameters
    ----------
    run : RunData
        ``pfpeople.io.run_dir.load_run(...)``.
    gt : GroundTruth
        With person ids.
    frame : str
        Frame of the GT positions (as ``pfpeople-eval score --frame``).
    sector : (float, float), optional
        Bearing interval (rad) of what counts; ``max_range`` likewise (m).
    follow_id : int, optional
        Person for the followed-person figure (``extra["followed"]``); default: the GT id with the most rows.
    sources : sequence of str, optional
        Subset of the sources (default all): ``"filter"`` (the run's ``people.csv``), ``"grid + NAME"`` (the
        stored belief grids classified by ``classify``), each detector name and ``"all detectors merged"``.
    classify : callable or None
        Classifier of the stored belief grids (``grids.npy``); None: no such row.
    classifier_name : str
        Its label.
    in_grid : bool
        Score only ground truth and hypotheses inside the run's grid (the grid cannot show people outside it;
        as :func:`evaluate_scenario`).
    min_hit_beams : int, optional
        Visibility filter for a GT CSV with a ``hit_beams`` column (the scan-level scenes): a person hit by
        fewer laser beams in a frame is *don't care* there: removed from the truth, and a hypothesis matched
        to it (one-to-one within ``gate``) is removed too (neither a hit nor a false positive). The sequence
        name gets `` [hit_beams>=N]``. None: every annotated person counts.
    followed : bool
        Compute the followed-person figure (False: none, e.g. for a GT that annotates everybody).

    Sources: ``"filter (people.csv)"`` (the run's people tracked here, births from any of them), ``"grid +
    NAME"``, ``"tracks.csv (pipeline)"`` (the tracks the run itself wrote: the shipped output; when the run
    has a ``tracks.csv``; ``"tracks.csv (particle pipeline)"`` for a run of the particle filter),
    ``"NAME (raw)"`` per detector and ``"all detectors merged (raw)"``. When the run wrote ``support.csv`` (its
    tracker used single legs), each raw source's tracker gets its detectors' single legs as support too, as the
    run's tracker did.

    Returns
    -------
    list of MotRow
        ``extra["followed"]`` holds ``{"id", "annotated_frames", "matched_fraction", "id_switches"}``.
    """
    truth = _gt_frames(run, gt, frame, tolerance_ns)
    hidden: list[NDArray[np.float64]] | None = None
    if min_hit_beams is not None:
        beams = _gt_hit_beams(run, gt, tolerance_ns)
        hidden = []
        for k, (tids, tpos) in enumerate(truth):
            low = np.array([beams[k].get(int(i), 0) < min_hit_beams for i in tids], dtype=bool)
            hidden.append(tpos[low])
            truth[k] = (tids[~low], tpos[~low])
    spec = run.spec
    if in_grid:
        truth = [_in_grid(spec, i, p) for i, p in truth]
    dts, egos = _run_egos(run)
    n = run.n_frames
    if config is None:
        config = TrackerConfig(region=run.spec.extent)
    ppl = run.people
    inputs: dict[str, tuple[list[Positions], list[NDArray[np.float64]] | None]] = {}
    fpos = group_by_frame(ppl["frame"], np.column_stack((ppl["x_m"], ppl["y_m"])), n)
    # confidence of each person: its blob's mean probability (NaN when not recorded: counts as 1)
    prob = np.clip(np.nan_to_num(ppl["mean_probability"].astype(float), nan=1.0), 0.0, 1.0)
    fsc = [g[:, 0].copy() for g in group_by_frame(ppl["frame"], np.column_stack((prob, prob)), n)]
    inputs["filter"] = (fpos, fsc)
    if classify is not None and (sources is None or f"grid + {classifier_name}" in sources):
        spec = run.spec
        cpos: list[Positions] = []
        csc: list[NDArray[np.float64]] = []
        for k in range(n):
            p, s = classify(np.asarray(run.grids[k], dtype=float), spec)
            cpos.append(np.asarray(p, dtype=float).reshape(-1, 2))
            csc.append(np.clip(np.asarray(s, dtype=float).reshape(-1), 0.0, 1.0))
        inputs[f"grid + {classifier_name}"] = (cpos, csc)
    det = run.detections
    per_det: list[list[Positions]] = []
    support: dict[str, list[Positions] | None] = {}
    sup_det: list[list[Positions]] = []
    for name in run.meta["detectors"]:
        sel = det["detector"] == name
        d = group_by_frame(det["frame"][sel], np.column_stack((det["x_m"][sel], det["y_m"][sel])), n)
        inputs[f"{name} (raw)"] = (d, None)
        per_det.append(d)
        if run.support is not None:
            sp = run.support
            ss = sp["detector"] == name
            sup_det.append(group_by_frame(sp["frame"][ss], np.column_stack((sp["x_m"][ss], sp["y_m"][ss])), n))
            support[f"{name} (raw)"] = sup_det[-1]
    if len(per_det) > 1:
        inputs["all detectors merged (raw)"] = ([merge_detections([d[k] for d in per_det]) for k in range(n)], None)
        if sup_det:
            support["all detectors merged (raw)"] = [np.concatenate([d[k] for d in sup_det]) for k in range(n)]
    if sources is not None:
        wanted = set(sources)
        inputs = {k: v for k, v in inputs.items() if k in wanted or k.removesuffix(" (raw)") in wanted}
        has_tracks = bool({"tracks", "tracks.csv"} & wanted) and (run.path / "tracks.csv").is_file()
        if not inputs and not has_tracks:
            raise ValueError(f"sources {sorted(wanted)} name none of the run's sources")
    if not followed:
        follow_id = None
    elif follow_id is None and len(gt):
        ids, counts = np.unique(gt.person_id, return_counts=True)
        follow_id = int(ids[np.argmax(counts)])
    bags = run.meta.get("provenance", {}).get("bag") or []
    seq = Path(str(bags[0])).name.removesuffix(".zip").removesuffix(".bag") if bags else run.path.name
    if min_hit_beams is not None:
        seq += f" [hit_beams>={min_hit_beams}]"
    hyps: dict[str, HypFrames] = {}
    shipped = run.path / "tracks.csv"
    if shipped.is_file() and (sources is None or {"tracks", "tracks.csv"} & set(sources)):
        kind = run.meta.get("config", {}).get("filter", {}).get("kind", "grid")
        hyps["tracks.csv (particle pipeline)" if kind == "particle" else "tracks.csv (pipeline)"] = read_tracks_csv(
            shipped, n
        )
    for source, (pos, sc) in inputs.items():
        cfg = replace(config, birth_min_score=0.0) if source == "filter" else config
        hyps[source] = run_tracker(pos, dts, scores=sc, egos=egos, config=cfg, support=support.get(source))
    rows: list[MotRow] = []
    for source, hyp in hyps.items():
        if in_grid:
            hyp = [_in_grid(spec, i, p) for i, p in hyp]
        if hidden is not None:
            hyp = [_drop_matched(i, p, hidden[k], gate) for k, (i, p) in enumerate(hyp)]
        scores = clear_mot(truth, hyp, gate=gate, sector=sector, max_range=max_range)
        extra: dict[str, Any] = hota_extra(truth, hyp, gate=gate, sector=sector, max_range=max_range)
        if follow_id is not None:
            one = [(i[i == follow_id], p[i == follow_id]) for i, p in truth]
            fs = clear_mot(one, hyp, gate=gate, sector=sector, max_range=max_range)
            extra["followed"] = {
                "id": follow_id,
                "annotated_frames": fs.num_gt,
                "matched_fraction": fs.recall,
                "id_switches": fs.id_switches,
            }
        rows.append(MotRow(seq, f"{source} (people.csv)" if source == "filter" else source, scores, extra))
    return rows


def read_tracks_csv(path: str | Path, n_frames: int) -> HypFrames:
    """The confirmed tracks of a run's ``tracks.csv`` as per-frame ``(ids, positions)`` (``n_frames`` frames)."""
    ids: list[list[int]] = [[] for _ in range(n_frames)]
    pos: list[list[tuple[float, float]]] = [[] for _ in range(n_frames)]
    with Path(path).open(newline="") as fh:
        for line, row in enumerate(csv.DictReader(fh), start=2):
            try:
                f, tid, x, y = int(row["frame"]), int(row["id"]), float(row["x"]), float(row["y"])
            except (KeyError, TypeError, ValueError) as exc:
                raise ValueError(f"{path}: line {line}: needs frame, id, x, y: {exc}") from None
            if not 0 <= f < n_frames:
                raise ValueError(f"{path}: line {line}: frame {f} outside the run's {n_frames} frames")
            ids[f].append(tid)
            pos[f].append((x, y))
    return [
        (np.array(i, dtype=np.int64), np.array(p, dtype=float).reshape(-1, 2)) for i, p in zip(ids, pos, strict=True)
    ]


def _gt_hit_beams(run: RunData, gt: GroundTruth, tolerance_ns: int | None) -> list[dict[int, int]]:
    """Per run frame, ``{person id: hit_beams}`` from the GT CSV's ``hit_beams`` column (rows as ``gt``)."""
    with gt.path.open(newline="", encoding="utf-8-sig") as fh:
        reader = csv.DictReader(fh)
        if reader.fieldnames is None or "hit_beams" not in [c.strip() for c in reader.fieldnames]:
            raise ValueError(f"{gt.path}: min_hit_beams needs a hit_beams column")
        beams = [int(r["hit_beams"]) for r in reader if any(v for v in r.values())]
    if len(beams) != len(gt):
        raise ValueError(f"{gt.path}: {len(beams)} hit_beams values for {len(gt)} ground-truth rows")
    fr = run.frames
    rows_frame, _ = gt.assign(fr["driver_index"], fr["stamp_ns"], fr["bag_time_ns"], tolerance_ns=tolerance_ns)
    out: list[dict[int, int]] = [{} for _ in range(run.n_frames)]
    for f, pid, b in zip(rows_frame, gt.person_id, beams, strict=True):
        if 0 <= f < run.n_frames:
            out[int(f)][int(pid)] = b
    return out


def _drop_matched(
    ids: NDArray[np.int64], pos: Positions, hidden: Positions, gate: float
) -> tuple[NDArray[np.int64], Positions]:
    """Hypotheses without those matched one-to-one (within ``gate``, least total distance) to ``hidden``."""
    if len(hidden) == 0 or len(pos) == 0:
        return ids, pos
    d = np.linalg.norm(hidden[:, None, :] - pos[None, :, :], axis=2)
    r, c = linear_sum_assignment(np.where(d <= gate, d, 1e6))
    keep = np.ones(len(pos), dtype=bool)
    keep[c[d[r, c] <= gate]] = False
    return ids[keep], pos[keep]


def _f(v: float, digits: int = 3) -> str:
    return "nan" if isinstance(v, float) and math.isnan(v) else f"{v:.{digits}f}"


def format_rows(rows: Sequence[MotRow]) -> str:
    """The tracking table: sequence, source, MOTA, HOTA, MOTP (m), IDSW, Frag, MT, ML, recall, precision."""
    head = f"{'sequence':<26}{'source':<36}{'MOTA':>7}{'HOTA':>7}{'MOTP':>7}{'IDSW':>6}{'Frag':>6}{'MT':>5}{'ML':>5}"
    head += f"{'recall':>8}{'prec':>7}"
    lines = [head, "-" * len(head)]
    for r in rows:
        s = r.scores
        h = float(r.extra.get("hota", math.nan))
        lines.append(
            f"{r.sequence[:25]:<26}{r.source[:35]:<36}{_f(s.mota):>7}{_f(h):>7}{_f(s.motp):>7}{s.id_switches:>6}"
            f"{s.fragmentations:>6}{s.mostly_tracked:>5}{s.mostly_lost:>5}{_f(s.recall):>8}{_f(s.precision):>7}"
        )
    for r in rows:
        fol = r.extra.get("followed")
        if fol:
            lines.append(
                f"followed person {fol['id']} on {r.source}: matched in {_f(fol['matched_fraction'])} of "
                f"{fol['annotated_frames']} annotated frames, {fol['id_switches']} id switches"
            )
    return "\n".join(lines)
