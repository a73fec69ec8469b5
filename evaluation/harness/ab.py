"""A/B evaluation: the grid filter and the particle filter on the very same frames and detections.

For a scenario with ground truth (:mod:`evaluation.scenarios`) the harness

1. scores each detector alone, as the paper's Table 2 does: its detections against the true people, and the
   cells that contain a detection against the true occupancy (FPCPF);
2. runs every filter (grid filter in the paper's and the linear form, the particle filter at several particle
   counts) on the same detections and odometry, classifies each posterior with the paper's blob algorithm
   (:func:`gridbridge.blobs.classify_blobs`) and with a plain threshold (connected cells above 0.5), and
   scores the classified people (recall, precision, FPCPF), the belief grid itself (Brier score, log-loss, ROC AUC
   against the true occupancy) and the time per iteration;
3. runs the paper's tracking application on each filter's posteriors;
4. writes a run record (JSON: configuration, seeds, versions, metrics) and figures in the style of the
   paper's Fig. 6 for chosen frames.

Matching rule: a true person inside the grid is found when a classified person (blob centroid) or a detection
lies within ``gate`` metres (0.5 m by default), one-to-one (:func:`evaluation.metrics.detection.match_people`). People
outside the grid are not counted: the grid cannot show them.
"""

from __future__ import annotations

import functools
import math
import platform
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal, TypeAlias

import numpy as np
from numpy.typing import NDArray

from evaluation.metrics.detection import DetectionAccumulator, tracking_summary
from evaluation.scenarios.scenario import Frame, Scenario
from gridbridge import GridFilter, GridSpec, rasterise
from gridbridge.blobs import Blob, BlobParams, ClassificationResult, classify_blobs, classify_threshold
from gridbridge.classifiers import classify_frame
from gridbridge.ego_motion import odometry_pose, velocity_displacement
from gridbridge.filter import BeliefFilter, FilterStep
from gridbridge.geometry import Pose2D
from gridbridge.params import DetectorModel
from pfpeople.io.jsonio import dumps
from pfpeople.track.blob_tracker import TrackerParams, track_sequence

__all__ = [
    "ABResult",
    "FilterRun",
    "FilterSpec",
    "default_filters",
    "format_table",
    "particles_label",
    "run_ab",
    "table_key",
]


#: What the harness needs of a filter: the one filter interface of both filters.
StepFilter: TypeAlias = BeliefFilter


@dataclass(frozen=True, kw_only=True)
class FilterSpec:
    """One filter of the comparison.

    Parameters
    ----------
    name : str
        Row label.
    kind : {"grid", "particle"}
    form : {"paper", "linear"}
        Grid filter prediction form (grid only).
    n_particles : int
        Particle count (particle only).
    motion_model : {"paper", "persistent"}
        Particle people-motion model (particle only).
    mode : {"paper", "recommended"}
        ``"recommended"``: the product's filter (:func:`pfpeople.pipeline.assembly.build_filter`, ``form`` ignored) and
        its peak classifier instead of the paper's blobs in the first row.
    """

    name: str
    kind: Literal["grid", "particle"] = "grid"
    form: Literal["paper", "linear"] = "paper"
    n_particles: int = 10_000
    motion_model: Literal["paper", "persistent"] = "paper"
    mode: Literal["paper", "recommended"] = "paper"

    def __post_init__(self) -> None:
        if self.kind not in ("grid", "particle"):
            raise ValueError(f"FilterSpec.kind must be 'grid' or 'particle', got {self.kind!r}")
        if self.form not in ("paper", "linear"):
            raise ValueError(f"FilterSpec.form must be 'paper' or 'linear', got {self.form!r}")
        n = self.n_particles
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
            raise ValueError(f"FilterSpec.n_particles must be a positive integer, got {n!r}")
        if self.motion_model not in ("paper", "persistent"):
            raise ValueError(f"FilterSpec.motion_model must be 'paper' or 'persistent', got {self.motion_model!r}")
        if self.mode not in ("paper", "recommended"):
            raise ValueError(f"FilterSpec.mode must be 'paper' or 'recommended', got {self.mode!r}")

    def build(self, spec: GridSpec, detectors: Sequence[DetectorModel], seed: int) -> StepFilter:
        """A fresh filter for ``spec`` and ``detectors``; particle filters draw from ``default_rng(seed)``."""
        if self.mode == "recommended":
            from pfpeople.config import FilterConfig
            from pfpeople.pipeline.assembly import build_filter

            cfg = FilterConfig(kind=self.kind, n_particles=self.n_particles, seed=seed, motion_model=self.motion_model)
            return build_filter(cfg, spec, detectors)
        if self.kind == "grid":
            return GridFilter(spec, detectors=detectors, form=self.form)
        from pfpeople.particle.filter import ParticleFilter
        from pfpeople.particle.predictor import PEOPLE_SAMPLERS

        return ParticleFilter(
            spec,
            detectors=detectors,
            n_particles=self.n_particles,
            rng=np.random.default_rng(seed),
            people_motion=PEOPLE_SAMPLERS[self.motion_model](),
        )


def particles_label(n: int) -> str:
    """Row label of a particle filter with ``n`` particles, e.g. ``particles 5e3``.

    The exact count (``particles 12345``) when one significant digit would round it: two counts must not share
    a label (it names the figure files).
    """
    short = f"{n:.0e}".replace("e+0", "e").replace("e+", "e")
    return f"particles {short if float(short) == n else n}"


def default_filters(particle_counts: Iterable[int] = (5_000, 50_000), *, recommended: bool = True) -> list[FilterSpec]:
    """Grid filter (paper and linear form), the particle filter at each count, and (``recommended``) the product's
    recommended grid filter."""
    out = [FilterSpec(name="grid (paper)", form="paper"), FilterSpec(name="grid (linear)", form="linear")]
    for n in particle_counts:
        out.append(FilterSpec(name=particles_label(n), kind="particle", n_particles=n))
    if recommended:
        out.append(FilterSpec(name="recommended grid", mode="recommended"))
    return out


@dataclass
class FilterRun:
    """Scores of one filter over the run, plus what the figures and tracking need."""

    name: str
    scores: dict[str, Any]
    threshold_scores: dict[str, Any]
    ms_per_iteration: float
    tracking: dict[str, Any]
    snapshots: dict[int, FilterStep] = field(default_factory=dict)
    classifier: str = "blobs"


@dataclass
class ABResult:
    """Everything one A/B run produced."""

    scenario: str
    n_frames: int
    detector_scores: dict[str, dict[str, Any]]
    filters: list[FilterRun]
    record_path: Path | None = None
    figure_paths: list[Path] = field(default_factory=list)


def _people_in_grid(frame: Frame, spec: GridSpec) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    inside = spec.contains(frame.people[:, 0], frame.people[:, 1])
    return frame.person_ids[inside], frame.people[inside]


def score_detectors(frames: Sequence[Frame], spec: GridSpec, models: Sequence[DetectorModel], gate: float) -> dict:
    """Each detector alone (the first rows of the paper's Table 2)."""
    out: dict[str, dict[str, Any]] = {}
    for i, model in enumerate(models):
        acc = DetectionAccumulator(gate=gate)
        for fr in frames:
            _, truth = _people_in_grid(fr, spec)
            det = fr.outputs[i].positions
            det = det[spec.contains(det[:, 0], det[:, 1])]
            cells = rasterise(spec, det) > 0
            acc.add(det, truth, classified=cells, occupancy=fr.truth_grid)
        out[model.name] = acc.summary()
    return out


def run_filter(
    fs: FilterSpec,
    frames: Sequence[Frame],
    spec: GridSpec,
    models: Sequence[DetectorModel],
    *,
    dt: float,
    seed: int,
    gate: float,
    blob_params: BlobParams,
    threshold: float = 0.5,
    snapshot_frames: Iterable[int] = (),
    noisy_odometry: bool = True,
    progress: Callable[[Iterable[Frame]], Iterable[Frame]] | None = None,
) -> FilterRun:
    """Run one filter over the frames and score it."""
    filt = fs.build(spec, models, seed)
    acc = DetectionAccumulator(gate=gate)
    acc_thr = DetectionAccumulator(gate=gate)
    keep = set(snapshot_frames)
    snapshots: dict[int, FilterStep] = {}
    classified: list[ClassificationResult] = []
    times: list[float] = []
    iterable = progress(frames) if progress else frames
    peaks = _recommended_classifier() if fs.mode == "recommended" else None
    for fr in iterable:
        t0 = time.perf_counter()
        odo = fr.odometry(noisy=noisy_odometry)
        out = filt.step(fr.detections, odo, dt)
        times.append(time.perf_counter() - t0)
        if peaks is not None:
            cls = _peaks_result(out, spec, peaks, odometry_pose(odo, dt))
        else:
            cls = classify_blobs(out.posterior, spec=spec, params=blob_params)
        _, truth = _people_in_grid(fr, spec)
        acc.add(cls.positions, truth, classified=cls.mask, occupancy=fr.truth_grid, belief=out.posterior)
        thr = classify_threshold(out.posterior, threshold, spec=spec)
        acc_thr.add(thr.positions, truth, classified=thr.mask, occupancy=fr.truth_grid)
        classified.append(cls)
        if fr.index in keep:
            snapshots[fr.index] = out
    tracking = evaluate_tracking(frames, classified, spec, dt=dt, gate=gate, noisy_odometry=noisy_odometry)
    return FilterRun(
        name=fs.name,
        scores=acc.summary(),
        threshold_scores=acc_thr.summary(),
        ms_per_iteration=1e3 * float(np.median(times)) if times else math.nan,
        tracking=tracking,
        snapshots=snapshots,
        classifier="peaks" if fs.mode == "recommended" else "blobs",
    )


def _recommended_classifier() -> Any:
    """A fresh recommended classifier (peaks with hysteresis: one per run, it keeps the previous frame)."""
    from pfpeople.config import ClassifierConfig
    from pfpeople.pipeline.assembly import build_classifier

    return build_classifier(ClassifierConfig())


def _peaks_result(out: FilterStep, spec: GridSpec, classifier: Any, ego: Pose2D | None) -> ClassificationResult:
    """The recommended classifier's people as a :class:`ClassificationResult` (one selected blob per person)."""
    found = classify_frame(classifier, out.posterior, spec, observed=np.asarray(out.covered).any(axis=0), ego=ego)
    labels = np.zeros(spec.shape, dtype=np.intp)
    blobs = []
    gx, gy = spec.cell_centres()
    for k, (pos, score) in enumerate(zip(found.positions, found.scores, strict=True), start=1):
        i, j = spec.to_cell(pos[0], pos[1])
        ci, cj = (float(np.asarray(c)) for c in spec.to_fractional(pos[0], pos[1]))
        near = found.mask & (np.hypot(gx - pos[0], gy - pos[1]) <= 0.45) & (labels == 0)
        near[int(i), int(j)] = True
        cells = np.argwhere(near).astype(np.intp)
        labels[near] = k
        blobs.append(
            Blob(
                label=k,
                cells=cells,
                mean_probability=float(score),
                max_probability=float(score),
                min_probability=float(score),
                centroid_cells=np.array([ci - 0.5, cj - 0.5]),
                centroid=np.asarray(pos, dtype=float),
                mean_cell=cells.mean(axis=0).astype(float),
                height=int(np.ptp(cells[:, 0]) + 1),
                width=int(np.ptp(cells[:, 1]) + 1),
                border_cells=0,
                selected=True,
            )
        )
    return ClassificationResult(blobs=blobs, labels=labels, spec=spec)


def evaluate_tracking(
    frames: Sequence[Frame],
    classified: Sequence[ClassificationResult],
    spec: GridSpec,
    *,
    dt: float,
    gate: float,
    noisy_odometry: bool = True,
    params: TrackerParams | None = None,
) -> dict[str, Any]:
    """The paper's tracking application on a filter's classified posteriors, scored against the truth.

    The tracker starts by itself on the first confident person blob and follows that one person (no restart);
    the previous centroid is carried into the current sensor frame with the odometry. The person it follows is
    the true person nearest to its first centroid. Reports the fraction of frames tracked while that person is
    in the grid, the frames where every detector missed the person but the track held, and the position error.
    """
    if not classified:
        return {}
    params = TrackerParams(restart=False) if params is None else params
    transforms = []
    for fr in frames:
        odo = fr.odometry(noisy=noisy_odometry)
        dx, dy, dth = velocity_displacement(odo.v, odo.omega, dt, vy=odo.vy)
        transforms.append((float(dx), float(dy), float(dth)))
    result = track_sequence(results=classified, spec=spec, params=params, transforms=transforms)
    tracked = result.tracked
    centroids = result.centroids
    if not tracked.any():
        return {"started": False}
    first = int(np.argmax(tracked))
    ids, pos = _people_in_grid(frames[first], spec)
    if len(ids) == 0:
        return {"started": True, "person_id": None}
    pid = int(ids[np.argmin(np.linalg.norm(pos - centroids[first], axis=1))])
    truth = np.full((len(frames), 2), np.nan)
    all_missed = np.zeros(len(frames), dtype=bool)
    for k, fr in enumerate(frames):
        ids_k, pos_k = _people_in_grid(fr, spec)
        hit = np.flatnonzero(ids_k == pid)
        if k >= first and hit.size:
            truth[k] = pos_k[hit[0]]
            all_missed[k] = not any(np.any(o.source == pid) for o in fr.outputs)
    summary = dict(tracking_summary(tracked, centroids, truth, all_missed=all_missed, gate=gate))
    summary["person_id"] = pid
    summary["start_frame"] = first
    return summary


def run_ab(
    scenario: Scenario,
    filters: Sequence[FilterSpec],
    *,
    gate: float = 0.5,
    blob_params: BlobParams | None = None,
    figure_frames: Sequence[int] = (),
    out_dir: Path | None = None,
    seed: int = 0,
    noisy_odometry: bool = True,
    progress: bool = False,
) -> ABResult:
    """Run the A/B evaluation (see the module docstring).

    Parameters
    ----------
    scenario : Scenario
        Frames with ground truth and simulated detections (generated once, shared by all filters).
    filters : sequence of FilterSpec
    gate : float
        Matching distance (m).
    blob_params : BlobParams, optional
        Classification thresholds (the paper's by default).
    figure_frames : sequence of int
        Frames to draw as Fig. 6-style panels (needs ``out_dir``).
    out_dir : Path, optional
        Where the run record (``run.json``) and figures go; nothing is written when None.
    seed : int
        Seed of the particle filters' generators.
    noisy_odometry : bool
        Feed the filters the reported (noisy) odometry rather than the true controls.
    progress : bool
        Show progress bars (:func:`pfpeople.progress.progress_bar`).
    """
    blob_params = BlobParams() if blob_params is None else blob_params
    spec = scenario.spec
    models = scenario.config.detector_models
    for k in figure_frames:
        if not 0 <= k < len(scenario):
            raise ValueError(f"figure frame {k} is outside the scenario's {len(scenario)} frames")
    frames = list(_progress(scenario.frames(), progress, "simulate", len(scenario)))
    detector_scores = score_detectors(frames, spec, models, gate)
    runs = []
    for fs in filters:
        runs.append(
            run_filter(
                fs,
                frames,
                spec,
                models,
                dt=scenario.dt,
                seed=seed,
                gate=gate,
                blob_params=blob_params,
                snapshot_frames=figure_frames,
                noisy_odometry=noisy_odometry,
                progress=functools.partial(_progress, show=True, desc=fs.name, total=len(frames)) if progress else None,
            )
        )
    result = ABResult(
        scenario=scenario.config.name, n_frames=len(frames), detector_scores=detector_scores, filters=runs
    )
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
        if figure_frames:
            from evaluation.harness.figures import fig6_panels

            for k in figure_frames:
                for run in runs:
                    path = out_dir / f"fig6_frame{k:04d}_{_slug(run.name)}.png"
                    fig6_panels(
                        frames[k],
                        run.snapshots[k],
                        spec,
                        models,
                        path,
                        title=f"{run.name}, frame {k}",
                        blob_params=blob_params,
                    )
                    result.figure_paths.append(path)
        result.record_path = write_record(
            result, scenario, filters, out_dir / "run.json", gate=gate, seed=seed, blob_params=blob_params
        )
    return result


def _slug(name: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in name).strip("_")


def _progress(it: Iterable[Frame], show: bool, desc: str, total: int) -> Iterable[Frame]:
    if not show:
        return it
    from pfpeople.progress import progress_bar

    return progress_bar(it, desc=desc, total=total, unit="frame", leave=False)


def write_record(
    result: ABResult,
    scenario: Scenario,
    filters: Sequence[FilterSpec],
    path: Path,
    *,
    gate: float,
    seed: int,
    blob_params: BlobParams,
) -> Path:
    """The run record: configuration, seeds, versions and every metric, as JSON (NaN written as null)."""
    import scipy

    record = {
        "scenario": {"name": scenario.config.name, "seed": scenario.config.seed, "n_frames": result.n_frames},
        "scenario_config": repr(scenario.config),
        "filters": [asdict(f) for f in filters],
        "particle_seed": seed,
        "matching_gate_m": gate,
        "blob_params": asdict(blob_params),
        "detectors": result.detector_scores,
        "results": [
            {
                "name": r.name,
                "blob_classification": r.scores,
                "threshold_classification": r.threshold_scores,
                "ms_per_iteration": r.ms_per_iteration,
                "tracking": r.tracking,
            }
            for r in result.filters
        ],
        "figures": [p.name for p in result.figure_paths],
        "versions": {"python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__},
        "machine": platform.platform(),
    }
    path.write_text(dumps(record) + "\n")
    return path


def table_key(gate: float = 0.5) -> str:
    """What the rows and columns of :func:`format_table` are, for printing under it (``gate``: the matching
    distance, m)."""
    return "\n".join(
        [
            "Rows: 'Detector X' is one detector alone; 'F + blobs' the filter F with the paper's blob classification,",
            "'F + threshold' with connected cells above 0.5 instead.",
            "Recall: true people found / true people in the grid; Precision: found people that are true (matched one",
            f"to one within {gate:g} m). FPCPF: false-positive cells per frame (cells classified as a person where",
            "nobody is). Brier, LogLoss (lower is better) and AUC (higher is better) score the belief grid against",
            "the true occupancy. ms/iter: median time of one filter step. tracked: the fraction of frames in which",
            "the paper's tracking application holds the person it started on, while that person is in the grid.",
        ]
    )


def format_table(result: ABResult) -> str:
    """The paper's Table 2 layout (recall, precision, FPCPF) plus grid scores, ms per iteration and tracking.

    Each filter has two rows: classification with the paper's blob algorithm and with the plain threshold.
    """

    def f(x: Any, nd: int = 2) -> str:
        return "   -" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:.{nd}f}"

    lines = [
        f"Scenario {result.scenario!r}, {result.n_frames} frames",
        f"{'':30} {'Recall':>7} {'Precision':>9} {'FPCPF':>6} {'Brier':>7} {'LogLoss':>8} {'AUC':>6} "
        f"{'ms/iter':>8} {'tracked':>8}",
    ]
    for name, s in result.detector_scores.items():
        lines.append(f"{'Detector ' + name:30} {f(s['recall']):>7} {f(s['precision']):>9} {f(s['fpcpf']):>6}")
    for r in result.filters:
        s, t = r.scores, r.threshold_scores
        tracked = r.tracking.get("tracked_fraction") if r.tracking else None
        lines.append(
            f"{r.name + ' + ' + r.classifier:30} {f(s['recall']):>7} {f(s['precision']):>9} {f(s['fpcpf']):>6} "
            f"{f(s['brier'], 4):>7} {f(s['log_loss'], 3):>8} {f(s['auc'], 3):>6} {f(r.ms_per_iteration, 3):>8} "
            f"{f(tracked):>8}"
        )
        lines.append(f"{r.name + ' + threshold':30} {f(t['recall']):>7} {f(t['precision']):>9} {f(t['fpcpf']):>6}")
    return "\n".join(lines)
