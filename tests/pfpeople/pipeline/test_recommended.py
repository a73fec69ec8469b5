"""The recommended mode's parts: default grid from a laser, filter/classifier building from the configuration,
peak classification against a brute-force reference, and a default run's tracks and clutter flags."""

from __future__ import annotations

import csv
import logging
import math
from pathlib import Path

import numpy as np
import pytest
from bag_fixtures import MOUNT, config, write_bag

from gridbridge import GridFilter, GridSpec
from gridbridge.classifiers import PeakClassifier, classify_peaks
from gridbridge.components import Appearance, BeliefBounds, LinearPrediction, PaperPrediction
from gridbridge.likelihoods import DeMorganLikelihood, IndependentLikelihood
from gridbridge.params import CALIBRATED_LASER_DETECTORS, PAPER_DETECTORS, PeopleMotion, SensorMotionNoise
from pfpeople import ParticleFilter, PersistentMotion
from pfpeople.config import ClassifierConfig, FilterConfig, config_from_mapping
from pfpeople.config.modes import PAPER_DEFAULTS
from pfpeople.io.bag.reader import BagSource
from pfpeople.io.run_dir import load_run
from pfpeople.particle.predictor import PEOPLE_SAMPLERS, PaperSampling, PersistentSampling, VelocityEgoSampling
from pfpeople.particle.resampler import Resampling
from pfpeople.pipeline.assembly import BELIEF_MIN, PEAK_THRESHOLD, build_classifier, build_filter, grid_for_scan
from pfpeople.pipeline.runner import Pipeline
from pfpeople.sensors import Pose2D
from pfpeople.track import TRACK_COLUMNS


def test_grid_for_scan_hand_values() -> None:
    at = {"resolution": 0.3, "reach": 10.0}  # [grid]'s defaults
    # 180 deg, 5 m: x in [0, 5.1], y in [-5.1, 5.1] (17 x 34 cells of 0.3 m, snapped outwards)
    assert grid_for_scan(-math.pi / 2, math.pi / 2, 5.0, **at) == GridSpec(nx=17, ny=34, x0=0.0, y0=-5.1)
    # 270 deg, range_max 25 m: capped at 10 m; behind the laser to -7.07 m -> -7.2
    g = grid_for_scan(-3 * math.pi / 4, 3 * math.pi / 4, 25.0, **at)
    assert (g.nx, g.ny, g.x0, g.y0) == (58, 68, -7.2, -10.2)
    # capped at 4 m instead, at 0.5 m cells: x in [-3.0, 4.0] (-2.83 -> -3.0), y in [-4, 4]
    g = grid_for_scan(-3 * math.pi / 4, 3 * math.pi / 4, 25.0, resolution=0.5, reach=4.0)
    assert (g.nx, g.ny, g.x0, g.y0, g.resolution) == (14, 16, -3.0, -4.0, 0.5)
    # a laser at (1, 0) looking along +y: the half plane y >= 0 around it
    g = grid_for_scan(-math.pi / 2, math.pi / 2, 5.0, mount=Pose2D(x=1.0, y=0.0, yaw=math.pi / 2), **at)
    assert (g.nx, g.ny, g.x0, g.y0) == (34, 17, -4.2, 0.0)
    with pytest.raises(ValueError, match="angle_min < angle_max"):
        grid_for_scan(1.0, -1.0, 5.0, **at)


@pytest.mark.parametrize(
    ("mode", "motion_model", "max_overflow"),
    [("recommended", "persistent", 0.1), ("paper", "paper", 0.0)],
)
def test_particle_components_from_the_config_are_the_previous_defaults(
    mode: str, motion_model: str, max_overflow: float
) -> None:
    """The ``[filter]`` keys map to the components that the former constructor's defaults and keywords built:
    ``motion_model`` to the sampler (the paper's ``PeopleMotion``, the default ``PersistentMotion``), the
    default noise and a pool of 4096 draws, systematic resampling below half the count and the mode's slack."""
    pf = build_filter(FilterConfig(kind="particle", mode=mode), GridSpec(), PAPER_DETECTORS)  # type: ignore[arg-type]
    assert isinstance(pf, ParticleFilter)
    if motion_model == "persistent":  # drawn inside the compiled step (the product's default)
        assert pf.people_motion == PersistentSampling(
            motion=PeopleMotion(), persistent=PersistentMotion(), compiled_draws=True
        )
    else:
        assert pf.people_motion == PaperSampling(motion=PeopleMotion(), redraw_in_cell=False)
    assert pf.people_motion.name == motion_model == FilterConfig(mode=mode).motion_model  # type: ignore[attr-defined, arg-type]
    assert pf.ego_motion == VelocityEgoSampling(noise=SensorMotionNoise(), pool=4096)
    assert pf.resampling == Resampling(scheme="systematic", ess_threshold=0.5, max_overflow=max_overflow)
    assert max_overflow == FilterConfig(mode=mode).max_overflow and pf.n_birth == 2  # type: ignore[arg-type]
    for name, cls in PEOPLE_SAMPLERS.items():
        cfg = FilterConfig(kind="particle", mode=mode, motion_model=name)  # type: ignore[arg-type]
        assert type(build_filter(cfg, GridSpec(), PAPER_DETECTORS).people_motion) is cls  # type: ignore[union-attr]


def test_build_filter_composes_the_modes() -> None:
    spec = GridSpec()
    paper = build_filter(FilterConfig(mode="paper"), spec, PAPER_DETECTORS)
    assert isinstance(paper, GridFilter) and isinstance(paper.prediction, PaperPrediction)
    assert isinstance(paper.likelihood, DeMorganLikelihood) and paper.appearance is None and paper.bounds is None
    assert paper.initial == 0.5 and paper.outside == 0.5
    cfg = FilterConfig()  # the configuration's values reach the filter (not the tuned numbers themselves)
    rec = build_filter(cfg, spec, CALIBRATED_LASER_DETECTORS)
    assert isinstance(rec.prediction, LinearPrediction) and isinstance(rec.likelihood, IndependentLikelihood)
    assert rec.appearance == Appearance(rate=cfg.appearance_rate)
    assert rec.bounds == BeliefBounds(low=BELIEF_MIN, high=cfg.belief_max)
    assert rec.initial == rec.outside == rec.likelihood.base_rate == cfg.base_rate
    assert all(m.footprint_radius == cfg.laser_footprint for m in rec.detectors)  # the person's footprint fires
    pf = build_filter(FilterConfig(kind="particle"), spec, CALIBRATED_LASER_DETECTORS)
    assert isinstance(pf, ParticleFilter) and isinstance(pf.likelihood, IndependentLikelihood)
    assert pf.n_particles == cfg.particles_for(spec.n_cells)
    assert pf.resampling.max_overflow == FilterConfig().max_overflow > 0
    assert isinstance(pf.people_motion, PersistentSampling)
    paper_pf = build_filter(FilterConfig(kind="particle", mode="paper"), spec, PAPER_DETECTORS)
    assert isinstance(paper_pf, ParticleFilter) and paper_pf.resampling.max_overflow == 0.0
    assert isinstance(paper_pf.people_motion, PaperSampling)  # the grid's prediction, sampled
    explicit = FilterConfig(kind="particle", motion_model="paper")
    assert build_filter(explicit, spec, CALIBRATED_LASER_DETECTORS).people_motion == PaperSampling()  # type: ignore[union-attr]
    numpy_draws = build_filter(FilterConfig(kind="particle", compiled_draws=False), spec, CALIBRATED_LASER_DETECTORS)
    assert numpy_draws.people_motion == PersistentSampling()  # type: ignore[union-attr]
    assert pf.people_motion == PersistentSampling(compiled_draws=True)  # the default: drawn in the compiled step
    overflow = build_filter(FilterConfig(kind="particle", max_overflow=0.3), spec, PAPER_DETECTORS)
    assert overflow.resampling == Resampling(max_overflow=0.3)  # type: ignore[union-attr]
    # the particle filter samples the integrated kernel whatever ``form`` (a grid-filter field)
    paper_form = build_filter(FilterConfig(kind="particle", form="paper"), spec, CALIBRATED_LASER_DETECTORS)
    assert isinstance(paper_form, ParticleFilter)


def test_the_paper_mode_gives_its_defaults_and_keeps_what_is_given() -> None:
    """The paper mode's defaults are :data:`PAPER_DEFAULTS` (one table), each field given is kept."""
    paper = FilterConfig(mode="paper")
    assert {k: getattr(paper, k) for k in PAPER_DEFAULTS["filter"]} == PAPER_DEFAULTS["filter"]
    assert FilterConfig(mode="paper", form="linear", max_overflow=0.2).max_overflow == 0.2
    doc = {"frames": {"driver": "/s"}, "detectors": [{"name": "a", "kind": "leg", "topic": "/s"}]}
    cfg = config_from_mapping({**doc, "filter": {"mode": "paper"}, "tracking": {"snap_radius": 0.4}})
    assert cfg.classifier.kind == "blobs" and not cfg.clutter.enabled and cfg.tracking.people == "classified"
    assert cfg.tracking.snap_radius == 0.4 and cfg.tracking.see_through is False  # given; the mode's
    assert config_from_mapping(doc).tracking.snap_radius == 0.3 and config_from_mapping(doc).clutter.enabled


def test_paper_mode_warns_about_detectors_with_fnr_above_half(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING, logger="pfpeople.pipeline.assembly"):
        build_filter(FilterConfig(mode="paper"), GridSpec(), CALIBRATED_LASER_DETECTORS)
    assert "FNR >= 0.5" in caplog.text and "laser_legs" in caplog.text


def test_config_tables_round_trip_and_name_wrong_keys() -> None:
    doc = {
        "frames": {"driver": "/scan"},
        "filter": {"kind": "particle", "n_particles": 9000, "base_rate": 0.03},
        "classifier": {"kind": "threshold", "threshold": 0.6},
        "tracking": {"enabled": False},
        "clutter": {"enabled": True, "laser_odometry": False, "params": {"static_time": 3.0}},
        "detectors": [{"name": "a", "kind": "leg", "topic": "/scan"}],
    }
    cfg = config_from_mapping(doc)
    assert cfg.grid.fixed is None and cfg.filter.n_particles == 9000 and cfg.classifier.threshold == 0.6
    assert not cfg.tracking.enabled and cfg.clutter.enabled and not cfg.clutter.laser_odometry
    assert config_from_mapping(cfg.to_dict()) == cfg
    with pytest.raises(ValueError, match=r"^\[classifier\] thresh: unknown key; allowed: \['keep'"):
        config_from_mapping({**doc, "classifier": {"thresh": 0.6}})
    with pytest.raises(ValueError, match=r"^\[filter\] mode: must be 'recommended' or 'paper', got 'fast'$"):
        FilterConfig(mode="fast")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^\[filter\] max_overflow: must be greater than or equal to 0, got -0\.5$"):
        FilterConfig(max_overflow=-0.5)
    with pytest.raises(ValueError, match=r"^\[filter\] motion_model: must be 'persistent' or 'paper', got 'cv'$"):
        FilterConfig(motion_model="cv")  # type: ignore[arg-type]
    assert config_from_mapping({**doc, "filter": {"motion_model": "paper"}}).filter.motion_model == "paper"
    assert config_from_mapping({**doc, "filter": {"compiled_draws": False}}).filter.compiled_draws is False
    assert config_from_mapping(doc).filter.compiled_draws is True  # the default
    with pytest.raises(ValueError, match=r"\[filter\] compiled_draws: must be a valid boolean, got 'yes'"):
        config_from_mapping({**doc, "filter": {"compiled_draws": "yes"}})
    with pytest.raises(ValueError, match=r"\[classifier\] kind"):
        ClassifierConfig(kind="cnn")  # type: ignore[arg-type]
    assert build_classifier(ClassifierConfig()).threshold == PEAK_THRESHOLD  # type: ignore[attr-defined]
    assert build_classifier(ClassifierConfig(kind="threshold")).threshold == 0.5  # type: ignore[attr-defined]


def _greedy_nms(belief: np.ndarray, spec: GridSpec, threshold: float, sep: float) -> set[tuple[int, int]]:
    """Brute-force reference: every cell no higher than any cell closer than ``sep`` or next to it (the 8
    neighbours), greedy by value (ties row-major), O(n^2)."""
    s2 = (sep / spec.resolution) ** 2
    cands = []
    for i in range(spec.nx):
        for j in range(spec.ny):
            v = belief[i, j]
            if v <= threshold:
                continue
            near = [
                belief[a, b]
                for a in range(spec.nx)
                for b in range(spec.ny)
                if (a - i) ** 2 + (b - j) ** 2 < s2 - 1e-9 or max(abs(a - i), abs(b - j)) == 1
            ]
            if v >= max(near, default=0.0):
                cands.append((-v, i, j))
    kept: list[tuple[int, int]] = []
    for _, i, j in sorted(cands):
        if all((i - a) ** 2 + (j - b) ** 2 >= (sep / spec.resolution) ** 2 - 1e-9 for a, b in kept):
            kept.append((i, j))
    return set(kept)


@pytest.mark.parametrize("seed", range(5))
def test_peaks_equal_a_brute_force_greedy_nms(seed: int) -> None:
    spec = GridSpec(nx=20, ny=24)
    rng = np.random.default_rng(seed)
    belief = np.round(rng.uniform(0, 1, spec.shape), 1)  # rounding makes plateaus (ties)
    found = classify_peaks(belief, spec, threshold=0.5, min_separation=0.6, centroid_radius=0.0)
    cells = {tuple(int(v) for v in spec.to_cell(x, y)) for x, y in found.positions}
    assert cells == _greedy_nms(belief, spec, 0.5, 0.6)


def test_peaks_position_plateau_and_observed_mask() -> None:
    spec = GridSpec()
    belief = np.zeros(spec.shape)
    belief[10, 15], belief[11, 15] = 0.9, 0.6  # one person: weighted mean of the two cells (0.6 >= 0.7 / 2)
    belief[20, 5] = belief[20, 6] = 0.8  # a plateau: one person
    found = PeakClassifier(threshold=0.7).classify(belief, spec)
    assert len(found) == 2
    x0, y0 = spec.cell_centre(10, 15)
    np.testing.assert_allclose(found.positions[0], [x0 + 0.3 * 0.6 / 1.5, y0], atol=1e-12)
    assert found.scores.tolist() == [0.9, 0.8] and found.sizes.tolist() == [2, 2]
    observed = np.ones(spec.shape, dtype=bool)
    observed[20] = False
    assert len(PeakClassifier(threshold=0.7).classify(belief, spec, observed=observed)) == 1
    assert len(PeakClassifier(threshold=0.7, only_observed=False).classify(belief, spec, observed=observed)) == 2
    assert len(classify_peaks(np.zeros(spec.shape), spec)) == 0


def _pose(p: Pose2D) -> list[float]:
    return [p.x, p.y, p.yaw]


def test_default_run_writes_tracks_and_static_flags(tmp_path: Path) -> None:
    """The README's default (recommended mode, tracking, clutter map) on a synthetic bag of two people."""
    bag = tmp_path / "synthetic.bag"
    truth = write_bag(bag)
    with BagSource(bag) as src:
        pipe = Pipeline(config())
        summary, results = pipe.run(src, tmp_path / "run", keep=True)
    assert summary.frames == 20
    run = load_run(tmp_path / "run")
    assert "static" in run.detections and set(np.unique(run.detections["static"])) <= {0, 1}
    # the base frame's pose in the grid (laser) frame is recorded, so GT in base_link can be scored
    np.testing.assert_allclose(run.meta["frames_in_grid"]["base_link"], _pose(MOUNT.inverse()), atol=1e-9)
    with (tmp_path / "run" / "tracks.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert tuple(rows[0]) == TRACK_COLUMNS
    last = [r for r in rows if int(r["frame"]) == 19]
    assert len(last) == 2 and len({r["id"] for r in last}) == 2  # both people tracked, two ids
    for xy in truth.people_laser[-1]:  # each true person has a track within 0.3 m
        assert min(math.hypot(float(r["x"]) - xy[0], float(r["y"]) - xy[1]) for r in last) < 0.3
    # the classified people of every frame are within 0.3 m of a true person (precision on this bag)
    for r, xy in zip(results, truth.people_laser, strict=True):
        for p in r.people:
            assert np.min(np.hypot(*(np.asarray(xy) - p).T)) < 0.3
