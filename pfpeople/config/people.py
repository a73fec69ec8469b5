"""``[classifier]`` and ``[tracking]``: how the belief becomes people, and people become tracks."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Annotated, Any, ClassVar, Literal

from pydantic import Field, model_validator

from pfpeople.config.schema import CellsF, ConfigError, Count, Flag, Metres, Ratio, Seconds, Table, fill_defaults, table

__all__ = ["KIND_THRESHOLD", "ClassifierConfig", "TrackingConfig", "check_params"]

#: The default ``threshold`` of each classifier kind that has one (chosen on the benchmark: at 0.5 the peaks
#: classifier finds 40 % more false people on negative_2 for 4 % more recall on the ETH/UCY replays).
KIND_THRESHOLD = {"peaks": 0.7, "threshold": 0.5}


@table
class ClassifierConfig(Table):
    """How the belief becomes people (``[classifier]``).

    Parameters
    ----------
    kind : {"peaks", "blobs", "threshold"}
        Local maxima of the belief with non-maximum suppression (:class:`gridbridge.classifiers.PeakClassifier`),
        the paper's blobs, or connected cells above ``threshold``.
    threshold : float
        Peaks: the belief a peak needs to be a person; threshold: the belief of a person's cells. Default by kind:
        0.7 for peaks, 0.5 for threshold (blobs have their own rule).
    min_separation : float
        Peaks: two people are at least this far apart.
    keep : float
        Peaks: hysteresis (:class:`gridbridge.classifiers.HysteresisPeaks`): a person of the previous frame continues
        at a peak within 0.5 m whose belief is above ``min(keep, threshold)``; ``keep >= threshold``: no hysteresis.
    smooth : float
        Peaks: standard deviation of a Gaussian the belief is smoothed with before its maxima are found (0: none;
        at most 10). For the particle filter, whose rasterised mass gives a person several separate cells at the
        bound, 1.0 raises precision on the scan-level scenes (0.79-0.82 to 0.89-0.96) for 0.06-0.07 less recall;
        the grid filter loses by it.
    """

    TABLE: ClassVar[str] = "[classifier]"

    kind: Literal["peaks", "blobs", "threshold"] = "peaks"
    threshold: Ratio = Field(default=KIND_THRESHOLD["peaks"], ge=0.0, le=1.0)
    min_separation: Metres = Field(default=0.6, gt=0.0)
    keep: Ratio = Field(default=0.5, ge=0.0, le=1.0)
    smooth: CellsF = Field(default=0.0, ge=0.0)

    @model_validator(mode="before")
    @classmethod
    def _kind_threshold(cls, data: Any) -> Any:
        def fill(given: dict[str, Any]) -> dict[str, Any]:
            kind = given.get("kind", "peaks")
            if "threshold" not in given and kind in KIND_THRESHOLD:
                given["threshold"] = KIND_THRESHOLD[kind]
            return given

        return fill_defaults(data, fill)

    def check(self) -> None:
        """``smooth`` within :data:`gridbridge.limits.MAX_SMOOTH_CELLS`."""
        from gridbridge.limits import check_smooth

        check_smooth(self.smooth, "[classifier] smooth")


@table
class TrackingConfig(Table):
    """Multi-person tracking of the classified people (``[tracking]``): ``tracks.csv``, the result bag's tracks and
    the people a run reports.

    Parameters
    ----------
    enabled : bool
        Track (``tracks.csv`` and the result bag's tracks); off, every classified person is reported.
    peak_threshold : float or "off"
        With the peaks classifier: the tracker is also fed the belief peaks above this (they carry tracks through a
        dip of the belief) and starts tracks only from the classifier's people (``[tracking.params]
        birth_min_score`` is then the classifier's threshold unless given); ``"off"``: the tracker gets the
        classifier's people only.
    people : {"confirmed", "classified"}
        The people a run reports (``people.csv``, the result bag): ``"confirmed"``, a classified person once a
        confirmed track has them, plus confirmed tracks through up to ``coast_frames`` missed frames;
        ``"classified"``: every classified person.
    coast_frames : int
        See ``people``.
    single_legs : bool
        With ``people = "confirmed"``: the laser detectors' unpaired single legs (static clutter removed) continue
        confirmed tracks that no classified person continued; they never start one.
    snap_radius : float
        People and weaker peaks with laser detections (static clutter removed) within this distance are moved to
        their mean before tracking and reporting; 0: never.
    confirm_evidence : float or "off"
        A tentative track is confirmed once its existence score reaches this (:class:`pfpeople.track.TrackerConfig`
        ``confirm_evidence``: the evidence of its hits, each weighed by the belief at the person, which carries the
        detectors' PPV and a scored detector's PPV of its score); ``"off"``: M of N (``[tracking.params]``
        ``confirm_hits`` of ``confirm_window``). ``[tracking.params] confirm_evidence`` takes precedence.
    static_confirm_s : float
        With ``people = "confirmed"``: a track that has not moved 0.3 m from where it started is reported only from
        this age on; a walker as soon as it is confirmed. 0: any confirmed track.
    observed_tracks_only : bool
        ``tracks.csv`` and the result bag leave out a confirmed track without a hit in this frame while its
        predicted position lies in no cell a detector observes (it lives on and keeps its id).
    see_through : bool
        A track without a hit in this frame is left out of the tracks and the people where a laser sees through its
        predicted position (every beam within 0.5 m of it returns 0.5 m or more behind it).
    params : table
        ``[tracking.params]``: fields of :class:`pfpeople.track.TrackerConfig` (its own table in this reference).
    """

    TABLE: ClassVar[str] = "[tracking]"

    enabled: Flag = True
    peak_threshold: Annotated[Ratio, Field(ge=0.0, lt=1.0)] | Literal["off"] = 0.5
    people: Literal["confirmed", "classified"] = "confirmed"
    coast_frames: Count = Field(default=1, ge=0)
    single_legs: Flag = True
    snap_radius: Metres = Field(default=0.3, ge=0.0)
    confirm_evidence: Annotated[Ratio, Field(gt=0.0, lt=1.0)] | Literal["off"] = 0.6
    static_confirm_s: Seconds = Field(default=1.0, ge=0.0)
    observed_tracks_only: Flag = True
    see_through: Flag = True
    params: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    @model_validator(mode="before")
    @classmethod
    def _none_is_off(cls, data: Any) -> Any:
        """``peak_threshold=None`` (the library's earlier spelling) is ``"off"``."""

        def fill(given: dict[str, Any]) -> dict[str, Any]:
            if "peak_threshold" in given and given["peak_threshold"] is None:
                given["peak_threshold"] = "off"
            return given

        return fill_defaults(data, fill)

    @property
    def peaks_above(self) -> float | None:
        """The belief above which peaks are fed to the tracker, or None (``peak_threshold = "off"``)."""
        return None if self.peak_threshold == "off" else float(self.peak_threshold)

    def check(self) -> None:
        """``params`` must build a :class:`pfpeople.track.TrackerConfig`."""
        from pfpeople.track.multi_person import TrackerConfig

        check_params(TrackerConfig, self.params, "[tracking.params]")


def check_params(cls: type, params: Mapping[str, Any], where: str) -> Any:
    """``cls(**params)`` (a dataclass of a ``params`` table), its errors as one :class:`ConfigError` naming
    ``where``."""
    if not isinstance(params, Mapping):
        raise ConfigError(f"{where} must be a table, got {params!r}")
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(params) - names)
    if unknown:
        raise ConfigError(f"{where} {unknown[0]}: unknown key; allowed: {sorted(names)}")
    try:
        return cls(**params)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"{where}: {exc}") from None
