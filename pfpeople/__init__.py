"""pfpeople: particle-filter fusion of people detectors into a local semantic grid, and what a robot user imports.

The particle filter (:class:`ParticleFilter`) has the same ``step`` as :class:`gridbridge.GridFilter` and
rasterises into the same grid; the built-in detectors live in :mod:`pfpeople.detectors`, rosbag input/output in
:mod:`pfpeople.bag`, the tracking application in :mod:`pfpeople.tracking`.
"""

from pfpeople.motion import PersistentMotion
from pfpeople.particle_filter import ParticleFilter, ParticleStep
from pfpeople.particles import ParticleState
from pfpeople.resampling import RESAMPLERS
from pfpeople.tracking import BlobTracker, TrackerParams, track_sequence

__all__ = [
    "RESAMPLERS",
    "BlobTracker",
    "ParticleFilter",
    "ParticleState",
    "ParticleStep",
    "PersistentMotion",
    "TrackerParams",
    "track_sequence",
]
