"""Multi-person tracking on people positions (fused filter output or raw detections): ids, velocities, scores.

See :mod:`pfpeople.mot.tracker` for the model, the assignment and the confirmation/deletion rules, and
:mod:`pfpeople.mot.inputs` for what the pipeline feeds it from the fused belief.
"""

from pfpeople.mot.inputs import tracker_inputs
from pfpeople.mot.tracker import TRACK_COLUMNS, MultiPersonTracker, Track, TrackerConfig, track_rows

__all__ = ["TRACK_COLUMNS", "MultiPersonTracker", "Track", "TrackerConfig", "track_rows", "tracker_inputs"]
