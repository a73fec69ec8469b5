"""Multi-person tracking on people positions (fused filter output or raw detections): ids, velocities, scores.

See :mod:`pfpeople.mot.tracker` for the model, the assignment and the confirmation/deletion rules, and
:mod:`pfpeople.mot.inputs` for what the pipeline feeds it from the fused belief, and :mod:`pfpeople.mot.people` for
the people a run reports (the classified people the tracker confirms).
"""

from pfpeople.mot.inputs import tracker_inputs
from pfpeople.mot.people import PEOPLE_MODES, PeopleTracker, TrackedFrame
from pfpeople.mot.tracker import TRACK_COLUMNS, MultiPersonTracker, Track, TrackerConfig, track_rows

__all__ = [
    "PEOPLE_MODES",
    "TRACK_COLUMNS",
    "MultiPersonTracker",
    "PeopleTracker",
    "Track",
    "TrackedFrame",
    "TrackerConfig",
    "track_rows",
    "tracker_inputs",
]
