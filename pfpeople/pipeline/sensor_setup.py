"""Sensor setup of a bag run: topic checks, TF mounts, each laser's field of view, and the default grid.

Before the first frame, :func:`setup_sensors` reads what is fixed for the whole run:

- the topics and their message types (:meth:`pfpeople.io.bag.reader.BagSource.require`);
- TF: every ``/tf_static`` message and each frame's first transform in the first :data:`TF_PRELOAD_S` s of
  ``/tf`` (or later, for a frame first published later; the config's ``[mounts]`` stand in for frames without TF,
  as children of the base frame). The run follows the later transforms (:mod:`pfpeople.pipeline.mounts`);
- the grid frame (``[frames] grid_frame``, else the driver's ``frame_id``);
- each detector's mount ``T`` (its frame's pose in the grid frame, m and rad), the pose in the grid frame of
  every frame the run's positions may be given in (written to ``run.json`` as ``frames_in_grid``), and the
  grid frame's mount on the base frame (needed by odometry, :mod:`pfpeople.perception.odometry`);
- for a LaserScan detector, the field of view ``[fov_min, fov_max]`` (rad) and ``max_range`` (m) of its
  first scan where ``[detectors.model]`` leaves them out;
- the grid: ``[grid]``, where it leaves its extent ``"auto"`` the one covering the fields of view of the driving
  laser and of every laser with a detector, each at its mount (:func:`pfpeople.pipeline.assembly.grid_for_scan`, the
  union of their boxes), else the paper's 30 x 30 cells.

Once the detectors' models are known (:meth:`pfpeople.pipeline.runner.Pipeline.prepare`), two checks of the setup as a
whole: :func:`check_grid_seen` refuses a grid with no cell inside any detector's field of view (the run could
only find nobody; refused rather than warned, as no frame of such a run says anything and it fails before any
output is written), :func:`warn_coarse_lasers` warns once per topic when a leg detector's laser is too coarse
to put :data:`pfpeople.detect.legs.MIN_LEG_BEAMS` returns on a leg within :data:`MIN_LEG_RANGE_M`, and
:func:`warn_dense_lasers` once per topic when a laser detector's scans are finer than the detectors are built for
(they get them thinned, :mod:`pfpeople.detect.spacing`).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

from gridbridge.geometry import Pose2D
from gridbridge.grid import GridSpec
from gridbridge.measurement import fov_mask
from gridbridge.params import DetectorModel
from pfpeople.config import BagConfig, DetectorConfig, check_run_limits, run_topics
from pfpeople.detect.adapters import DetectorAdapter, LaserAdapter
from pfpeople.detect.legs import MIN_LEG_BEAMS, LegDetectorParams, leg_beam_range
from pfpeople.detect.spacing import FINEST_SPACING_DEG, thinning
from pfpeople.io.bag.reader import IMAGE_TYPES, LASER_TYPES, ODOMETRY_TYPES, BagMessage, BagSource
from pfpeople.io.bag.tf import TfBuffer, TfLookupError
from pfpeople.pipeline.assembly import grid_for_scan

__all__ = [
    "MIN_LEG_RANGE_M",
    "TF_PRELOAD_S",
    "SensorSetup",
    "SetupSensors",
    "check_grid_seen",
    "scan_bearings",
    "setup_sensors",
    "warn_coarse_lasers",
    "warn_dense_lasers",
]

log = logging.getLogger(__name__)

#: TF on /tf (not static) read before the run to find sensor mounts: the first this many seconds of the bag (a mount
#: first published later is read from further into the bag, :func:`read_tf`).
TF_PRELOAD_S = 1.0
#: LaserScans of a topic looked at for the first one that gives a field of view (:func:`_first_messages`).
FIRST_SCAN_LOOKAHEAD = 100
#: A leg detector should get :data:`~pfpeople.detect.legs.MIN_LEG_BEAMS` returns on a leg out to this range (m):
#: people this near a robot are the least it must see (0.5 deg gives 3.8 m, 1 deg 1.9 m).
MIN_LEG_RANGE_M = 3.0


@dataclass(frozen=True, kw_only=True, eq=False)
class SensorSetup:
    """What is fixed for a run: frames, mounts, the detectors' configurations and the grid.

    Attributes
    ----------
    tf : TfBuffer
        The transforms read before the run.
    grid_frame : str
        The frame the grid is attached to.
    detectors : tuple of DetectorConfig
        The configured detectors, each LaserScan detector with its scan's field of view and range filled in.
    mounts : tuple of Pose2D
        Per detector, its frame's pose in the grid frame (m, rad).
    frame_mounts : dict of str to Pose2D
        Pose in the grid frame of the grid frame, every detector frame and (when TF knows it) the base frame.
    base_to_grid : Pose2D or None
        The grid frame's pose in the base frame (only with an odometry topic).
    spec : GridSpec
        The grid.
    first : dict of str to BagMessage
        The first message of the driver and of each detector topic (topics without messages left out).
    """

    tf: TfBuffer
    grid_frame: str
    detectors: tuple[DetectorConfig, ...]
    mounts: tuple[Pose2D, ...]
    frame_mounts: dict[str, Pose2D]
    base_to_grid: Pose2D | None
    spec: GridSpec
    first: dict[str, BagMessage]


#: The signature of :func:`setup_sensors` (a replacement passed to :class:`pfpeople.pipeline.runner.Pipeline`).
SetupSensors = Callable[..., SensorSetup]


def scan_bearings(msg: Any) -> tuple[float, float]:
    """``(lowest, highest)`` bearing of a LaserScan message (rad), whatever the sign of its increment."""
    a0, a1 = float(msg.angle_min), float(msg.angle_max)
    lo, hi = min(a0, a1), max(a0, a1)
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi - lo <= 0:
        raise ValueError(f"LaserScan angles angle_min={a0!r}, angle_max={a1!r} give no field of view")
    return lo, min(hi, lo + 2 * math.pi)


def with_scan_fov(d: DetectorConfig, msg: Any) -> DetectorConfig:
    """``d`` with the field of view and range of its LaserScan where its ``[detectors.model]`` leaves them out."""
    try:
        lo, hi = scan_bearings(msg)
    except ValueError:
        return d  # the reader reports such scans; the model keeps its own field of view
    m = d.model
    rmax = float(msg.range_max)
    max_range = m.max_range if m.max_range is not None or not (math.isfinite(rmax) and rmax > 0) else rmax
    min_range = m.min_range
    if min_range is not None and min_range >= (math.inf if max_range is None else max_range):
        min_range = None
    fov_min = lo if m.fov_min is None else m.fov_min
    fov_max = hi if m.fov_max is None else m.fov_max
    model = replace(m, fov_min=fov_min, fov_max=fov_max, max_range=max_range, min_range=min_range)
    return replace(d, model=model)


def _usable_scan(m: BagMessage) -> bool:
    """Whether a LaserScan gives a field of view: two or more beams over a span (:func:`scan_bearings`)."""
    try:
        scan_bearings(m.msg)
    except ValueError:
        return False
    return len(m.msg.ranges) >= 2


def _first_messages(bag: BagSource, topics: Sequence[str]) -> dict[str, BagMessage]:
    """The first message of each topic; of a LaserScan topic, the first of :data:`FIRST_SCAN_LOOKAHEAD` that gives a
    field of view (warned: the earlier ones give none).

    Raises
    ------
    ValueError
        For a LaserScan topic none of whose first :data:`FIRST_SCAN_LOOKAHEAD` scans gives a field of view.
    """
    first: dict[str, BagMessage] = {}
    for topic in dict.fromkeys(topics):
        seen: list[BagMessage] = []
        for m in bag.messages([topic]):
            if m.msgtype not in LASER_TYPES or _usable_scan(m):
                first[topic] = m
                break
            seen.append(m)
            if len(seen) == FIRST_SCAN_LOOKAHEAD:
                break
        if seen and topic not in first:
            raise ValueError(
                f"topic {topic!r}: none of its first {len(seen)} LaserScans gives a field of view (the first: "
                f"{len(seen[0].msg.ranges)} beam(s), angle_min={float(seen[0].msg.angle_min)!r}, "
                f"angle_max={float(seen[0].msg.angle_max)!r}); check the laser driver"
            )
        if seen:
            log.warning(
                "topic %s: its first %d scan(s) give no field of view (the first: %d beam(s), angle_min=%r, "
                "angle_max=%r): the field of view, range and grid come from scan %d",
                topic,
                len(seen),
                len(seen[0].msg.ranges),
                float(seen[0].msg.angle_min),
                float(seen[0].msg.angle_max),
                len(seen),
            )
    return first


def read_tf(config: BagConfig, bag: BagSource, needed: Sequence[tuple[str, str]] = ()) -> TfBuffer:
    """TF known before the run: ``/tf_static``, the first transform of each frame in the first
    :data:`TF_PRELOAD_S` s of ``/tf`` (the mount at the start: the run follows it, :mod:`pfpeople.pipeline.mounts`),
    ``[mounts]``.

    A frame of ``needed`` (``(target, source)`` pairs to look up) that these leave unconnected is looked for
    further into ``/tf``: its first transform is used (:func:`_read_late_tf`).
    """
    tf = TfBuffer(fallback_parent=config.base_frame, fallback=config.mounts)
    for topic in (t for t in config.tf_topics if t in bag.topics):
        static = topic.endswith("tf_static")
        for m in bag.messages([topic]):
            if not static and m.bag_time_ns - bag.start_time_ns > TF_PRELOAD_S * 1e9:
                break
            # the first transform of each frame on /tf: the mount at the start (the run follows the later ones)
            tf.add_message(m.msg, topic=topic, new_frames_only=not static)  # a zero quaternion is refused
    if any(not tf.can_transform(t, s) for t, s in needed):
        _read_late_tf(tf, config, bag, needed)
    return tf


def _read_late_tf(tf: TfBuffer, config: BagConfig, bag: BagSource, needed: Sequence[tuple[str, str]]) -> None:
    """Add to ``tf`` the first transform of every frame it lacks, read from ``/tf`` after :data:`TF_PRELOAD_S`,
    until every pair of ``needed`` connects (or the bag ends); warns once naming the frames and when they appear."""
    topics = [t for t in config.tf_topics if t in bag.topics and not t.endswith("tf_static")]
    late: dict[str, float] = {}
    for m in bag.messages(topics):
        if m.bag_time_ns - bag.start_time_ns <= TF_PRELOAD_S * 1e9:
            continue
        before = {f for f in tf.frames if tf.parent_of(f) is not None}  # the frames with TF (children)
        tf.add_message(m.msg, topic=m.topic, new_frames_only=True)
        for child in sorted({f for f in tf.frames if tf.parent_of(f) is not None} - before):
            late.setdefault(f"frame {child!r} (topic {m.topic})", (m.bag_time_ns - bag.start_time_ns) * 1e-9)
        if late and all(tf.can_transform(t, s) for t, s in needed):
            break
    if late:
        log.warning(
            "TF first published after the first %g s of the bag: %s; each such frame's first transform is its mount "
            "from the start of the run",
            TF_PRELOAD_S,
            ", ".join(f"{k} at {v:.1f} s" for k, v in late.items()),
        )


def setup_sensors(
    config: BagConfig,
    bag: BagSource,
    *,
    input_types: Mapping[str, Sequence[str] | None],
    laser_kinds: Collection[str],
) -> SensorSetup:
    """Check the bag's topics and read the run's frames, mounts and grid (see the module docstring).

    Parameters
    ----------
    config : BagConfig
        The run's configuration.
    bag : BagSource
        The input bag.
    input_types : mapping of str to sequence of str or None
        Per detector kind, the message types its topic must carry (None: any).
    laser_kinds : collection of str
        Detector kinds whose input is a LaserScan (their scans give field of view, range and default grid).

    Raises
    ------
    ValueError
        If a mount is missing from TF and ``[mounts]`` (naming the detector), the driver has no frame_id and
        no grid frame is configured, or the default grid is too large for the filter.
    """
    c = config
    bag.require(run_topics(c), types=_required_types(c, input_types))
    first = _first_messages(bag, [c.driver, *(d.topic for d in c.detectors)])
    ids = {t: m.frame_id for t, m in first.items()}
    grid_frame = c.grid_frame or ids.get(c.driver, "")
    if not grid_frame:
        raise ValueError(f"driver topic {c.driver!r} has no frame_id; set [frames] grid_frame in the config")
    tf = read_tf(c, bag, _needed_lookups(c, grid_frame, ids))
    detectors, mounts, frame_mounts = _detector_mounts(c, tf, grid_frame, first, laser_kinds)
    base_to_grid: Pose2D | None = None
    if c.odometry:
        try:
            base_to_grid = tf.lookup(c.base_frame, grid_frame)
        except TfLookupError as exc:
            raise ValueError(f"odometry needs the grid frame's mount on the base frame: {exc}") from None
    if c.base_frame not in frame_mounts:  # so ground truth given in the base frame can be scored
        try:
            frame_mounts[c.base_frame] = tf.lookup(grid_frame, c.base_frame)
        except TfLookupError:
            pass
    spec = c.grid.fixed or _lasers_grid(c, tf, grid_frame, first, laser_kinds)
    return SensorSetup(
        tf=tf,
        grid_frame=grid_frame,
        detectors=tuple(detectors),
        mounts=tuple(mounts),
        frame_mounts=frame_mounts,
        base_to_grid=base_to_grid,
        spec=spec,
        first=first,
    )


def _lasers_grid(
    c: BagConfig, tf: TfBuffer, grid_frame: str, first: Mapping[str, BagMessage], laser_kinds: Collection[str]
) -> GridSpec:
    """The grid of a ``[grid]`` whose extent is (partly) ``"auto"``: the one covering the lasers' fields of view
    (:func:`default_grid`; the driver's and the laser detectors' first scans ``first``) with the given extent fields
    in place, checked against the filter's limits.

    Raises
    ------
    ValueError
        If that grid is too large for the filter (:func:`check_run_limits`).
    """
    lasers = [c.driver, *(d.topic for d in c.detectors if d.kind in laser_kinds)]
    auto = default_grid(tf, grid_frame, first, lasers, resolution=c.grid.resolution, reach=c.grid.max_range)
    spec = c.grid.completed(auto)
    check_run_limits(spec, c.filter, len(c.detectors))
    log.info("grid from the lasers' fields of view: %s", spec)
    return spec


def _required_types(c: BagConfig, input_types: Mapping[str, Sequence[str] | None]) -> dict[str, Sequence[str]]:
    """The message types each run topic must carry: the driver's, each detector kind's, the odometry's."""
    types: dict[str, Sequence[str]] = {c.driver: (*LASER_TYPES, *IMAGE_TYPES)}
    for d in c.detectors:
        kind_types = input_types.get(d.kind)
        if kind_types is not None:
            types[d.topic] = kind_types
    if c.odometry:
        types[c.odometry] = ODOMETRY_TYPES
    return types


def _detector_mounts(
    c: BagConfig, tf: TfBuffer, grid_frame: str, first: Mapping[str, BagMessage], laser_kinds: Collection[str]
) -> tuple[list[DetectorConfig], list[Pose2D], dict[str, Pose2D]]:
    """Each detector (a laser's with its scan's field of view), its mount in the grid frame from TF, and the mounts
    by frame (the grid frame's own included).

    Raises
    ------
    ValueError
        A detector whose frame TF does not connect to the grid frame, naming the detector.
    """
    ids = {t: m.frame_id for t, m in first.items()}
    detectors: list[DetectorConfig] = []
    mounts: list[Pose2D] = []
    frame_mounts: dict[str, Pose2D] = {grid_frame: Pose2D()}
    for d in c.detectors:
        if d.kind in laser_kinds and d.topic in first:
            d = with_scan_fov(d, first[d.topic].msg)
        src = d.frame or ids.get(d.topic, "") or grid_frame
        try:
            mount = tf.lookup(grid_frame, src)
        except TfLookupError as exc:
            raise ValueError(f"detector {d.name!r}: {exc}") from None
        detectors.append(d)
        mounts.append(mount)
        frame_mounts[src] = mount
        how = "[mounts]" if any(link.child == src for link in tf.fallback_links([src])) else "TF"
        log.debug(
            "detector %s (%s on %s, frame %r): at x=%.3f y=%.3f m yaw=%.1f deg in the grid frame %r (%s)",
            d.name, d.kind, d.topic, src, mount.x, mount.y, math.degrees(mount.yaw), grid_frame, how,
        )  # fmt: skip
    return detectors, mounts, frame_mounts


def _needed_lookups(c: BagConfig, grid_frame: str, ids: Mapping[str, str]) -> list[tuple[str, str]]:
    """The ``(target, source)`` look-ups :func:`setup_sensors` makes: each detector's and laser's frame in the grid
    frame, and the grid frame in the base frame (with odometry)."""
    frames = [d.frame or ids.get(d.topic, "") or grid_frame for d in c.detectors] + [ids.get(c.driver, "")]
    out = [(grid_frame, f) for f in dict.fromkeys(frames) if f and f != grid_frame]
    return out + ([(c.base_frame, grid_frame)] if c.odometry else [])


def default_grid(
    tf: TfBuffer,
    grid_frame: str,
    first: Mapping[str, BagMessage],
    lasers: Sequence[str],
    *,
    resolution: float,
    reach: float,
) -> GridSpec:
    """The grid covering every LaserScan topic of ``lasers`` with a first message (each laser's field of view out to
    ``min(range_max, reach)`` by :func:`pfpeople.pipeline.assembly.grid_for_scan` at its mount, at ``resolution``, the
    union of their boxes: several lasers fuse into one grid), or the paper's grid when there is none."""
    topics = [t for t in dict.fromkeys(lasers) if t in first and first[t].msgtype in LASER_TYPES]
    if not topics:
        log.info("no LaserScan to size the grid: the paper's 30 x 30 cells (x0 = 0, y0 = -4.5 m)")
        return GridSpec(resolution=resolution)
    specs = []
    for topic in topics:
        m = first[topic]
        try:
            mount = tf.lookup(grid_frame, m.frame_id or grid_frame)
        except TfLookupError as exc:
            raise ValueError(f"grid from the laser {topic!r}: {exc}") from None
        lo, hi = scan_bearings(m.msg)
        specs.append(grid_for_scan(lo, hi, float(m.msg.range_max), mount=mount, resolution=resolution, reach=reach))
    return _union(specs)


def _union(specs: Sequence[GridSpec]) -> GridSpec:
    """The smallest grid holding every one of ``specs`` (all of one resolution, corners on its lattice)."""
    res = specs[0].resolution
    x0 = min(g.x0 for g in specs)
    y0 = min(g.y0 for g in specs)
    nx = max(round((g.x0 - x0) / res) + g.nx for g in specs)
    ny = max(round((g.y0 - y0) / res) + g.ny for g in specs)
    return GridSpec(nx=nx, ny=ny, resolution=res, x0=x0, y0=y0)


def _grid_text(spec: GridSpec) -> str:
    return (
        f"x {spec.x0:.2f}..{spec.x1:.2f} m, y {spec.y0:.2f}..{spec.y1:.2f} m "
        f"({spec.nx} x {spec.ny} cells of {spec.resolution:g} m)"
    )


def _view_text(model: DetectorModel) -> str:
    return (
        f"{model.name}: bearings {math.degrees(model.fov_min):.0f}..{math.degrees(model.fov_max):.0f} deg, "
        f"range {model.min_range:g}..{model.max_range:g} m, from ({model.mount_x:.2f}, {model.mount_y:.2f}) m "
        f"yaw {math.degrees(model.mount_yaw):.0f} deg"
    )


def check_grid_seen(spec: GridSpec, models: Sequence[DetectorModel], *, configured: bool) -> None:
    """Refuse a grid without a cell (centre) inside any detector's field of view and range.

    Parameters
    ----------
    spec : GridSpec
        The run's grid (grid frame).
    models : sequence of DetectorModel
        The detectors' models, with their mounts in the grid frame.
    configured : bool
        True when the grid is the config's ``[grid]`` (named in the error).

    Raises
    ------
    ValueError
        Naming the grid and every detector's field of view, when no detector sees any of its cells.
    """
    if not models or any(fov_mask(spec, m).any() for m in models):
        return
    where = "[grid]" if configured else "the grid"
    raise ValueError(
        f"{where} ({_grid_text(spec)}) has no cell inside any detector's field of view "
        f"({'; '.join(_view_text(m) for m in models)}; grid frame): the run could only find nobody; move or "
        "enlarge the grid (x0, y0, nx, ny) to overlap them"
        + (", or leave [grid] out to size it from the lasers" if configured else "")
    )


def _leg_params(detector: object) -> LegDetectorParams | None:
    """The leg tests' thresholds of a detector (a ``LegDetector``, or a single-leg detector built on one)."""
    for obj in (detector, getattr(detector, "legs", None)):
        params = getattr(obj, "params", None)
        if isinstance(params, LegDetectorParams):
            return params
    return None


def warn_coarse_lasers(adapters: Sequence[DetectorAdapter], first: Mapping[str, BagMessage]) -> list[str]:
    """Warn once per topic whose beam spacing gives a leg too few returns for a leg detector on it.

    A leg ``far_leg_width`` wide gets fewer than :data:`~pfpeople.detect.legs.MIN_LEG_BEAMS` beams beyond
    :func:`~pfpeople.detect.legs.leg_beam_range`; the warning is given when that range is below
    :data:`MIN_LEG_RANGE_M` and the detector's ``max_range``.

    Parameters
    ----------
    adapters : sequence of DetectorAdapter
        The run's detectors.
    first : mapping of str to BagMessage
        The first message of each topic (the spacing of a topic's first LaserScan is used).

    Returns
    -------
    list of str
        The topics warned about.
    """
    warned: list[str] = []
    for a in adapters:
        topic, params, msg = a.config.topic, _leg_params(a.detector), first.get(a.config.topic)
        if params is None or msg is None or msg.msgtype not in LASER_TYPES or topic in warned:
            continue
        inc = abs(float(msg.msg.angle_increment))
        reach = leg_beam_range(params, inc)
        if not reach < min(MIN_LEG_RANGE_M, a.model.max_range):
            continue
        warned.append(topic)
        log.warning(
            "topic %s: beam spacing %.3g deg is too coarse for the leg detector %s: a leg %.2f m wide gets fewer "
            "than %d returns beyond %.2f m (floor(width / (range * spacing))), so it finds almost nobody farther "
            "than that (far leg blobs start at far_from = %g m); use a laser or driver setting with a finer spacing "
            "(%.3g deg gives %d returns out to %g m)",
            topic,
            math.degrees(inc),
            a.config.name,
            params.far_leg_width or LegDetectorParams().far_leg_width,
            MIN_LEG_BEAMS,
            reach,
            params.far_from,
            math.degrees(inc) * reach / MIN_LEG_RANGE_M,
            MIN_LEG_BEAMS,
            MIN_LEG_RANGE_M,
        )
    return warned


def warn_dense_lasers(adapters: Sequence[DetectorAdapter], first: Mapping[str, BagMessage]) -> list[str]:
    """Warn once per topic whose beam spacing is finer than the laser detectors are built for: its scans reach them
    thinned to every ``k``-th beam (:mod:`pfpeople.detect.spacing`; without it they went blind, unwarned).

    Parameters
    ----------
    adapters : sequence of DetectorAdapter
        The run's detectors (the laser detectors among them: :class:`pfpeople.detect.adapters.LaserAdapter`).
    first : mapping of str to BagMessage
        The first message of each topic (the spacing of a topic's first LaserScan is used).

    Returns
    -------
    list of str
        The topics warned about.
    """
    warned: list[str] = []
    for a in adapters:
        topic, msg = a.config.topic, first.get(a.config.topic)
        if not isinstance(a, LaserAdapter) or msg is None or msg.msgtype not in LASER_TYPES or topic in warned:
            continue
        inc = abs(float(msg.msg.angle_increment))
        k = thinning(inc)
        if k == 1:
            continue
        warned.append(topic)
        names = [b.config.name for b in adapters if isinstance(b, LaserAdapter) and b.config.topic == topic]
        log.warning(
            "topic %s: beam spacing %.3g deg is finer than the laser detectors are built for (%g deg and coarser; "
            "range noise between neighbouring beams blinds their segment features): %s get every %d-th beam "
            "(%.3g deg); the static-clutter map and the saved scans keep every beam",
            topic,
            math.degrees(inc),
            FINEST_SPACING_DEG,
            ", ".join(names),
            k,
            math.degrees(inc) * k,
        )
    return warned
