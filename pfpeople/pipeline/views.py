"""Each frame's view of the detectors in the back end: where they were (mounts) and what they covered (fields of view).

The front end places each detector with its frame's TF mount (:mod:`pfpeople.pipeline.mounts`) and gives a laser
detector the field of view its frame's scan covered (:func:`pfpeople.detect.coverage.frame_view`, in
:attr:`pfpeople.detect.adapters.Detections.field_of_view`). :func:`follow_views` gives both to the back end's adapters
and to the filter's detector models before the frame's step (the filter's ``set_detector_mounts`` and
``set_detector_fields_of_view``; a filter from a custom factory without them keeps its models), so a sector a scan did
not cover gets no update. A frame whose scan covered less than the configured field of view is counted per detector
in ``stats.fov_narrowed`` and warned once per detector.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

from pfpeople.detect.adapters import Detections, DetectorAdapter
from pfpeople.pipeline.mounts import remount
from pfpeople.run_state import RunSummary, WarnOnce, count
from pfpeople.sensors import Pose2D

__all__ = ["follow_views", "narrow_views"]


def follow_views(
    adapters: Sequence[DetectorAdapter],
    mounts: Sequence[Pose2D],
    found: Sequence[Detections | None],
    filt: Any,
    summary: RunSummary,
    warn: WarnOnce,
) -> None:
    """Give the back end's ``adapters`` and the filter ``filt`` the frame's ``mounts`` (empty: unchanged) and the
    fields of view of its detections ``found`` (see the module docstring)."""
    if mounts:
        remount(adapters, mounts, filt)
    narrow_views(adapters, found, filt, summary, warn)


def narrow_views(
    adapters: Sequence[DetectorAdapter],
    found: Sequence[Detections | None],
    filt: Any,
    summary: RunSummary,
    warn: WarnOnce,
) -> None:
    """Set each detector's field of view to the one its frame covered (a detector without data keeps its last one),
    counting and warning about narrowed ones, then the filter's."""
    for a, f in zip(adapters, found, strict=True):
        view = None if f is None else f.field_of_view
        if view is None:
            continue
        if (a.model.fov_min, a.model.fov_max) != view:
            a.model = replace(a.model, fov_min=view[0], fov_max=view[1])
        configured = getattr(a, "view", view)
        if view != configured:
            count(summary.fov_narrowed, a.config.name)
            warn(
                f"fov:{a.config.name}",
                "detector %s: a scan of %s covers %.2f .. %.2f deg, less than its field of view %.2f .. %.2f deg: "
                "cells outside what each scan covers get no update in such frames (counted in stats.fov_narrowed)",
                a.config.name,
                a.config.topic,
                *(math.degrees(v) for v in (*view, *configured)),
            )
    set_views = getattr(filt, "set_detector_fields_of_view", None)
    want = [(a.model.fov_min, a.model.fov_max) for a in adapters]
    if set_views is not None and [(d.fov_min, d.fov_max) for d in getattr(filt, "detectors", ())] != want:
        set_views(want)
