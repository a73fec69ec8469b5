"""pfpeople: particle-filter fusion of people detectors into a local semantic grid, and what a robot user imports.

The particle filter (:class:`ParticleFilter`, composed of the components of :mod:`pfpeople.particle`: a predictor's
people and ego motion, an updater's likelihood, a resampler; :class:`PeopleSampler`, :class:`EgoSampler` and
:class:`Resampler` say what a component of your own needs) has the same ``step`` as :class:`gridbridge.GridFilter` and
rasterises into the same grid; :func:`recommended` builds the recommended mode's filter, classifier and tracker
(:class:`MultiPersonTracker` inside a :class:`pfpeople.track.reported_people.PeopleTracker`) as ``pfpeople run`` does.
:func:`run_bag` runs a bag as ``pfpeople run`` does and returns a :class:`Run` (people, tracks, grids, summary);
:class:`PeopleStream` takes a frame's messages as they arrive and returns its people, tracks and grid
(:mod:`pfpeople.pipeline.stream`); :func:`load_run` reads a run directory back. These three are imported on first use.
The built-in detectors live in :mod:`pfpeople.detect`, rosbag input/output in :mod:`pfpeople.io.bag`, the paper's blob
tracker in :mod:`pfpeople.track.blob_tracker`.
"""

from typing import TYPE_CHECKING

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

if TYPE_CHECKING:
    from pfpeople.io.run_dir import load_run
    from pfpeople.pipeline.bag_run import Run, run_bag
    from pfpeople.pipeline.stream import PeopleStream

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
    "PeopleStream",
    "PersistentMotion",
    "PersistentSampling",
    "Recommended",
    "Resampler",
    "Resampling",
    "Run",
    "Track",
    "TrackerConfig",
    "TrackerParams",
    "VelocityEgoSampling",
    "load_run",
    "recommended",
    "run_bag",
    "track_sequence",
]

#: Names imported on first use (they bring the bag readers and the pipeline, which ``import pfpeople`` does not need).
_LAZY = {
    "run_bag": "pfpeople.pipeline.bag_run",
    "Run": "pfpeople.pipeline.bag_run",
    "PeopleStream": "pfpeople.pipeline.stream",
    "load_run": "pfpeople.io.run_dir",
}


def __getattr__(name: str) -> object:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'pfpeople' has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(module), name)
