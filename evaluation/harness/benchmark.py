"""The people-detection benchmark: every scene, each detector alone, the paper's modes and the recommended mode.

Scenes (each skipped with a reason when its data is absent):

* ``eth``, ``hotel``, ``zara01``: real ETH/UCY crowd motion around a virtual robot, detections simulated
  (detection-level scenarios of :mod:`evaluation.scenarios`);
* ``scan:wheelchair``, ``scan:corridor``, ``scan:crowd``: scan-level scenes (:mod:`evaluation.scenarios.scan`)
  written as ROS 1 bags and run through ``pfpeople run``'s pipeline (raw scans -> built-in detectors -> filter);
* ``person_following_outdoor_1`` (real, the followed person annotated: recall only) and ``negative_2`` (real,
  nobody there: false people per scan; each of its three lasers alone, and ``negative_2:all``: the three in one
  run configured by ``pfpeople inspect --write-config``, as a user would) from ``../shared/data/leg_tracker``;
* ``positive_bags``: leg_tracker's six labelled ``positive_*_extracted.bag`` (real, a 768-beam 270 deg laser at
  7.5 Hz, the sensor of the issue's wheelchair; stationary, clips of people walking in front of it): recall of
  the labelled people (:func:`write_labelled_people_csv`: the labelled legs paired, 0.1-0.6 m, closest first;
  an unpaired leg is a person too). Recall only: legs are labelled only in a box in front of the laser (x
  0.5-5 m, abs(y) < 0.75 m), so people elsewhere are not annotated. Each bag runs with the configuration
  ``pfpeople inspect --write-config`` writes for it, as the README tells a user, except for the boosted
  detector's model: the shipped one was trained on these six bags, so each bag runs with a model trained the
  same way (:func:`pfpeople.detect.training.train_from_directory`, default parameters) on the other five
  and negative_2 (leave one bag out): the figures to expect on a recording the model has not seen.

For bags the pipeline runs once, as a user runs it (the README's configuration: the recommended mode); its
``people.csv`` gives the row ``recommended (pipeline)`` and its detections are replayed
(:mod:`evaluation.harness.replay`)
through every other mode, so every row of a scene sees the very same detections (the recommended mode the ones
its static-clutter map kept, as in the run; the detectors alone and the paper's modes all of them). Scores:
recall, precision, false people per scan (FP / frames) and FPCPF (false-positive cells per frame, where the
truth is complete), all with the one-to-one matching of ``pfpeople-eval score`` (gate 0.5 m), against the true
people inside the grid (the grid cannot show people outside it; every row's positions are inside it too: the
detectors alone are clipped to it), in every scene as in the MOT table; ms per frame is the filter and
classifier (replay) or the whole pipeline including detectors (``pipeline`` rows).
"""

from __future__ import annotations

import copy
import csv
import math
import tempfile
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from evaluation.harness.replay import ReplayLog, log_from_run, log_from_scenario, step_and_classify
from evaluation.metrics.detection import DetectionAccumulator
from gridbridge.classifiers import BlobClassifier, Classifier, ThresholdClassifier, classify_frame, people_cells
from gridbridge.grid import GridSpec
from gridbridge.params import PAPER_DETECTORS, DetectorModel
from pfpeople.config import BagConfig, ClassifierConfig, DetectorConfig, FilterConfig, TrackingConfig
from pfpeople.pipeline.assembly import build_classifier, build_filter, build_people_tracker

__all__ = [
    "MODES",
    "POSITIVE_BAGS",
    "SCENES",
    "BenchRow",
    "Mode",
    "boosted_model_without",
    "format_rows",
    "particle_overrides",
    "pooled_rows",
    "run_benchmark",
    "write_labelled_people_csv",
]

REPLAY_SCENES = ("eth", "hotel", "zara01")
SCAN_SCENES = ("wheelchair", "corridor", "crowd", "lobby", "hall")
SCENES = (
    *REPLAY_SCENES,
    *(f"scan:{s}" for s in SCAN_SCENES),
    "person_following_outdoor_1",
    "negative_2",
    "positive_bags",
)
#: The labelled leg_tracker bags of scene ``positive_bags`` (``positive_<k>_extracted.bag``).
POSITIVE_BAGS = (1, 2, 3, 4, 6, 7)
#: The beams a true person needs on them to count as seen: the MOT table's ``[hit_beams>=3]`` rows and the pipeline
#: rows' "seen" recall of standing and walking people.
SEEN_BEAMS = 3


_TABLE1 = {m.name: m for m in PAPER_DETECTORS}


@dataclass(frozen=True)
class Mode:
    """One filter + classifier row of the table.

    The paper's modes use the paper's Table 1 PPV / FNR for the detectors it names (laser_legs, laser_boosted,
    camera_hog): its update needs FNR < 0.5 (a detector with FNR >= 0.5 makes every non-detection raise the
    belief, so every cell would drift to 1 with the measured FNR of our laser detectors, 0.60 / 0.55).
    """

    name: str
    filter: FilterConfig
    classifier: Classifier
    #: The run's [tracking] (people confirmed by the tracker, :mod:`pfpeople.track.reported_people`) as ``pfpeople run``
    #: applies it in this filter mode; None: the classifier's people.
    tracking: TrackingConfig | None = None

    def build(self, spec: GridSpec, models: Sequence[DetectorModel]) -> Any:
        if self.filter.mode == "paper":
            models = [
                replace(m, ppv=_TABLE1[m.name].ppv, fnr=_TABLE1[m.name].fnr) if m.name in _TABLE1 else m for m in models
            ]
        return build_filter(self.filter, spec, models)


RECOMMENDED = FilterConfig()
MODES: tuple[Mode, ...] = (
    Mode("paper grid + blobs", FilterConfig(mode="paper"), BlobClassifier()),
    Mode("paper grid + threshold", FilterConfig(mode="paper"), ThresholdClassifier(threshold=0.5)),
    Mode("recommended grid", RECOMMENDED, build_classifier(ClassifierConfig()), TrackingConfig()),
    Mode(
        "recommended particles", FilterConfig(kind="particle"), build_classifier(ClassifierConfig()), TrackingConfig()
    ),
)


@dataclass
class BenchRow:
    """One line of the table."""

    scene: str
    source: str
    frames: int
    recall: float = math.nan
    precision: float = math.nan
    fp_per_frame: float = math.nan
    fpcpf: float = math.nan
    ms_per_frame: float = math.nan
    note: str = ""
    extra: dict[str, Any] = field(default_factory=dict)


def _occupancy(
    spec: GridSpec, centres: tuple[NDArray[np.float64], NDArray[np.float64]], people: NDArray[np.float64]
) -> NDArray[np.bool_]:
    gx, gy = centres
    occ = np.zeros(spec.shape, dtype=bool)
    for x, y in people:
        occ |= np.hypot(gx - x, gy - y) <= 0.3
    return occ


def _score(
    log: ReplayLog, people: Sequence[NDArray[np.float64]], masks: Sequence[NDArray[np.bool_]] | None, *, gate: float
) -> dict[str, Any]:
    acc = DetectionAccumulator(gate=gate)
    complete = not (log.recall_only or log.nobody)
    centres = log.spec.cell_centres()
    for k in range(len(log)):
        if masks is not None and complete:
            acc.add(people[k], log.truth[k], classified=masks[k], occupancy=_occupancy(log.spec, centres, log.truth[k]))
        else:
            acc.add(people[k], log.truth[k])
    s = acc.summary()
    out = {
        "recall": s["recall"] if not log.nobody else math.nan,
        "precision": s["precision"] if complete else math.nan,
        "fp_per_frame": acc.fp / max(acc.frames, 1) if not log.recall_only else math.nan,
        "fpcpf": s.get("fpcpf", math.nan) if (complete and masks is not None) else math.nan,
    }
    if log.nobody:
        out["fpcpf"] = float(np.mean([m.sum() for m in masks])) if masks is not None else math.nan
    out["extra"] = {"tp": acc.tp, "fn": acc.fn, "fp": acc.fp}
    return out


def pooled_rows(rows: Sequence[BenchRow], scene: str) -> list[BenchRow]:
    """One row per source pooling ``rows`` (several logs of one scene), named ``scene``: recall = matches / true
    people over all of them; false people per scan = false people / frames where every pooled row has that
    figure (else NaN); precision, FPCPF and ms per frame are left out (NaN)."""
    by_source: dict[str, list[BenchRow]] = {}
    for r in rows:
        if "tp" in r.extra:
            by_source.setdefault(r.source, []).append(r)
    out = []
    for source, group in by_source.items():
        tp, fn, fp = (sum(int(r.extra[k]) for r in group) for k in ("tp", "fn", "fp"))
        frames = sum(r.frames for r in group)
        row = BenchRow(scene, source, frames, note=f"{len(group)} runs pooled", extra={"tp": tp, "fn": fn, "fp": fp})
        row.recall = tp / (tp + fn) if tp + fn else math.nan
        if not any(math.isnan(r.fp_per_frame) for r in group):
            row.fp_per_frame = fp / max(frames, 1)
        out.append(row)
    return out


def detector_rows(log: ReplayLog, *, gate: float = 0.5) -> list[BenchRow]:
    """Each detector alone: its detections inside the grid against the truth."""
    rows = []
    spec = log.spec
    for i, model in enumerate(log.models):
        dets = []
        for k in range(len(log)):
            d = log.detections[k][i]
            d = np.zeros((0, 2)) if d is None else d
            dets.append(d[spec.contains(d[:, 0], d[:, 1])] if len(d) else d)
        rows.append(BenchRow(log.name, f"detector {model.name}", len(log), **_score(log, dets, None, gate=gate)))
    return rows


#: For logs of pipeline runs: the log of the detections its filter saw (static clutter suppressed), by id.
_SEEN: dict[int, ReplayLog] = {}


def _paper_detectors(log: ReplayLog) -> ReplayLog:
    """The log with only the detectors the paper's Table 1 names (its modes are the paper's three-detector
    setup: a detector it has no PPV / FNR for, e.g. ``laser_single_legs`` with FNR >= 0.5, would make every
    non-detection raise the belief in its update)."""
    keep = [k for k, m in enumerate(log.models) if m.name in _TABLE1]
    if len(keep) == len(log.models):
        return log
    return replace(
        log,
        models=tuple(log.models[k] for k in keep),
        detections=[[frame[k] for k in keep] for frame in log.detections],
    )


def mode_row(log: ReplayLog, mode: Mode, *, gate: float = 0.5) -> BenchRow:
    """One mode replayed over the log's detections (for a pipeline run, the recommended mode gets the detections
    its static-clutter map kept, as in the run; the paper's mode, which has no such map, gets every detection)."""
    if mode.filter.mode == "recommended":
        log = _SEEN.get(id(log), log)
    else:
        log = _paper_detectors(log)
    filt = mode.build(log.spec, log.models)
    classifier = copy.deepcopy(mode.classifier)  # a stateful one (hysteresis) starts afresh on every log
    tracker = None if mode.tracking is None else build_people_tracker(mode.tracking, classifier)
    people, masks, times = [], [], []
    for k in range(len(log)):
        t0 = time.perf_counter()
        _, found = step_and_classify(filt, classifier, log, k, tracker=tracker)
        times.append(time.perf_counter() - t0)
        people.append(found.positions)
        masks.append(found.mask)
    row = BenchRow(log.name, mode.name, len(log), **_score(log, people, masks, gate=gate))
    row.ms_per_frame = 1e3 * float(np.median(times)) if times else math.nan
    return row


def _pipeline_log(
    bag: Path,
    config: BagConfig,
    out: Path,
    *,
    gt: Path | None = None,
    nobody: bool = False,
    recall_only: bool = False,
    name: str,
    max_frames: int | None = None,
) -> tuple[ReplayLog, BenchRow]:
    """Run the pipeline on a bag (as ``pfpeople run`` does) and read it back as a log plus its own row."""
    from pfpeople.io.bag.reader import BagSource
    from pfpeople.io.run_dir import load_run
    from pfpeople.pipeline.runner import Pipeline

    with BagSource(bag) as src:
        summary, _ = Pipeline(config).run(src, out, max_frames=max_frames)
    kw: dict[str, Any] = {"gt": gt, "frame": "laser", "nobody": nobody, "recall_only": recall_only, "name": name}
    log = log_from_run(out, in_grid=True, **kw)
    seen = log_from_run(out, in_grid=True, suppressed=True, **kw)
    _SEEN[id(log)] = seen
    run = load_run(out)
    n = run.n_frames
    people = [np.zeros((0, 2)) for _ in range(n)]
    per: dict[int, list[tuple[float, float]]] = {}
    for f, x, y in zip(run.people["frame"], run.people["x_m"], run.people["y_m"], strict=True):
        per.setdefault(int(f), []).append((float(x), float(y)))
    for f, pts in per.items():
        people[f] = np.asarray(pts, dtype=float)
    # the cells classified as people (FPCPF): the run's classifier over its grids in order (with hysteresis, the
    # grid's motion between frames is not in the run directory: taken as none), of the peaks the run reported
    classifier = build_classifier(config.classifier)
    masks = [_reported_cells(classifier, np.asarray(g), log.spec, people[k]) for k, g in enumerate(run.grids)]
    row = BenchRow(name, "recommended (pipeline)", n, **_score(log, people, masks, gate=0.5))
    row.ms_per_frame = 1e3 * summary.elapsed_s / max(summary.frames, 1)
    row.note = f"{summary.fps:.0f} fps incl. detectors"
    return log, row


def _motion_columns(row: BenchRow, run: Path, gt: Path) -> None:
    """Recall of standing and walking people (of everyone, and of the people ``SEEN_BEAMS`` or more beams reach)
    and the suppressed true-person detections (:func:`evaluation.metrics.standing_walking.motion_split`) into
    ``row.extra`` and its note."""
    from evaluation.metrics.standing_walking import motion_split

    m = motion_split(run, gt, seen_beams=SEEN_BEAMS)
    row.extra.update(
        recall_standing=m.recall_standing,
        recall_walking=m.recall_walking,
        recall_standing_seen=m.recall_standing_seen,
        recall_walking_seen=m.recall_walking_seen,
        suppressed_true=m.suppressed_true,
    )
    row.note += (
        f"; standing {_f(m.recall_standing)} walking {_f(m.recall_walking)}"
        f" (seen: {_f(m.recall_standing_seen)} / {_f(m.recall_walking_seen)}) suppressed {_f(m.suppressed_true, 3)}"
    )


def _reported_cells(
    classifier: Any, grid: NDArray[np.float64], spec: GridSpec, reported: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """Cells of the classifier's people of ``grid`` that are reported (within 0.3 m of a reported person)."""
    found = classify_frame(classifier, grid, spec)
    if not len(found.positions):
        return found.mask
    if not len(reported):
        return np.zeros(spec.shape, dtype=bool)
    d = np.hypot(found.positions[:, None, 0] - reported[None, :, 0], found.positions[:, None, 1] - reported[None, :, 1])
    return people_cells(found.mask, spec, found.positions, d.min(axis=1) <= 0.3)


def _laser_config(topic: str, **changes: Any) -> BagConfig:
    from pfpeople.io.bag.inspect import LASER_DETECTORS

    dets = tuple(DetectorConfig(name=name, kind=kind, topic=topic) for name, kind, _ in LASER_DETECTORS)
    return replace(BagConfig(driver=topic, detectors=dets), **changes)


def _negative_2_all(bag: Path, work: Path, frames: int | None) -> tuple[ReplayLog, BenchRow]:
    """negative_2's three lasers in one run (``negative_2:all``), configured as a user would: ``pfpeople inspect
    --write-config`` (:func:`pfpeople.io.bag.inspect.starter_config`: detectors on every laser; no TF in the bag,
    so each laser is assumed at the base origin, facing forward)."""
    from pfpeople.config import load_config
    from pfpeople.io.bag.inspect import inspect_path, starter_config

    work.mkdir(parents=True, exist_ok=True)
    cfg_path = work / "negative_2_starter.toml"
    cfg_path.write_text(starter_config(inspect_path(bag)), encoding="utf-8")
    out = work / "negative_2_all"
    return _pipeline_log(bag, load_config(cfg_path), out, nobody=True, name="negative_2:all", max_frames=frames)


def write_labelled_people_csv(bag: Path, out: Path) -> int:
    """Ground-truth CSV of the people of a leg_tracker ``positive_*_extracted.bag``; returns its row count.

    Per ``/training_scan`` message (``scan_index``: its index on the topic, the run's ``driver_index``) the
    labelled legs of ``/leg_cluster_positions`` are paired into people (:func:`evaluation.bench.clutter.
    labelled_people`: pairs 0.1-0.6 m apart, closest first, at their midpoint; an unpaired leg is a person at its
    own position). Columns ``scan_index, person_id, x_laser_m, y_laser_m`` (the scan's frame; ``person_id`` is
    the rank in the scan, 1 for the first: the labels carry no identities).
    """
    from evaluation.bench.clutter import labelled_people
    from pfpeople.detect.leg_tracker_bags import load_labelled_scans

    n = 0
    with Path(out).open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["scan_index", "person_id", "x_laser_m", "y_laser_m"])
        for k, scan in enumerate(load_labelled_scans(bag)):
            for j, (x, y) in enumerate(labelled_people(scan.legs), start=1):
                w.writerow([k, j, f"{x:.4f}", f"{y:.4f}"])
                n += 1
    return n


def boosted_model_without(leg: Path, work: Path, held: int, present: Sequence[int]) -> Path:
    """The boosted model trained as the shipped one (the labelled bags, ``negative_2`` and the simulated training
    scenes, ``make model``) but without the labelled bag ``positive_<held>``: ``work/models/without_positive_<held>
    .yml`` (the simulated scenes in ``work/sim-train``)."""
    from evaluation.scenarios.scan.training_scenes import training_people_bags
    from pfpeople.detect.training import train_from_directory

    model = work / "models" / f"without_positive_{held}.yml"
    others = [f"positive_{j}_extracted.bag" for j in present if j != held]
    people = training_people_bags(work / "sim-train")
    train_from_directory(
        leg, model.parent, train_positive=others, name=model.stem, leave_one_out=False, people_bags=people
    )
    return model


def _positive_bags_logs(leg: Path, work: Path, frames: int | None) -> tuple[list[ReplayLog], list[BenchRow], str]:
    """Scene ``positive_bags``: each labelled leg_tracker bag run as the README says, with a boosted model trained
    without it (and with the simulated training scenes, as the shipped model)."""
    from pfpeople.config import load_config
    from pfpeople.io.bag.inspect import inspect_path, starter_config

    logs, rows = [], []
    present = [k for k in POSITIVE_BAGS if (leg / f"positive_{k}_extracted.bag").is_file()]
    work.mkdir(parents=True, exist_ok=True)
    for k in present:
        bag = leg / f"positive_{k}_extracted.bag"
        nm = f"positive_{k}"
        gt = work / f"{nm}_gt.csv"
        write_labelled_people_csv(bag, gt)
        model = boosted_model_without(leg, work, k, present)
        cfg_path = work / f"{nm}.toml"  # as the README: pfpeople inspect BAG --write-config
        cfg_path.write_text(starter_config(inspect_path(bag)), encoding="utf-8")
        cfg = load_config(cfg_path)
        dets = tuple(
            replace(d, params={**dict(d.params), "model_path": str(model)})
            if d.kind in ("boosted", "single-legs")
            else d
            for d in cfg.detectors
        )
        log, row = _pipeline_log(
            bag,
            replace(cfg, detectors=dets),
            work / f"{nm}_run",
            gt=gt,
            recall_only=True,
            name=nm,
            max_frames=frames,
        )
        logs.append(log)
        rows.append(row)
    if not logs:
        return [], [], f"no positive_*_extracted.bag in {leg}"
    return logs, rows, ""


def scene_logs(
    scene: str, *, data: Path, work: Path, frames: int | None = None, scan_seed: int | None = None
) -> tuple[list[ReplayLog], list[BenchRow], str]:
    """The logs of one scene, the rows of its pipeline runs, and a skip reason ("" when it ran).

    ``scan_seed``: seed of the scan-level scenes' simulation (people, robot noise, laser noise; default the
    scene's own, 0)."""
    leg = data / "leg_tracker"
    if scene in REPLAY_SCENES:
        from evaluation.scenarios.eth_ucy import DataNotFoundError
        from evaluation.scenarios.scenario import Scenario

        try:
            sc = Scenario.from_name(scene, n_frames=frames)
            return [log_from_scenario(sc)], [], ""
        except (DataNotFoundError, FileNotFoundError) as exc:
            return [], [], f"no data ({exc})"
    if scene.startswith("scan:"):
        from evaluation.scenarios.scan import write_scene_bag
        from pfpeople.config import load_config
        from pfpeople.io.bag.inspect import inspect_path, starter_config

        name = scene.split(":", 1)[1]
        sb = write_scene_bag(name, work / name, frames=frames, seed=scan_seed)
        cfg_path = work / name / f"{name}_starter.toml"  # as the README: pfpeople inspect BAG --write-config
        cfg_path.write_text(starter_config(inspect_path(sb.bag)), encoding="utf-8")
        run = work / f"{name}_run"
        log, row = _pipeline_log(sb.bag, load_config(cfg_path), run, gt=sb.gt_csv, name=scene)
        _motion_columns(row, run, sb.gt_csv)
        return [log], [row], ""
    if scene == "person_following_outdoor_1":
        bag, gt = leg / "person_following_outdoor_1.bag.zip", leg / "person_following_outdoor_1_gt.csv"
        if not bag.is_file():
            return [], [], f"{bag} is absent"
        from pfpeople.config import builtin_config_path, load_config

        cfg = load_config(builtin_config_path("person_following_outdoor_1"))
        log, row = _pipeline_log(bag, cfg, work / "pf1_run", gt=gt, recall_only=True, name=scene, max_frames=frames)
        return [log], [row], ""
    if scene == "negative_2":
        bag = leg / "negative_2.bag"
        if not bag.is_file():
            return [], [], f"{bag} is absent"
        logs, rows = [], []
        for topic in ("/left_scan", "/rear_scan", "/right_scan"):
            nm = f"negative_2{topic.replace('/', ':').replace('_scan', '')}"
            out = work / nm.replace(":", "_")
            log, row = _pipeline_log(bag, _laser_config(topic), out, nobody=True, name=nm, max_frames=frames)
            logs.append(log)
            rows.append(row)
        log, row = _negative_2_all(bag, work, frames)
        return [*logs, log], [*rows, row], ""
    if scene == "positive_bags":
        return _positive_bags_logs(leg, work, frames)
    raise ValueError(f"unknown scene {scene!r}; scenes: {', '.join(SCENES)}")


def mot_rows(
    scene: str,
    *,
    data: Path,
    work: Path,
    frames: int | None = None,
    gate: float = 0.75,
    particle: Mapping[str, Any] | None = None,
) -> list[Any]:
    """The multi-person tracking (CLEAR-MOT) rows of one scene, after :func:`scene_logs` ran it in ``work``.

    Replay scenes: the recommended filters (grid, particles) + tracker replayed as ``pfpeople run`` runs them, and
    the tracker on each detector's raw detections and on all merged (tracking-by-detection),
    :func:`evaluation.harness.mot_eval.evaluate_log`. Bag scenes: the run's own ``tracks.csv`` (the shipped output), the
    ``tracks.csv`` of the same run with the particle filter (``FilterConfig.kind = "particle"``, run here into
    ``<name>_prun``), and the tracker on each detector's detections and all merged
    (:func:`evaluation.harness.mot_eval.evaluate_run`); the scan-level scenes again scoring only people hit by >= 3
    laser beams (``[hit_beams>=3]``: fully occluded people out). ``person_following_outdoor_1`` annotates the followed
    person only: its figure is the followed-person line (MOTA / precision there count passers-by as false).
    ``negative_2`` (nobody there) has no MOT rows. Gate ``gate`` m (leg_tracker's 0.75). ``particle``: other
    :class:`~pfpeople.config.FilterConfig` fields for the particle filter's rows (e.g. ``{"seed": 3}``).
    """
    from evaluation.harness.mot_eval import evaluate_log, evaluate_run
    from pfpeople.config import builtin_config_path, load_config
    from pfpeople.io.ground_truth import read_gt_csv
    from pfpeople.io.run_dir import load_run
    from pfpeople.track import TrackerConfig

    if scene in REPLAY_SCENES:
        from evaluation.scenarios.scenario import Scenario

        return evaluate_log(log_from_scenario(Scenario.from_name(scene, n_frames=frames)), gate=gate, particle=particle)
    srcs = ["tracks", "laser_legs", "laser_boosted", "all detectors merged"]
    if scene.startswith("scan:"):
        name = scene.split(":", 1)[1]
        bag, cfg = work / name / f"{name}.bag", load_config(work / name / f"{name}_starter.toml")  # as scene_logs
        gt_csv, out = work / name / f"{name}_gt.csv", work / f"{name}_run"
        visible: tuple[int | None, ...] = (None, SEEN_BEAMS)
        followed, max_frames = False, None  # the scene bag has the benchmark's frames only
    elif scene == "person_following_outdoor_1":
        name, bag = "pf1", data / "leg_tracker" / "person_following_outdoor_1.bag.zip"
        cfg = load_config(builtin_config_path("person_following_outdoor_1"))
        gt_csv, out = bag.parent / "person_following_outdoor_1_gt.csv", work / "pf1_run"
        visible, followed, max_frames = (None,), True, frames
    else:
        return []
    gt = read_gt_csv(gt_csv)
    particle_out = work / f"{name}_prun"
    _particle_run(bag, cfg, particle_out, max_frames=max_frames, particle=particle)
    grid_run, particle_run = load_run(out), load_run(particle_out)
    rows: list[Any] = []
    for beams in visible:
        kw: dict[str, Any] = {"config": TrackerConfig(), "gate": gate, "classify": None, "min_hit_beams": beams}
        grid_rows = evaluate_run(grid_run, gt, sources=srcs, followed=followed, **kw)
        particle_rows = evaluate_run(particle_run, gt, sources=["tracks"], followed=followed, **kw)
        rows += grid_rows[:1] + particle_rows + grid_rows[1:]  # the two filters' tracks first
    return rows


def _particle_run(
    bag: Path,
    config: BagConfig,
    out: Path,
    *,
    max_frames: int | None = None,
    particle: Mapping[str, Any] | None = None,
) -> None:
    """Run the pipeline on ``bag`` with ``config``'s filter made the (recommended) particle filter, ``particle``
    its other :class:`~pfpeople.config.FilterConfig` fields, into ``out``."""
    from pfpeople.io.bag.reader import BagSource
    from pfpeople.pipeline.runner import Pipeline

    filt = replace(config.filter, kind="particle", **dict(particle or {}))
    with BagSource(bag) as src:
        Pipeline(replace(config, filter=filt)).run(src, out, max_frames=max_frames)


def particle_overrides(items: Iterable[str]) -> dict[str, Any]:
    """``KEY=VALUE`` strings (``pfpeople-eval benchmark --particle``) as :class:`~pfpeople.config.FilterConfig` fields
    of the particle filter runs: each KEY a ``[filter]`` key other than ``kind``, each VALUE a TOML value
    (``seed=3``, ``compiled_draws=true``, ``motion_model="paper"``; a bare word is taken as a string).

    Raises
    ------
    ValueError
        An item without ``=``, a key that is no ``[filter]`` key, or a combination FilterConfig refuses (its
        message, naming the field).
    """
    import tomllib
    from dataclasses import fields

    items = list(items)
    keys = sorted(f.name for f in fields(FilterConfig) if f.name != "kind")
    out: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise ValueError(f"--particle {item!r}: expected KEY=VALUE (e.g. seed=3)")
        if key not in keys:
            raise ValueError(f"--particle {item!r}: {key!r} is not a [filter] key; keys: {', '.join(keys)}")
        try:
            out[key] = tomllib.loads(f"v = {text.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            out[key] = text.strip()  # a bare word: a string
    try:
        FilterConfig(kind="particle", **out)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"--particle {' '.join(items)}: {exc}") from None
    return out


def run_benchmark(
    scenes: Iterable[str] = SCENES,
    *,
    data: Path,
    modes: Sequence[Mode] = MODES,
    frames: int | None = None,
    work: Path | None = None,
    progress: Callable[[str], None] | None = None,
    mot: list[Any] | None = None,
    scan_seed: int | None = None,
    particle: Mapping[str, Any] | None = None,
    ap: list[Any] | None = None,
) -> list[BenchRow]:
    """Every scene x (each detector, each mode, the pipeline's own run). See the module docstring.

    ``mot``: when a list, the multi-person tracking rows of every scene (:func:`mot_rows`,
    :class:`evaluation.harness.mot_eval.MotRow`) are appended to it. ``scan_seed``: simulation seed of the scan-level
    scenes (default each scene's own): other seeds give other people, paths and noise in the same room, a check
    that figures tuned on the default seed carry over. ``particle``: :class:`~pfpeople.config.FilterConfig` fields
    that replace the defaults of every particle filter run (the modes of kind ``"particle"``, the tracking rows,
    the bags' particle runs), e.g. ``{"seed": 3}``: a particle row is one Monte Carlo draw, other seeds give its
    spread (:func:`particle_overrides` checks them). ``ap``: when a list, the detection rows of every detector alone
    and of the fused output (AP, recall at precision 0.90, standing / walking recall, false people per scan;
    :mod:`evaluation.harness.benchmark_ap`) of the scan-level scenes, ``positive_bags`` and ``negative_2`` are
    appended to it."""
    if particle:
        modes = [replace(m, filter=replace(m.filter, **particle)) if m.filter.kind == "particle" else m for m in modes]
    rows: list[BenchRow] = []
    with tempfile.TemporaryDirectory(prefix="pfpeople-bench-") as tmp:
        base = Path(work) if work is not None else Path(tmp)
        for scene in scenes:
            if progress:
                progress(scene)
            logs, pipe_rows, skip = scene_logs(scene, data=data, work=base, frames=frames, scan_seed=scan_seed)
            if skip:
                rows.append(BenchRow(scene, "skipped", 0, note=skip))
                continue
            first = len(rows)
            prows: list[BenchRow | None] = list(pipe_rows) if pipe_rows else [None] * len(logs)
            for log, prow in zip(logs, prows, strict=True):
                rows.extend(detector_rows(log))
                for mode in modes:
                    rows.append(mode_row(log, mode))
                if prow is not None:
                    rows.append(prow)
            if scene == "positive_bags" and len(logs) > 1:
                rows.extend(pooled_rows(rows[first:], "positive_bags (all)"))
            if ap is not None:
                ap.extend(_ap_rows(scene, data, base))
            if mot is not None:
                mot.extend(mot_rows(scene, data=data, work=base, frames=frames, particle=particle))
    return rows


def _ap_rows(scene: str, data: Path, work: Path) -> list[Any]:
    """The detection table's rows of ``scene`` (none for the detection-level replays and the recall-only bag)."""
    from evaluation.harness import benchmark_ap

    leg = data / "leg_tracker"
    if scene.startswith("scan:"):
        name = scene.split(":", 1)[1]
        return benchmark_ap.scan_ap_rows(
            scene, work / name / f"{name}.bag", work / name / f"{name}_gt.csv", work / f"{name}_run"
        )
    if scene == "positive_bags":
        present = [k for k in POSITIVE_BAGS if (leg / f"positive_{k}_extracted.bag").is_file()]
        return benchmark_ap.positive_ap_rows(leg, work, present)
    if scene == "negative_2":
        return benchmark_ap.negative_ap_rows(leg, work)
    return []


def _f(v: float, nd: int = 2) -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.{nd}f}"


def format_rows(rows: Sequence[BenchRow]) -> str:
    """The table: scene, source, frames, recall, precision, false people per scan, FPCPF, ms per frame."""
    head = (
        f"{'scene':<28}{'source':<28}{'frames':>7}{'recall':>8}{'prec.':>7}{'FP/scan':>9}{'FPCPF':>7}{'ms/fr':>8}  note"
    )
    lines = [head, "-" * len(head)]
    last = None
    for r in rows:
        if last is not None and r.scene != last:
            lines.append("")
        last = r.scene
        lines.append(
            f"{r.scene:<28}{r.source:<28}{r.frames:>7}{_f(r.recall):>8}{_f(r.precision):>7}{_f(r.fp_per_frame, 3):>9}"
            f"{_f(r.fpcpf):>7}{_f(r.ms_per_frame):>8}  {r.note}"
        )
    return "\n".join(lines)
