"""Configuration of a bag run: topics, frames, time synchronisation, detectors, grid and filter.

A run is configured by a TOML file (read with :mod:`tomllib`) or by the same keys given as a mapping. Every
table is optional except ``[frames]`` (the driving topic) and at least one ``[[detectors]]`` entry::

    [frames]
    driver = "/scan"            # the topic whose messages make the frames (one frame per message)
    grid_frame = ""             # frame the grid is attached to; "" = the driver's header frame_id
    base_frame = "base_link"    # the robot's body frame (odometry moves it)
    time_source = "header"      # "header": header stamps (bag time for messages without a header); "bag"
    sync_tolerance_s = 0.05     # a reading further than this from the frame stamp is not used
    max_pending_frames = 20     # frames waiting for late messages before they are finalised anyway

    [odometry]
    topic = "/odom"             # nav_msgs/Odometry; "" = none (the robot is taken as standing)

    [tf]
    topics = ["/tf_static", "/tf"]   # read when present in the bag

    [mounts]                    # static 2-D mounts used when the bag has no TF for a frame:
    laser = [0.1, 0.0, 0.0]     #   child frame = [x, y, yaw] in base_frame (m, m, rad)

    [grid]                      # gridbridge.GridSpec fields; leave the table out to cover the lasers'
    nx = 30                     #   fields of view (each out to min(range_max, 10 m)) at 0.3 m cells
    ny = 30
    resolution = 0.3
    x0 = 0.0
    y0 = -4.5

    [filter]
    kind = "grid"               # "grid" (gridbridge.GridFilter) or "particle" (pfpeople.ParticleFilter)
    mode = "recommended"        # "recommended" (the product's default) or "paper" (Batista & Pereira as written)
    # form, initial, n_particles, seed, motion_model, compiled_draws, max_overflow, base_rate, appearance_rate,
    # belief_max, laser_footprint: see FilterConfig (unset = the mode's default)

    [classifier]
    kind = "peaks"              # "peaks" (recommended mode's default), "blobs" (paper's), "threshold"
    threshold = 0.7             # default 0.7 for peaks, 0.5 for threshold
    min_separation = 0.6        # m
    keep = 0.5                  # peaks: a person of the previous frame continues above this (hysteresis)
    smooth = 0.0                # peaks: found on the belief smoothed by a Gaussian of this many cells (0: none)

    [tracking]
    enabled = true              # tracks.csv and tracks in the result bag
    peak_threshold = 0.5        # with the peaks classifier: the tracker gets the peaks above this and starts
                                #   tracks only from the classifier's people (above its threshold)
    people = "confirmed"        # people.csv: the classified people once a track confirms them, plus confirmed
                                #   tracks through coast_frames misses ("classified": every classified person;
                                #   default "confirmed" in the recommended mode, "classified" in the paper mode)
    coast_frames = 1
    single_legs = true          # unpaired single legs of the laser detectors continue confirmed tracks (never
                                #   start one; with people = "confirmed")
    snap_radius = 0.3           # people with detections this close (m) are moved to their mean (0: never)
    static_confirm_s = 1.0      # a track that has not moved 0.3 m is reported once this old (s; 0: at once)
    observed_tracks_only = true # tracks.csv: a coasting track is left out where no detector observes
    see_through = true          # a coasting track / person is left out where a laser sees through it
    [tracking.params]           # pfpeople.track.TrackerConfig fields

    [clutter]                   # static-clutter suppression of laser detections (pfpeople.perception.clutter_map)
    enabled = true              # default: on in the recommended mode, off in the paper mode
    laser_odometry = true       # no odometry topic: move the grid by scan matching the driving laser
    [clutter.params]            # pfpeople.perception.clutter_map.ClutterConfig fields

    [output]
    frame = ""                  # frame of the people, tracks and markers written (people.csv / tracks.csv extra
                                #   columns, result bag, pfpeople node): "" = the grid frame; e.g. "odom" (the
                                #   odometry's frame or any TF frame); the grid stays in the grid frame

    [[detectors]]
    name = "laser_legs"
    kind = "leg"                # "leg" | "boosted" | "single-legs" | "hog" (built-in) | "topic" (in the bag)
    topic = "/scan"             # its input: LaserScan for leg/boosted/single-legs, Image/CompressedImage for hog,
                                #   PoseArray or any message with a pose / poses field for "topic"
    frame = ""                  # frame of its output when the message has no header ("" = the message's)
    assign = "nearest"          # "nearest": the message closest to the frame stamp (within the tolerance);
                                #   "preceding": all messages from this frame's stamp to the next frame's
    [detectors.model]           # DetectorModel fields overriding the detector's own (radians, metres);
    ppv = 0.95                  #   a laser detector's fov_min, fov_max, min_range and max_range default to
    fnr = 0.30                  #   its LaserScan's angle_min, angle_max, range_min and range_max
    [detectors.params]          # keyword arguments of the built-in detector's constructor

Angles are radians, lengths metres, times seconds (REP-103 frames).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from gridbridge.grid import GridSpec
from gridbridge.limits import check_grid_size, check_memory, check_smooth
from gridbridge.params import DetectorModel, PeopleMotion, current_detector_name
from gridbridge.validation import check_int, check_number, check_probability, check_real

__all__ = [
    "DETECTOR_KINDS",
    "MODES",
    "BagConfig",
    "ClassifierConfig",
    "ClutterSuppression",
    "DetectorConfig",
    "FilterConfig",
    "OutputConfig",
    "TrackingConfig",
    "check_run_limits",
    "config_from_mapping",
    "load_config",
    "run_topics",
]

log = logging.getLogger(__name__)

#: Detector kinds: the built-in detectors and detections read from a topic.
DETECTOR_KINDS = ("leg", "boosted", "single-legs", "learned", "motion", "hog", "topic")
_MODEL_FIELDS = {f.name for f in fields(DetectorModel)}


def _check_str(value: object, name: str, *, allow_empty: bool = False) -> str:
    if not isinstance(value, str) or (not allow_empty and not value):
        raise ValueError(f"{name} must be a {'' if allow_empty else 'non-empty '}string, got {value!r}")
    return value


@dataclass(frozen=True, kw_only=True)
class DetectorConfig:
    """One detector of a run.

    Parameters
    ----------
    name : str
        Unique name (used in the outputs).
    kind : {"leg", "boosted", "single-legs", "hog", "topic"}
        Built-in detector run on the input topic, or ``"topic"``: positions read from the topic.
    topic : str
        Input topic.
    frame : str
        Frame of the detections when the message has no header; ``""`` = the message's frame_id (or the
        grid frame when the message has none).
    assign : {"nearest", "preceding"}
        How messages of the topic are assigned to frames (see the module docstring).
    model : mapping
        :class:`gridbridge.params.DetectorModel` fields overriding the detector's own model. Required (at
        least ``ppv`` and ``fnr``) for ``kind="topic"``.
    params : mapping
        Keyword arguments of the built-in detector's constructor.
    """

    name: str
    kind: str
    topic: str
    frame: str = ""
    assign: str = "nearest"
    model: Mapping[str, Any] = field(default_factory=dict)
    params: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        _check_str(self.name, "DetectorConfig.name")
        if self.kind not in DETECTOR_KINDS:
            raise ValueError(f"DetectorConfig({self.name}).kind must be one of {DETECTOR_KINDS}, got {self.kind!r}")
        _check_str(self.topic, f"DetectorConfig({self.name}).topic")
        _check_str(self.frame, f"DetectorConfig({self.name}).frame", allow_empty=True)
        if self.assign not in ("nearest", "preceding"):
            raise ValueError(
                f"DetectorConfig({self.name}).assign must be 'nearest' or 'preceding', got {self.assign!r}"
            )
        unknown = set(self.model) - _MODEL_FIELDS
        if unknown:
            raise ValueError(
                f"DetectorConfig({self.name}).model has unknown fields {sorted(unknown)}; "
                f"DetectorModel fields are {sorted(_MODEL_FIELDS)}"
            )
        if self.kind == "topic" and not {"ppv", "fnr"} <= set(self.model):
            raise ValueError(f"DetectorConfig({self.name}).model must give ppv and fnr for a kind='topic' detector")
        if "name" in self.model and self.model["name"] != self.name:
            raise ValueError(f"DetectorConfig({self.name}).model.name must equal the detector's name")
        if not isinstance(self.params, Mapping):
            raise ValueError(f"DetectorConfig({self.name}).params must be a table")


MODES = ("recommended", "paper")


@dataclass(frozen=True, kw_only=True)
class FilterConfig:
    """Which filter a run uses and its options (one specification, built by
    :func:`pfpeople.pipeline.assembly.build_filter`).

    Parameters
    ----------
    kind : {"grid", "particle"}
        ``gridbridge.GridFilter`` or ``pfpeople.ParticleFilter``.
    mode : {"recommended", "paper"}
        ``"recommended"`` (default): the product's configuration, chosen on the benchmark across every scene
        (README "Recommended mode"): linear people prediction, appearance probability, bounded belief,
        calibrated independent fusion of the detectors (:class:`gridbridge.likelihoods.IndependentLikelihood`),
        laser detections with the person's footprint. ``"paper"``: Batista & Pereira (2015) as written (De Morgan
        fusion, beliefs unbounded, initial 0.5, border belief 0.5).
    form : {"paper", "linear"} or None
        People-motion prediction; None: ``"linear"`` in the recommended mode, ``"paper"`` in the paper mode.
    initial : float or None
        Initial belief of every cell; None: the base rate (recommended) or 0.5 (paper).
    n_particles : int or None
        Particle count (particle filter only); None: 5 per cell, at least 5000.
    seed : int
        Seed (>= 0) of the particle filter's ``numpy.random.Generator``.
    motion_model : {"paper", "persistent"} or None
        Particle people-motion sampler (:mod:`pfpeople.particle.propagation`); None: ``"persistent"`` in the recommended
        mode (walkers keep their heading and speed: compact person blobs, README "Recommended particles"),
        ``"paper"`` (the paper's memoryless model, what the grid filter predicts) in the paper mode.
    compiled_draws : bool
        Particle filter with the persistent people motion: draw it inside the compiled step (default;
        :class:`pfpeople.particle.components.PersistentSampling`'s ``compiled_draws``), faster, the same
        distributions as numpy's draws (false), other draws; the paper's people motion always draws there.
    max_overflow : float or None
        Particle filter: births may push the count this fraction above ``n_particles`` before they trigger a
        resampling (:class:`pfpeople.ParticleFilter`); None: 0.1 in the recommended mode (29 % of the steps
        then resample instead of all, at the same accuracy: README "Benchmarks"), 0 in the paper mode.
    base_rate : float
        Recommended mode: prior probability of a person per cell (appearance floor, calibration of the PPV).
    appearance_rate : float
        Recommended mode: rate (1/s) at which an observed cell gets someone new
        (:class:`gridbridge.components.Appearance`).
    belief_max : float
        Recommended mode: upper bound of the belief (bounded log-odds).
    laser_footprint : float
        Recommended mode: a point (laser) detection fires every cell whose centre is within this distance (m).
    """

    kind: str = "grid"
    mode: str = "recommended"
    form: str | None = None
    initial: float | None = None
    n_particles: int | None = None
    seed: int = 0
    motion_model: str | None = None
    compiled_draws: bool = True
    max_overflow: float | None = None
    base_rate: float = 0.02
    appearance_rate: float = 0.05
    belief_max: float = 0.99
    laser_footprint: float = 0.3

    def __post_init__(self) -> None:
        if self.kind not in ("grid", "particle"):
            raise ValueError(f"FilterConfig.kind must be 'grid' or 'particle', got {self.kind!r}")
        if self.mode not in MODES:
            raise ValueError(f"FilterConfig.mode must be one of {MODES}, got {self.mode!r}")
        if self.form is not None and self.form not in ("paper", "linear"):
            raise ValueError(f"FilterConfig.form must be 'paper' or 'linear', got {self.form!r}")
        if self.initial is not None:
            check_probability(check_real(self.initial, "FilterConfig.initial"), "FilterConfig.initial")
        if self.n_particles is not None:
            check_int(self.n_particles, "FilterConfig.n_particles", minimum=1)
        check_int(self.seed, "FilterConfig.seed", minimum=0)  # numpy's generators take non-negative seeds
        if self.motion_model not in (None, "paper", "persistent"):
            raise ValueError(
                f"FilterConfig.motion_model must be 'paper', 'persistent' or unset, got {self.motion_model!r}"
            )
        if not isinstance(self.compiled_draws, bool):
            raise TypeError(f"FilterConfig.compiled_draws must be true or false, got {self.compiled_draws!r}")
        if self.max_overflow is not None:
            check_real(self.max_overflow, "FilterConfig.max_overflow", low=0.0, high=10.0)
        for name in ("base_rate", "belief_max"):
            check_real(getattr(self, name), f"FilterConfig.{name}", low=0.0, high=1.0, low_open=True, high_open=True)
        for name in ("appearance_rate", "laser_footprint"):
            check_real(getattr(self, name), f"FilterConfig.{name}", low=0.0)
        if self.mode == "recommended" and not self.base_rate < self.belief_max:
            raise ValueError("FilterConfig: base_rate must be below belief_max")

    def particles_for(self, n_cells: int) -> int:
        """The particle count for a grid of ``n_cells`` cells (``n_particles`` or 5 per cell, >= 5000)."""
        return self.n_particles if self.n_particles is not None else max(5000, 5 * n_cells)


@dataclass(frozen=True, kw_only=True)
class ClassifierConfig:
    """How the belief becomes people (``[classifier]``).

    Parameters
    ----------
    kind : {"peaks", "blobs", "threshold"} or None
        Peaks with non-maximum suppression (:class:`gridbridge.classifiers.PeakClassifier`), the paper's blobs,
        or connected cells above a threshold; None: peaks in the recommended mode, blobs in the paper mode.
    threshold : float or None
        Peak / cell threshold; None: 0.7 for peaks (chosen on the benchmark: at 0.5 negative_2 has 40 % more
        false people for 4 % more recall on the ETH/UCY replays), 0.5 for the plain threshold classifier.
    min_separation : float
        Peaks: two people are at least this far apart (m).
    keep : float or None
        Peaks: hysteresis (:class:`gridbridge.classifiers.HysteresisPeaks`): a person of the previous frame
        continues at a peak within 0.5 m whose belief is above ``keep`` (<= ``threshold``); None: 0.5
        (see ``pfpeople.pipeline.assembly.PEAK_KEEP``); equal to ``threshold``: no hysteresis.
    smooth : float
        Peaks: standard deviation (cells) of a Gaussian the belief is smoothed with before its maxima are found
        (:func:`gridbridge.classifiers.classify_peaks`); 0 (default): none; at most
        :data:`gridbridge.limits.MAX_SMOOTH_CELLS` (10). For the particle filter, whose
        rasterised mass gives a person several separate cells at the bound: with 1.0 its pipeline's precision on
        the scan-level scenes goes from 0.79-0.82 to 0.89-0.96 and the MOTA of its tracks from 0.32-0.35 to
        0.45-0.55, for 0.06-0.07 less recall there and 0.13-0.15 less on the ETH/UCY replays (README,
        "Recommended mode"). The grid filter loses by it (recall -0.02, MOTA -0.02 at 0.7).
    """

    kind: str | None = None
    threshold: float | None = None
    min_separation: float = 0.6
    keep: float | None = None
    smooth: float = 0.0

    def __post_init__(self) -> None:
        if self.kind is not None and self.kind not in ("peaks", "blobs", "threshold"):
            raise ValueError(f"ClassifierConfig.kind must be 'peaks', 'blobs' or 'threshold', got {self.kind!r}")
        thr, keep = self.threshold, self.keep
        for name, value in (("threshold", thr), ("keep", keep)):
            if value is not None:
                check_probability(check_real(value, f"ClassifierConfig.{name}"), f"ClassifierConfig.{name}")
        if keep is not None and thr is not None and keep > thr:
            raise ValueError(f"ClassifierConfig.keep must be <= threshold, got keep={keep!r} > threshold={thr!r}")
        check_real(self.min_separation, "ClassifierConfig.min_separation", low=0.0, low_open=True)
        check_smooth(self.smooth, "ClassifierConfig.smooth")


@dataclass(frozen=True, kw_only=True)
class ClutterSuppression:
    """Static-clutter suppression and laser odometry (``[clutter]``, :mod:`pfpeople.perception.clutter_map`).

    Parameters
    ----------
    enabled : bool or None
        Drop laser detections on places that have been occupied for a long time (chair and table legs, posts);
        None: on in the recommended mode, off in the paper mode.
    laser_odometry : bool
        Without an odometry topic, move the grid with the driving laser's scan matching (when it succeeds).
    params : mapping
        :class:`pfpeople.perception.clutter_map.ClutterConfig` fields overriding its defaults.
    """

    enabled: bool | None = None
    laser_odometry: bool = True
    params: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.enabled is not None and not isinstance(self.enabled, bool):
            raise ValueError(f"[clutter] enabled must be true or false, got {self.enabled!r}")
        if not isinstance(self.laser_odometry, bool):
            raise ValueError(f"[clutter] laser_odometry must be true or false, got {self.laser_odometry!r}")
        if not isinstance(self.params, Mapping):
            raise ValueError("[clutter] params must be a table")

    def on(self, mode: str) -> bool:
        """Whether suppression runs in ``mode``."""
        return self.enabled if self.enabled is not None else mode == "recommended"


@dataclass(frozen=True, kw_only=True)
class TrackingConfig:
    """Multi-person tracking of the classified people (``[tracking]``): ``tracks.csv`` and result-bag tracks.

    Parameters
    ----------
    enabled : bool
        Track (default True).
    peak_threshold : float or None
        With the peaks classifier and a threshold below the classifier's: the tracker is fed the belief peaks
        above this (they update tracks through a dip of the belief) and starts tracks only from the peaks above
        the classifier's threshold (``birth_min_score``, unless ``params`` sets it). None: the tracker gets the
        classifier's people. Default 0.5 (MOT ablation: see :class:`pfpeople.track.TrackerConfig`).
    people : {"confirmed", "classified"} or None
        The people a run reports (``people.csv``, the result bag's people; see :mod:`pfpeople.track.reported_people`):
        ``"confirmed"``, a classified person once a confirmed track has it, plus confirmed tracks through up to
        ``coast_frames`` missed frames; ``"classified"``, every classified person. None: ``"confirmed"`` in the
        recommended filter mode, ``"classified"`` in the paper mode (and whenever tracking is off).
    coast_frames : int
        See ``people`` (default 1).
    single_legs : bool
        With ``people = "confirmed"``: the laser detectors' unpaired single legs (static clutter removed) are
        given to the tracker as support positions: they continue confirmed tracks that no classified person
        continued, which are then reported, and never start a track (:mod:`pfpeople.track.reported_people`).
        Default True.
    snap_radius : float
        The classified people and weaker peaks with detections of point-like detectors (the laser ones, static
        clutter removed) within this distance (m) are moved to their mean before tracking and reporting
        (:mod:`pfpeople.track.reported_people`); 0: never. Default 0.3; the paper mode never snaps.
    observed_tracks_only : bool
        Recommended mode: ``tracks.csv`` and the result bag's tracks leave out a confirmed track without a hit in
        this frame while its predicted position lies in no cell a detector observes (it lives on and keeps its id;
        :mod:`pfpeople.track.reported_people`). Default True; the paper mode never leaves tracks out.
    static_confirm_s : float
        With ``people = "confirmed"``: a track that has not moved (0.3 m from its birth position in the odometry
        frame, ``TrackerConfig.moved_distance``) is reported only from this age (s) on; a walker as soon as it is
        confirmed (:mod:`pfpeople.track.reported_people`). 0: any confirmed track. Default 1.0.
    see_through : bool
        Recommended mode: a track without a hit in this frame is left out of ``tracks.csv``, the result bag and
        the people where a laser sees through its predicted position (every beam within 0.5 m of it returns 0.5 m
        or more behind it: the person left, stopped or turned; :mod:`pfpeople.track.free_space`). Default True; the
        paper mode never does.
    params : mapping
        :class:`pfpeople.track.TrackerConfig` fields overriding its defaults.
    """

    enabled: bool = True
    peak_threshold: float | None = 0.5
    people: str | None = None
    coast_frames: int = 1
    single_legs: bool = True
    snap_radius: float = 0.3
    static_confirm_s: float = 1.0
    observed_tracks_only: bool = True
    see_through: bool = True
    params: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.enabled, bool):
            raise ValueError(f"TrackingConfig.enabled must be true or false, got {self.enabled!r}")
        if self.peak_threshold is not None:
            check_real(self.peak_threshold, "TrackingConfig.peak_threshold", low=0.0, high=1.0, high_open=True)
        if self.people is not None and self.people not in ("confirmed", "classified"):
            raise ValueError(f'TrackingConfig.people must be "confirmed" or "classified", got {self.people!r}')
        check_int(self.coast_frames, "TrackingConfig.coast_frames", minimum=0)
        check_real(self.snap_radius, "TrackingConfig.snap_radius", low=0.0)
        check_real(self.static_confirm_s, "TrackingConfig.static_confirm_s", low=0.0)
        if not isinstance(self.single_legs, bool):
            raise ValueError(f"TrackingConfig.single_legs must be true or false, got {self.single_legs!r}")
        if not isinstance(self.observed_tracks_only, bool):
            raise ValueError(
                f"TrackingConfig.observed_tracks_only must be true or false, got {self.observed_tracks_only!r}"
            )
        if not isinstance(self.see_through, bool):
            raise ValueError(f"TrackingConfig.see_through must be true or false, got {self.see_through!r}")
        if not isinstance(self.params, Mapping):
            raise ValueError("TrackingConfig.params must be a table")


@dataclass(frozen=True, kw_only=True)
class OutputConfig:
    """Where a run's results are given (``[output]``).

    Parameters
    ----------
    frame : str
        The frame of the people, tracks and markers a run writes besides the grid frame's (``people.csv`` and
        ``tracks.csv`` ``out_*`` columns, the result bag's people, tracks and markers, the node's topics): the
        odometry's frame (its messages' ``header.frame_id``) or any frame TF connects to the grid frame, e.g.
        ``"odom"``; ``""``: the grid frame (nothing more is written). The grid stays in the grid frame.
    """

    frame: str = ""

    def __post_init__(self) -> None:
        _check_str(self.frame, "OutputConfig.frame", allow_empty=True)
        if self.frame.startswith("/"):
            raise ValueError(f"OutputConfig.frame: a TF frame id has no leading '/', got {self.frame!r}")


@dataclass(frozen=True, kw_only=True)
class BagConfig:
    """Everything a bag run needs besides the bag (see the module docstring for the TOML form).

    Parameters
    ----------
    driver : str
        Topic whose messages make the frames.
    detectors : tuple of DetectorConfig
        The detectors, in the order the filter sees them.
    grid_frame : str
        Frame of the grid (``""``: the driver's frame_id).
    base_frame : str
        Robot body frame.
    time_source : {"header", "bag"}
        Stamps used for synchronisation.
    sync_tolerance_s : float
        Largest distance (s) between a frame stamp and a reading used for it.
    max_pending_frames : int
        Frames kept waiting for late messages (memory bound).
    odometry : str
        ``nav_msgs/Odometry`` topic, ``""`` for none.
    tf_topics : tuple of str
        TF topics read when present.
    mounts : mapping of str to (x, y, yaw)
        Static mounts of frames in ``base_frame`` used when TF does not give them.
    grid : GridSpec or None
        The local grid in the grid frame; None: the bounding box of the fields of view of the driving laser and
        of every laser with a detector, each out to ``min(range_max, 10 m)``, at 0.3 m cells (see
        :func:`pfpeople.pipeline.assembly.grid_for_scan` and :func:`pfpeople.pipeline.sensor_setup.default_grid`).
    filter : FilterConfig
        The filter.
    classifier : ClassifierConfig
        Belief -> people.
    tracking : TrackingConfig
        People -> tracks.
    clutter : ClutterSuppression
        Static-clutter suppression of laser detections, laser odometry.
    output : OutputConfig
        The frame of the results besides the grid frame.
    """

    driver: str
    detectors: tuple[DetectorConfig, ...]
    grid_frame: str = ""
    base_frame: str = "base_link"
    time_source: str = "header"
    sync_tolerance_s: float = 0.05
    max_pending_frames: int = 20
    odometry: str = ""
    tf_topics: tuple[str, ...] = ("/tf_static", "/tf")
    mounts: Mapping[str, tuple[float, float, float]] = field(default_factory=dict)
    grid: GridSpec | None = None
    filter: FilterConfig = field(default_factory=FilterConfig)
    classifier: ClassifierConfig = field(default_factory=ClassifierConfig)
    tracking: TrackingConfig = field(default_factory=TrackingConfig)
    clutter: ClutterSuppression = field(default_factory=ClutterSuppression)
    output: OutputConfig = field(default_factory=OutputConfig)

    def __post_init__(self) -> None:
        _check_str(self.driver, "BagConfig.driver")
        if not self.detectors:
            raise ValueError("BagConfig.detectors must name at least one detector")
        if not all(isinstance(d, DetectorConfig) for d in self.detectors):
            raise ValueError("BagConfig.detectors must be DetectorConfig objects")
        names = [d.name for d in self.detectors]
        if len(set(names)) != len(names):
            raise ValueError(f"BagConfig.detectors: names must be unique, got {names}")
        _check_str(self.grid_frame, "BagConfig.grid_frame", allow_empty=True)
        _check_str(self.base_frame, "BagConfig.base_frame")
        if self.time_source not in ("header", "bag"):
            raise ValueError(f"BagConfig.time_source must be 'header' or 'bag', got {self.time_source!r}")
        check_real(self.sync_tolerance_s, "BagConfig.sync_tolerance_s", low=0.0)
        check_int(self.max_pending_frames, "BagConfig.max_pending_frames", minimum=1)
        _check_str(self.odometry, "BagConfig.odometry", allow_empty=True)
        for t in self.tf_topics:
            _check_str(t, "BagConfig.tf_topics")
        for frame, mount in self.mounts.items():
            _mount(f"BagConfig.mounts[{frame!r}]", mount)
        if self.grid is not None and not isinstance(self.grid, GridSpec):
            raise ValueError("BagConfig.grid must be a GridSpec or None (from the driving laser)")
        if not isinstance(self.filter, FilterConfig):
            raise ValueError("BagConfig.filter must be a FilterConfig")
        if not isinstance(self.classifier, ClassifierConfig):
            raise ValueError("BagConfig.classifier must be a ClassifierConfig")
        if not isinstance(self.tracking, TrackingConfig):
            raise ValueError("BagConfig.tracking must be a TrackingConfig")
        if not isinstance(self.clutter, ClutterSuppression):
            raise ValueError("BagConfig.clutter must be a ClutterSuppression")
        if not isinstance(self.output, OutputConfig):
            raise ValueError("BagConfig.output must be an OutputConfig")
        if self.grid is not None:
            check_run_limits(self.grid, self.filter, len(self.detectors))

    @property
    def sync_tolerance_ns(self) -> int:
        return round(self.sync_tolerance_s * 1e9)

    def to_dict(self) -> dict[str, Any]:
        """A JSON/TOML-able mapping that :func:`config_from_mapping` turns back into this config."""
        out: dict[str, Any] = {
            "frames": {
                "driver": self.driver,
                "grid_frame": self.grid_frame,
                "base_frame": self.base_frame,
                "time_source": self.time_source,
                "sync_tolerance_s": self.sync_tolerance_s,
                "max_pending_frames": self.max_pending_frames,
            },
            "odometry": {"topic": self.odometry},
            "tf": {"topics": list(self.tf_topics)},
            "mounts": {k: list(v) for k, v in self.mounts.items()},
            "filter": {f.name: getattr(self.filter, f.name) for f in fields(FilterConfig)},
            "classifier": {f.name: getattr(self.classifier, f.name) for f in fields(ClassifierConfig)},
            "tracking": {
                "enabled": self.tracking.enabled,
                "peak_threshold": self.tracking.peak_threshold,
                "people": self.tracking.people,
                "coast_frames": self.tracking.coast_frames,
                "single_legs": self.tracking.single_legs,
                "snap_radius": self.tracking.snap_radius,
                "static_confirm_s": self.tracking.static_confirm_s,
                "observed_tracks_only": self.tracking.observed_tracks_only,
                "see_through": self.tracking.see_through,
                "params": dict(self.tracking.params),
            },
            "clutter": {
                k: v
                for k, v in {
                    "enabled": self.clutter.enabled,
                    "laser_odometry": self.clutter.laser_odometry,
                    "params": dict(self.clutter.params),
                }.items()
                if v is not None
            },
            "detectors": [
                {
                    "name": d.name,
                    "kind": d.kind,
                    "topic": d.topic,
                    "frame": d.frame,
                    "assign": d.assign,
                    "model": dict(d.model),
                    "params": dict(d.params),
                }
                for d in self.detectors
            ],
        }
        if self.grid is not None:
            out["grid"] = {f.name: getattr(self.grid, f.name) for f in fields(GridSpec)}
        if self.output.frame:
            out["output"] = {"frame": self.output.frame}
        # TOML has no null: unset options are left out (they mean "the mode's default")
        out["filter"] = {k: v for k, v in out["filter"].items() if v is not None}
        out["classifier"] = {k: v for k, v in out["classifier"].items() if v is not None}
        return out


def check_run_limits(g: GridSpec, filt: FilterConfig, n_detectors: int) -> None:
    """Resource limits before anything is allocated (:mod:`gridbridge.limits`, :mod:`pfpeople.particle.limits`): cells,
    prediction work, particles, memory."""
    from pfpeople.particle.limits import check_particles

    check_grid_size(g.nx, g.ny, g.resolution, v_max=PeopleMotion().v_max, dt=0.1, where="BagConfig.grid")
    if filt.kind == "particle":
        check_particles(
            filt.particles_for(g.n_cells),
            n_cells=g.n_cells,
            n_detectors=n_detectors,
            where="BagConfig.filter.n_particles",
        )
    else:
        check_memory(g.n_cells, n_detectors=n_detectors, where="BagConfig.grid")


def _table(data: Mapping[str, Any], key: str) -> Mapping[str, Any]:
    value = data.get(key, {})
    if not isinstance(value, Mapping):
        raise ValueError(f"config: [{key}] must be a table, got {type(value).__name__}")
    return value


def _only(table: Mapping[str, Any], allowed: set[str], where: str) -> None:
    unknown = set(table) - allowed
    if unknown:
        raise ValueError(f"config: unknown keys {sorted(unknown)} in [{where}]; allowed: {sorted(allowed)}")


def _mount(key: str, value: object) -> tuple[float, float, float]:
    """A ``[mounts]`` entry as ``(x, y, yaw)``; TypeError / ValueError naming the key for another value."""
    where = key if key.startswith("BagConfig.") else f"[mounts] {key!r}"
    if isinstance(value, str | bytes) or not isinstance(value, Sequence) or len(value) != 3:
        raise ValueError(f"{where} must be three numbers [x, y, yaw] (m, m, rad), got {value!r}")
    x, y, yaw = (check_number(v, f"{where} {axis}") for v, axis in zip(value, ("x", "y", "yaw"), strict=True))
    return x, y, yaw


#: The tables of a run configuration.
_TABLES = frozenset(("frames", "odometry", "tf", "mounts", "grid", "filter", "classifier", "tracking", "clutter"))
_TABLES |= {"output", "detectors"}


def config_from_mapping(data: Mapping[str, Any], *, source: str = "config") -> BagConfig:
    """Build a :class:`BagConfig` from a parsed TOML document (see the module docstring); ``source`` names it in
    the warning about detector names of earlier versions (:func:`gridbridge.params.current_detector_name`)."""
    _only(data, set(_TABLES), "top level")
    frames = _table(data, "frames")
    _only(
        frames,
        {"driver", "grid_frame", "base_frame", "time_source", "sync_tolerance_s", "max_pending_frames"},
        "frames",
    )
    if "driver" not in frames:
        raise ValueError("config: [frames] driver (the topic that drives the frames) is required")
    odometry = _table(data, "odometry")
    _only(odometry, {"topic"}, "odometry")
    tf = _table(data, "tf")
    _only(tf, {"topics"}, "tf")
    tf_topics = tf.get("topics", ("/tf_static", "/tf"))
    if not isinstance(tf_topics, list | tuple):  # a bare string would be read as its characters
        raise ValueError(f"config: [tf] topics must be an array of topic names, got {tf_topics!r}")
    grid = _table(data, "grid")
    _only(grid, {f.name for f in fields(GridSpec)}, "grid")
    filt = _table(data, "filter")
    _only(filt, {f.name for f in fields(FilterConfig)}, "filter")
    classifier = _table(data, "classifier")
    _only(classifier, {f.name for f in fields(ClassifierConfig)}, "classifier")
    tracking = _table(data, "tracking")
    _only(tracking, {f.name for f in fields(TrackingConfig)}, "tracking")
    clutter = _table(data, "clutter")
    _only(clutter, {"enabled", "laser_odometry", "params"}, "clutter")
    output = _table(data, "output")
    _only(output, {"frame"}, "output")
    dets = data.get("detectors", [])
    if not isinstance(dets, list):
        raise ValueError("config: detectors must be an array of tables ([[detectors]])")
    detectors = []
    renamed: dict[str, str] = {}
    for k, d in enumerate(dets):
        if not isinstance(d, Mapping):
            raise ValueError(f"config: detectors[{k}] must be a table")
        _only(d, {f.name for f in fields(DetectorConfig)}, f"detectors[{k}]")
        detectors.append(DetectorConfig(**_current_name(d, renamed)))
    if renamed:
        pairs = [f"{old!r} as {new!r}" for old, new in renamed.items()]
        log.warning(
            "%s: %d detector name(s) are pfpeople's former default names, which are not valid ROS names: read with "
            "today's (%s); rename them in the config to silence this",
            source,
            len(pairs),
            ", ".join(pairs[:3] + (["..."] if len(pairs) > 3 else [])),
        )
    mounts = {str(k): _mount(k, v) for k, v in _table(data, "mounts").items()}
    return BagConfig(
        **frames,
        detectors=tuple(detectors),
        odometry=odometry.get("topic", ""),
        tf_topics=tuple(tf_topics),
        mounts=mounts,
        grid=GridSpec(**grid) if grid else None,
        filter=FilterConfig(**filt),
        classifier=ClassifierConfig(**classifier),
        tracking=TrackingConfig(**tracking),
        clutter=ClutterSuppression(**clutter),
        output=OutputConfig(**output),
    )


def _current_name(table: Mapping[str, Any], renamed: dict[str, str]) -> dict[str, Any]:
    """A ``[[detectors]]`` table with an old default name (``laser-legs``, ``laser-boosted:rear_scan``) as today's
    (:func:`gridbridge.params.current_detector_name`), its ``[detectors.model] name`` too; ``renamed`` gets
    ``old -> new``."""
    out = dict(table)
    name = out.get("name")
    new = current_detector_name(name) if isinstance(name, str) else name
    if new == name:
        return out
    renamed[str(name)] = str(new)
    out["name"] = new
    model = out.get("model")
    if isinstance(model, Mapping) and model.get("name") == name:
        out["model"] = {**model, "name": new}
    return out


def load_config(path: str | Path) -> BagConfig:
    """Read a TOML run configuration; errors name the file (:func:`pfpeople.io.tomlio.load_toml`: not UTF-8, not
    TOML, nested too deeply; then the setting at fault)."""
    from pfpeople.io.tomlio import load_toml

    path = Path(path)
    data = load_toml(path, "config file")
    try:
        return config_from_mapping(data, source=f"config file {str(path)!r}")
    except (ValueError, TypeError) as exc:
        raise ValueError(f"config file {str(path)!r}: {exc}") from None


def builtin_config_path(name: str) -> Path:
    """Path of a configuration shipped in ``pfpeople/configs`` (``name`` without ``.toml``)."""
    path = Path(__file__).with_name("configs") / f"{name}.toml"
    if not path.is_file():
        have = sorted(p.stem for p in path.parent.glob("*.toml"))
        raise FileNotFoundError(f"no built-in config {name!r}; available: {have}")
    return path


def run_topics(config: BagConfig) -> list[str]:
    """The topics a run reads: driver, detector topics and odometry (sorted)."""
    topics = {config.driver, *(d.topic for d in config.detectors)}
    if config.odometry:
        topics.add(config.odometry)
    return sorted(topics)
