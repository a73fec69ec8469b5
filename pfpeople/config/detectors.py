"""``[[detectors]]`` with its ``[detectors.model]``: the detectors of a run, their kinds and their typed models.

A detector kind is one entry of :data:`KINDS` (what its configuration needs; the adapter that runs it is
registered in :data:`pfpeople.detect.adapters.ADAPTERS` under the same name, and its ``[detectors.params]`` are
the keyword arguments of that adapter's detector class, checked against their annotations when the run builds the
detector, :mod:`pfpeople.detect.settings`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Annotated, Any, ClassVar, Literal

from pydantic import AllowInfNan, Field, field_validator, model_validator

from gridbridge.geometry import Pose2D
from gridbridge.params import DetectorModel
from pfpeople.config.schema import ConfigError, Flag, Metres, Radians, Ratio, Table, Text, fill_defaults, table
from pfpeople.units import Unit

__all__ = ["DETECTOR_KINDS", "KINDS", "DetectorConfig", "DetectorKind", "DetectorModelConfig"]


@dataclass(frozen=True, kw_only=True)
class DetectorKind:
    """What the configuration of one detector kind needs.

    Parameters
    ----------
    input : str
        The kind of input message (for the reference): ``"LaserScan"``, ``"Image"``, ``"detections"``.
    hold_arrivals : bool
        The default of ``[[detectors]] hold_arrivals`` for the kind.
    model_requires : tuple of str
        ``[detectors.model]`` fields a detector of the kind must give (a kind without a built-in model).
    """

    input: str
    hold_arrivals: bool = False
    model_requires: tuple[str, ...] = ()


#: The detector kinds (the built-in detectors, and detections read from a topic). ``hold_arrivals``: on for the
#: boosted detector, the only built-in one at least as precise as the fused output must be (PPV 0.92, the precision
#: target 0.9), so one arrival's evidence may be trusted for 2 s.
KINDS: dict[str, DetectorKind] = {
    "leg": DetectorKind(input="LaserScan"),
    "boosted": DetectorKind(input="LaserScan", hold_arrivals=True),
    "single-legs": DetectorKind(input="LaserScan"),
    "learned": DetectorKind(input="LaserScan"),
    "motion": DetectorKind(input="LaserScan"),
    "hog": DetectorKind(input="Image"),
    "topic": DetectorKind(input="detections", model_requires=("ppv", "fnr")),
}
#: The detector kinds' names.
DETECTOR_KINDS = tuple(KINDS)

_Range = Annotated[float, Unit("m"), AllowInfNan(True), Field(gt=0.0)]
_MOUNT_FIELDS = ("mount_x", "mount_y", "mount_yaw")


@table
class DetectorModelConfig(Table):
    """The detector's model in the filter (``[detectors.model]``, :class:`gridbridge.params.DetectorModel`): each field
    given replaces the detector's own; a field left out keeps it (the kind's calibrated PPV and FNR, a laser
    detector's field of view and range from its scans, the mount from TF or ``[mounts]``).

    Parameters
    ----------
    ppv : float
        Precision: P(D | person) in a cell where the detector fires, in (0, 1).
    fnr : float
        False-negative rate: P(D | person) in a covered cell where it does not fire, in (0, 1).
    fov_min, fov_max : float
        Bearing range of the field of view (counter-clockwise from the detector's x axis).
    max_range : float
        Largest range at which the detector sees people (``inf``: unbounded).
    min_range : float
        Smallest range at which it sees people.
    mount_x, mount_y, mount_yaw : float
        The detector's pose in the grid frame (instead of TF's).
    uncertainty : {"point", "gaussian"}
        A detection marks its cell and the cells within ``footprint_radius`` (``"point"``), or a Gaussian of
        ``sigma_lateral`` / ``sigma_range`` along its bearing (``"gaussian"``).
    footprint_radius : float
        Radius around a point detection whose cell centres are marked too.
    sigma_lateral, sigma_range : float
        Standard deviations of a ``"gaussian"`` detection across and along the line of sight.
    """

    TABLE: ClassVar[str] = "[detectors.model]"

    ppv: Annotated[Ratio, Field(gt=0.0, lt=1.0)] | None = None
    fnr: Annotated[Ratio, Field(gt=0.0, lt=1.0)] | None = None
    fov_min: Radians | None = None
    fov_max: Radians | None = None
    max_range: _Range | None = None
    min_range: Annotated[Metres, Field(ge=0.0)] | None = None
    mount_x: Metres | None = None
    mount_y: Metres | None = None
    mount_yaw: Radians | None = None
    uncertainty: Literal["point", "gaussian"] | None = None
    footprint_radius: Annotated[Metres, Field(ge=0.0)] | None = None
    sigma_lateral: Annotated[Metres, Field(gt=0.0)] | None = None
    sigma_range: Annotated[Metres, Field(gt=0.0)] | None = None

    @field_validator("max_range")
    @classmethod
    def _not_nan(cls, value: float | None) -> float | None:
        if value is not None and math.isnan(value):
            raise ValueError("must be a number, got nan")
        return value

    def given(self) -> dict[str, Any]:
        """The fields given (``{name: value}``), in field order."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if getattr(self, f.name) is not None}

    @property
    def gives_mount(self) -> bool:
        """Whether the model gives the detector's mount (``mount_x``, ``mount_y`` or ``mount_yaw``)."""
        return any(getattr(self, k) is not None for k in _MOUNT_FIELDS)

    def applied(self, base: DetectorModel | None, *, name: str, mount: Pose2D) -> DetectorModel:
        """``base`` (a new :class:`DetectorModel` when None) with the given fields, named ``name`` and mounted at
        ``mount`` where the model does not give the mount."""
        over: dict[str, Any] = {"mount_x": mount.x, "mount_y": mount.y, "mount_yaw": mount.yaw, **self.given()}
        over["name"] = name
        return DetectorModel(**over) if base is None else dataclasses.replace(base, **over)


@table
class DetectorConfig(Table):
    """One detector of a run (``[[detectors]]``).

    Parameters
    ----------
    name : str
        Unique name (outputs, result-bag topics: a valid ROS name such as ``laser_legs``).
    kind : str
        ``"leg"``, ``"boosted"``, ``"single-legs"`` (laser detectors), ``"hog"`` (camera) or ``"topic"``
        (positions read from the bag: ``geometry_msgs/PoseArray`` or any message with a pose / poses field).
    topic : str
        Its input topic: a LaserScan for the laser detectors, a (compressed) image for hog, detections for topic.
    frame : str
        Frame of its output when the message has no header; ``""``: the message's frame_id (or the grid frame).
    assign : {"nearest", "preceding"}
        ``"nearest"``: the message nearest the frame's stamp (within ``sync_tolerance_s``); ``"preceding"``: all
        messages from this frame's stamp to the next frame's (a frame without one: nobody was seen).
    hold_arrivals : bool
        Laser detectors with static-clutter suppression: a detection that arrived (the laser saw through the place a
        moment earlier) keeps its place for 2 s, its static detections within 0.3 m counting as arrived too. Default
        by kind: on for ``boosted`` (PPV 0.92, at least the precision the fused output must reach), off for the
        others.
    model : table
        ``[detectors.model]`` (its own table in this reference). A ``topic`` detector must give ``ppv`` and ``fnr``.
    params : table
        ``[detectors.params]``: the keyword arguments of the kind's detector class (its own tables in this
        reference).
    """

    TABLE: ClassVar[str] = "[[detectors]]"

    name: Annotated[Text, Field(min_length=1)]
    kind: Text
    topic: Annotated[Text, Field(min_length=1)]
    frame: Text = ""
    assign: Literal["nearest", "preceding"] = "nearest"
    hold_arrivals: Flag = False
    model: DetectorModelConfig = dataclasses.field(default_factory=DetectorModelConfig)
    params: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    @model_validator(mode="before")
    @classmethod
    def _kind_defaults(cls, data: Any) -> Any:
        def fill(given: dict[str, Any]) -> dict[str, Any]:
            kind = KINDS.get(given.get("kind"))  # type: ignore[arg-type]
            if kind is not None:
                given.setdefault("hold_arrivals", kind.hold_arrivals)
            return given

        return fill_defaults(data, fill)

    @field_validator("kind")
    @classmethod
    def _known_kind(cls, value: str) -> str:
        if value not in KINDS:
            raise ValueError(f"must be one of {list(KINDS)}, got {value!r}")
        return value

    def check(self) -> None:
        """The model fields the kind requires."""
        missing = [k for k in KINDS[self.kind].model_requires if getattr(self.model, k) is None]
        if missing:
            raise ConfigError(
                f"[[detectors]] {self.name!r}: a {self.kind!r} detector must give {', '.join(missing)} in "
                "[detectors.model]"
            )
