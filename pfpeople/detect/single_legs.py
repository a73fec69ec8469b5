"""Laser detector "single legs": the legs a leg classifier finds but cannot pair, as a detector of their own.

A person walking towards a laser, or standing side-on, or behind another person, often shows one leg: in the
labelled recordings and the scan-level scenes more than half of the person-frames with a leg candidate have
exactly one. The paired detectors (:class:`~pfpeople.detect.legs.LegDetector`,
:class:`~pfpeople.detect.boosted.BoostedSegmentDetector`) report a person only for a pair (or two legs
together), and counting their single legs as people in the same detector made it a worse detector (its PPV is
then a mix of two very different kinds of detection).

The paper's fusion (eqs. 12-14) takes any number of detectors, each with its own precision (PPV) and
false-negative rate (FNR): a single leg is weak evidence of a person (chair and table legs are single legs too),
and a detector that fires only when one leg shows misses most people, so this detector has a low PPV and a high
FNR, measured on the labelled data (:data:`gridbridge.params.CALIBRATED_LASER_DETECTORS`). The filter then
accumulates its evidence over frames, the static-clutter map suppresses the furniture legs that keep their place,
and a person it finds for long enough is held by the tracker.

Detections: the source classifier's unpaired single legs (:func:`~pfpeople.detect.legs.people_and_single_legs`)
that lie farther than ``exclude_radius`` from a person the source found (a leg beside a paired person is that
person's or furniture beside them, not a second person). They are still the source detector's ``support`` for
the tracker; this detector reports them as people.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from gridbridge.params import CALIBRATED_LASER_DETECTORS, DetectorModel
from gridbridge.validation import check_positive
from pfpeople.detect.boosted import BoostedSegmentDetector
from pfpeople.detect.legs import LegDetector
from pfpeople.perception.clutter_kernels import near_any
from pfpeople.sensors import LaserScan

__all__ = ["SINGLE_LEG_SOURCES", "SingleLegDetector"]

SINGLE_LEG_SOURCES = ("boosted", "leg")


class SingleLegDetector:
    """Unpaired single legs of a leg classifier, reported as people (see the module docstring).

    Parameters
    ----------
    source : {"boosted", "leg"}
        The leg classifier: the boosted segment classifier (default; ``model_path`` as
        :class:`~pfpeople.detect.boosted.BoostedSegmentDetector`) or the geometric leg tests.
    model_path : str or Path, optional
        The boosted model (``source = "boosted"`` only); default the shipped one.
    exclude_radius : float
        Single legs within this distance (m) of a person the source found are not reported.
    model : DetectorModel, optional
        PPV / FNR for the grid; default the measured ``laser_single_legs`` model
        (:data:`gridbridge.params.CALIBRATED_LASER_DETECTORS`).
    """

    def __init__(
        self,
        source: str = "boosted",
        *,
        model_path: str | Path | None = None,
        exclude_radius: float = 0.5,
        model: DetectorModel | None = None,
    ) -> None:
        if source not in SINGLE_LEG_SOURCES:
            raise ValueError(f"source must be one of {SINGLE_LEG_SOURCES}, got {source!r}")
        if model_path is not None and source != "boosted":
            raise ValueError('model_path is for source = "boosted" only')
        self.source = source
        self.exclude_radius = check_positive(exclude_radius, "exclude_radius", allow_zero=True)
        self.legs: BoostedSegmentDetector | LegDetector = (
            BoostedSegmentDetector(model_path) if source == "boosted" else LegDetector()
        )
        self.model = model if model is not None else CALIBRATED_LASER_DETECTORS[2]
        if not isinstance(self.model, DetectorModel):
            raise TypeError(f"model must be a DetectorModel, got {type(self.model).__name__}")

    def detect(self, scan: LaserScan) -> NDArray[np.float64]:
        """Single-leg positions ``(S, 2)`` (m, scan frame) reported as people; ``(0, 2)`` when there are none."""
        return self.detect_with_singles(scan)[0]

    def detect_with_singles(self, scan: LaserScan) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """People ``(S, 2)`` (the single legs away from the source's people) and no support ``(0, 2)``."""
        people, singles = self.legs.detect_with_singles(scan)
        if singles.shape[0] and people.shape[0] and self.exclude_radius > 0:
            singles = singles[~near_any(singles, people, self.exclude_radius)]
        return np.asarray(singles, dtype=float).reshape(-1, 2), np.zeros((0, 2))
