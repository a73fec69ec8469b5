"""Multi-person tracking on people positions (fused filter output or raw detections): ids, velocities, scores.

See :mod:`pfpeople.track.multi_person` for the model, the assignment and the confirmation/deletion rules, and
:mod:`pfpeople.track.belief_inputs` for what the pipeline feeds it from the fused belief, and
:mod:`pfpeople.track.reported_people` for
the people a run reports (the classified people the tracker confirms).
"""

from pfpeople.track.belief_inputs import tracker_inputs
from pfpeople.track.multi_person import TRACK_COLUMNS, MultiPersonTracker, Track, TrackerConfig, track_rows
from pfpeople.track.reported_people import PEOPLE_MODES, PeopleTracker, TrackedFrame

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
