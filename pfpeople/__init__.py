"""pfpeople: particle-filter fusion of people detectors into a local semantic grid, and what a robot user imports.

The particle filter (:class:`ParticleFilter`, composed of the components of :mod:`pfpeople.particle`: a predictor's
people and ego motion, an updater's likelihood, a resampler; :class:`PeopleSampler`, :class:`EgoSampler` and
:class:`Resampler` say what a component of your own needs) has the same ``step`` as :class:`gridbridge.GridFilter` and
rasterises into the same grid; :func:`recommended` builds the recommended mode's filter, classifier and tracker
(:class:`MultiPersonTracker` inside a :class:`pfpeople.track.reported_people.PeopleTracker`) as ``pfpeople run`` does.
The built-in detectors live in :mod:`pfpeople.detect`, rosbag input/output in :mod:`pfpeople.io.bag`, the paper's blob
tracker in :mod:`pfpeople.track.blob_tracker`.
"""

from pfpeople.particle.filter import ParticleFilter, ParticleStep
from pfpeople.particle.predictor import (
    EgoSampler,
    PaperSampling,
    PeopleSampler,
    PersistentMotion,
    PersistentSampling,
    VelocityEgoSampling,
)
from pfpeople.particle.resampler import RESAMPLERS, Resampler, Resampling
from pfpeople.particle.state import ParticleState
from pfpeople.preset import PeopleFrame, Recommended, recommended
from pfpeople.track.blob_tracker import BlobTracker, TrackerParams, track_sequence
from pfpeople.track.multi_person import MultiPersonTracker, Track, TrackerConfig

__all__ = [
    "RESAMPLERS",
    "BlobTracker",
    "EgoSampler",
    "MultiPersonTracker",
    "PaperSampling",
    "ParticleFilter",
    "ParticleState",
    "ParticleStep",
    "PeopleFrame",
    "PeopleSampler",
    "PersistentMotion",
    "PersistentSampling",
    "Recommended",
    "Resampler",
    "Resampling",
    "Track",
    "TrackerConfig",
    "TrackerParams",
    "VelocityEgoSampling",
    "recommended",
    "track_sequence",
]
