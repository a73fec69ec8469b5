"""The whole configuration of a bag run (:class:`BagConfig`): topics, frames, synchronisation and every table."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Annotated, Any, ClassVar, Literal

from pydantic import Field, field_validator, model_validator

from gridbridge.grid import GridSpec
from gridbridge.limits import check_grid_size, check_memory, check_motion_step
from gridbridge.params import PeopleMotion
from pfpeople.config.detectors import DetectorConfig, DetectorModelConfig
from pfpeople.config.filtering import FilterConfig
from pfpeople.config.grid import GridConfig
from pfpeople.config.modes import for_mode, mode_of
from pfpeople.config.people import ClassifierConfig, TrackingConfig
from pfpeople.config.perception import ClutterSuppression, OutputConfig
from pfpeople.config.schema import ConfigError, Count, Metres, Radians, Seconds, Table, Text, fill_defaults, table

__all__ = ["FRAMES_KEYS", "BagConfig", "check_run_limits", "run_topics"]

#: The keys of ``[frames]`` (fields of :class:`BagConfig` of the same names).
FRAMES_KEYS = ("driver", "grid_frame", "base_frame", "time_source", "sync_tolerance_s", "max_pending_frames")
#: Where the other fields of :class:`BagConfig` are in a TOML file.
_TOML_KEY = {"odometry": "[odometry] topic", "tf_topics": "[tf] topics", "mounts": "[mounts]"}
#: The tables whose defaults follow ``[filter] mode`` (:mod:`pfpeople.config.modes`).
_MODE_TABLES = {"classifier": "classifier", "tracking": "tracking", "clutter": "clutter"}

Mount = tuple[Metres, Metres, Radians]


@table
class BagConfig(Table):
    """Everything a bag run needs besides the bag (``docs/configuration.md``; the TOML keys in brackets).

    Parameters
    ----------
    driver : str
        ``[frames] driver``: the topic whose messages make the frames (one frame per message).
    detectors : tuple of DetectorConfig
        ``[[detectors]]``: the detectors, in the order the filter sees them (at least one).
    grid_frame : str
        ``[frames] grid_frame``: the frame the grid is attached to; ``""``: the driver's header frame_id.
    base_frame : str
        ``[frames] base_frame``: the robot's body frame (odometry moves it; ``[mounts]`` are given in it).
    time_source : {"header", "bag"}
        ``[frames] time_source``: the stamps the messages are synchronised on: header stamps (record times for
        messages without a header) or record times.
    sync_tolerance_s : float
        ``[frames] sync_tolerance_s``: a message further than this from the frame's stamp is not used for it.
    max_pending_frames : int
        ``[frames] max_pending_frames``: frames kept waiting for late messages before they are finalised anyway (a
        memory bound).
    odometry : str
        ``[odometry] topic``: the ``nav_msgs/Odometry`` topic; ``""``: none (scan matching, or the robot taken as
        standing).
    tf_topics : tuple of str
        ``[tf] topics``: the TF topics read when the bag has them.
    mounts : table
        ``[mounts]``: ``frame = [x, y, yaw]`` (m, m, rad) in ``base_frame``: static mounts of frames the bag's TF does
        not give.
    grid : GridConfig
        ``[grid]``.
    filter : FilterConfig
        ``[filter]``.
    classifier : ClassifierConfig
        ``[classifier]``.
    tracking : TrackingConfig
        ``[tracking]``.
    clutter : ClutterSuppression
        ``[clutter]``.
    output : OutputConfig
        ``[output]``.
    """

    TABLE: ClassVar[str] = "[frames]"

    driver: Annotated[Text, Field(min_length=1)]
    detectors: Annotated[tuple[DetectorConfig, ...], Field(min_length=1)]
    grid_frame: Text = ""
    base_frame: Annotated[Text, Field(min_length=1)] = "base_link"
    time_source: Literal["header", "bag"] = "header"
    sync_tolerance_s: Seconds = Field(default=0.05, ge=0.0)
    max_pending_frames: Count = Field(default=20, ge=1)
    odometry: Text = ""
    tf_topics: tuple[Annotated[Text, Field(min_length=1)], ...] = ("/tf_static", "/tf")
    mounts: Mapping[str, Mount] = dataclasses.field(default_factory=dict)
    grid: GridConfig = dataclasses.field(default_factory=GridConfig)
    filter: FilterConfig = dataclasses.field(default_factory=FilterConfig)
    classifier: ClassifierConfig = dataclasses.field(default_factory=ClassifierConfig)
    tracking: TrackingConfig = dataclasses.field(default_factory=TrackingConfig)
    clutter: ClutterSuppression = dataclasses.field(default_factory=ClutterSuppression)
    output: OutputConfig = dataclasses.field(default_factory=OutputConfig)

    @field_validator("mounts", mode="before")
    @classmethod
    def _mounts(cls, value: Any) -> Any:
        """Each mount three finite numbers (a one-line error naming the frame and the number otherwise)."""
        if not isinstance(value, Mapping):
            return value
        for frame, mount in value.items():
            if isinstance(mount, str | bytes) or not isinstance(mount, Sequence) or len(mount) != 3:
                raise ValueError(f"{frame!r} must be three numbers [x, y, yaw] (m, m, rad), got {mount!r}")
            for v, axis in zip(mount, ("x", "y", "yaw"), strict=True):
                if isinstance(v, bool) or not isinstance(v, int | float):
                    raise ValueError(f"{frame!r} {axis} must be a number, got {type(v).__name__}")
                if not math.isfinite(v):
                    raise ValueError(f"{frame!r} {axis} must be finite, got {v!r}")
        return value

    @classmethod
    def label(cls, name: str) -> str:
        """Where field ``name`` is in a TOML file (``"[frames] driver"``, ``"[odometry] topic"``)."""
        return _TOML_KEY.get(name, f"[frames] {name}")

    @model_validator(mode="before")
    @classmethod
    def _defaults(cls, data: Any) -> Any:
        """The grid as a :class:`GridConfig` (a ``GridSpec`` is a fixed grid; None: from the lasers), and the tables
        whose defaults follow ``[filter] mode`` completed with the mode's."""

        def fill(given: dict[str, Any]) -> dict[str, Any]:
            grid = given.get("grid")
            if grid is None:
                given.pop("grid", None)
            elif isinstance(grid, GridSpec):
                given["grid"] = GridConfig.of(grid)
            mode = mode_of(given.get("filter"))
            for key, name in _MODE_TABLES.items():
                value = given.get(key, {})
                if isinstance(value, Mapping):
                    given[key] = for_mode(mode, name, value)
            return given

        return fill_defaults(data, fill)

    def check(self) -> None:
        """Unique detector names; the resource limits the configuration already decides."""
        names = [d.name for d in self.detectors]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ConfigError(
                f"[[detectors]] name: names must be unique, {twice[0]!r} is given {names.count(twice[0])} times"
            )
        check_config_limits(self.grid, self.filter, len(self.detectors))

    @property
    def sync_tolerance_ns(self) -> int:
        return round(self.sync_tolerance_s * 1e9)

    def to_dict(self) -> dict[str, Any]:
        """A JSON/TOML-able mapping of every field that :func:`pfpeople.config.config_from_mapping` turns back into
        this config (the defaults written out)."""
        return {
            "frames": {k: getattr(self, k) for k in FRAMES_KEYS},
            "odometry": {"topic": self.odometry},
            "tf": {"topics": list(self.tf_topics)},
            "mounts": {k: list(v) for k, v in self.mounts.items()},
            "grid": _plain(self.grid),
            "filter": _plain(self.filter),
            "classifier": _plain(self.classifier),
            "tracking": _plain(self.tracking),
            "clutter": _plain(self.clutter),
            "output": _plain(self.output),
            "detectors": [_plain(d) for d in self.detectors],
        }


def _plain(obj: Any) -> Any:
    """A table as TOML-able values: tables and mappings as dicts, tuples as lists, a model as its given fields."""
    if isinstance(obj, DetectorModelConfig):
        return obj.given()
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: _plain(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, Mapping):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_plain(v) for v in obj]
    return obj


def check_config_limits(grid: GridConfig, filt: FilterConfig, n_detectors: int) -> None:
    """The resource limits (:func:`check_run_limits`) as far as the configuration decides them: all of them for a
    fully given grid; else the motion neighbourhood of the resolution, the cells of a given ``nx`` and ``ny``, and a
    given particle count (checked again on the run's grid)."""
    spec = grid.fixed
    if spec is not None:
        check_run_limits(spec, filt, n_detectors)
        return
    motion = PeopleMotion()
    check_motion_step(1, grid.resolution, v_max=motion.v_max, dt=0.1, where="[grid]")
    cells = 1
    if grid.nx != "auto" and grid.ny != "auto":
        check_grid_size(grid.nx, grid.ny, grid.resolution, v_max=motion.v_max, dt=0.1, where="[grid]")
        cells = grid.nx * grid.ny
    if filt.kind == "particle" and filt.n_particles != "auto":
        from pfpeople.particle.limits import check_particles

        check_particles(filt.n_particles, n_cells=cells, n_detectors=n_detectors, where="[filter] n_particles")


def check_run_limits(g: GridSpec, filt: FilterConfig, n_detectors: int) -> None:
    """Resource limits before anything is allocated (:mod:`gridbridge.limits`, :mod:`pfpeople.particle.limits`):
    cells, prediction work, particles, memory."""
    from pfpeople.particle.limits import check_particles

    check_grid_size(g.nx, g.ny, g.resolution, v_max=PeopleMotion().v_max, dt=0.1, where="[grid]")
    if filt.kind == "particle":
        check_particles(
            filt.particles_for(g.n_cells), n_cells=g.n_cells, n_detectors=n_detectors, where="[filter] n_particles"
        )
    else:
        check_memory(g.n_cells, n_detectors=n_detectors, where="[grid]")


def run_topics(config: BagConfig) -> list[str]:
    """The topics a run reads: driver, detector topics and odometry (sorted)."""
    topics = {config.driver, *(d.topic for d in config.detectors)}
    if config.odometry:
        topics.add(config.odometry)
    return sorted(topics)
