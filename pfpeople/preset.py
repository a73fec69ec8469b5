"""The recommended mode for a library user: filter, classifier and tracker in one object, as ``pfpeople run``
builds them.

::

    import numpy as np
    import pfpeople

    people = pfpeople.recommended()  # the grid filter on the built-in laser detectors; kind="particle" for particles
    for _ in range(10):
        frame = people.step([np.array([[3.0, 0.45]]), np.zeros((0, 2)), np.zeros((0, 2))], dt=0.1)
    frame.people.positions, [t.id for t in frame.tracks]

Each ``step`` runs the filter (eqs. 1-14 with the recommended mode's components, :mod:`pfpeople.pipeline.assembly`), the
peak classifier with hysteresis and the multi-person tracker (:class:`pfpeople.track.reported_people.PeopleTracker`),
the same three stages as a run's back end. Positions are in the grid's sensor frame (m, REP-103).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from gridbridge.classifiers import Classifier, HysteresisPeaks, People, classify_frame
from gridbridge.ego_motion import Odometry, odometry_pose
from gridbridge.filter import GridFilter
from gridbridge.grid import GridSpec
from gridbridge.params import CALIBRATED_LASER_DETECTORS, DetectorModel
from pfpeople.config import ClassifierConfig, FilterConfig, TrackingConfig
from pfpeople.particle.filter import ParticleFilter
from pfpeople.pipeline.assembly import build_classifier, build_filter, build_people_tracker
from pfpeople.track.multi_person import Track
from pfpeople.track.reported_people import PeopleTracker

__all__ = ["PeopleFrame", "Recommended", "recommended"]


@dataclass(frozen=True, eq=False)
class PeopleFrame:
    """One :meth:`Recommended.step`.

    Attributes
    ----------
    belief : ndarray, shape (nx, ny)
        The posterior: the probability of a person in each cell.
    people : People
        The reported people (positions (P, 2) in m, grid frame): the tracker-confirmed ones.
    tracks : list of Track
        The confirmed tracks, each with an id, a position (m) and a velocity (m/s).
    """

    belief: NDArray[np.float64]
    people: People
    tracks: list[Track]


@dataclass(eq=False)
class Recommended:
    """The recommended filter, classifier and tracker on one grid (see the module docstring).

    Attributes
    ----------
    spec : GridSpec
        The grid.
    filter : GridFilter or ParticleFilter
        The filter (its ``detectors`` set the order of :meth:`step`'s detections).
    classifier : Classifier or HysteresisPeaks
        The belief's people, per frame.
    tracker : PeopleTracker
        Tracks of the classified people; reports the confirmed ones.
    """

    spec: GridSpec
    filter: GridFilter | ParticleFilter
    classifier: Classifier | HysteresisPeaks
    tracker: PeopleTracker

    def step(
        self, detections: Sequence[ArrayLike | None], odometry: Odometry | None = None, dt: float = 0.1
    ) -> PeopleFrame:
        """One frame: filter, classifier, tracker.

        Parameters
        ----------
        detections : sequence, one entry per detector model of ``filter``
            Entry i: an ``(M_i, 2)`` array of person positions (m, grid frame), or None when detector i has no
            data this frame.
        odometry : Odometry, optional
            The robot's motion over ``dt`` (m/s, rad/s); None: standing still.
        dt : float
            Seconds since the previous frame (> 0).

        Returns
        -------
        PeopleFrame
        """
        out = self.filter.step(detections, odometry, dt)
        belief = np.asarray(out.posterior, dtype=float)
        observed = np.asarray(out.covered).any(axis=0)
        ego = odometry_pose(odometry, dt)
        found = classify_frame(self.classifier, belief, self.spec, observed=observed, ego=ego)
        tracked = self.tracker.step(found, belief, self.spec, dt, observed=observed, ego=ego)
        return PeopleFrame(belief=belief, people=tracked.people, tracks=tracked.tracks)

    def reset(self) -> None:
        """Start again: the filter's belief, the classifier's memory and every track."""
        self.filter.reset()
        if hasattr(self.classifier, "reset"):
            self.classifier.reset()
        self.tracker.reset()


def recommended(
    spec: GridSpec | None = None,
    detectors: Sequence[DetectorModel] | None = None,
    *,
    kind: Literal["grid", "particle"] = "grid",
    seed: int = 0,
) -> Recommended:
    """The recommended mode's filter, classifier and tracker, as ``pfpeople run`` builds them.

    Parameters
    ----------
    spec : GridSpec, optional
        The grid (default: 30 x 30 cells of 0.3 m, the sensor at the middle of the x = 0 edge).
    detectors : sequence of DetectorModel, optional
        The detectors, in the order of :meth:`Recommended.step`'s detections (default: the built-in laser
        detectors with their measured PPV / FNR, :data:`gridbridge.params.CALIBRATED_LASER_DETECTORS`: laser_legs,
        laser_boosted, laser_single_legs).
    kind : {"grid", "particle"}
        The grid filter or the particle filter.
    seed : int
        The particle filter's random seed (the grid filter draws nothing).

    Returns
    -------
    Recommended

    Raises
    ------
    ValueError
        An unknown ``kind``, or detectors the filter refuses.
    """
    spec = GridSpec() if spec is None else spec
    models = tuple(CALIBRATED_LASER_DETECTORS if detectors is None else detectors)
    flt = build_filter(FilterConfig(kind=kind, seed=seed), spec, models)
    classifier = build_classifier(ClassifierConfig())
    tracker = build_people_tracker(TrackingConfig(), classifier)
    assert tracker is not None  # tracking is on by default
    return Recommended(spec=spec, filter=flt, classifier=classifier, tracker=tracker)
