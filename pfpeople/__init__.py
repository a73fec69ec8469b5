"""pfpeople: particle-filter fusion of people detectors into a local semantic grid, and what a robot user imports.

The particle filter (:class:`ParticleFilter`, composed of the components of :mod:`pfpeople.components`) has the
same ``step`` as :class:`gridbridge.GridFilter` and rasterises into the same grid; :func:`recommended` builds
the recommended mode's filter, classifier and tracker (:class:`MultiPersonTracker` inside a
:class:`pfpeople.mot.people.PeopleTracker`) as ``pfpeople run`` does. The built-in detectors live in
:mod:`pfpeople.detectors`, rosbag input/output in :mod:`pfpeople.bag`, the paper's blob tracker in
:mod:`pfpeople.tracking`.
"""

from pfpeople.components import PaperSampling, PersistentSampling, Resampling, VelocityEgoSampling
from pfpeople.mot.tracker import MultiPersonTracker, Track, TrackerConfig
from pfpeople.motion import PersistentMotion
from pfpeople.particle_filter import ParticleFilter, ParticleStep
from pfpeople.particles import ParticleState
from pfpeople.preset import PeopleFrame, Recommended, recommended
from pfpeople.resampling import RESAMPLERS
from pfpeople.tracking import BlobTracker, TrackerParams, track_sequence

__all__ = [
    "RESAMPLERS",
    "BlobTracker",
    "MultiPersonTracker",
    "PaperSampling",
    "ParticleFilter",
    "ParticleState",
    "ParticleStep",
    "PeopleFrame",
    "PersistentMotion",
    "PersistentSampling",
    "Recommended",
    "Resampling",
    "Track",
    "TrackerConfig",
    "TrackerParams",
    "VelocityEgoSampling",
    "recommended",
    "track_sequence",
]
