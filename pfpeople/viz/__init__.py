"""Pictures of runs: animation frames and summary pages (matplotlib, Agg canvas; no pyplot state).

See :mod:`pfpeople.viz.run_view` for what is drawn, :mod:`pfpeople.viz.summary` for the summary page and
:mod:`pfpeople.viz.video` for the encoding.
"""

from pfpeople.viz.run_view import RunFrameRenderer, ViewOptions, read_tracks, robot_path
from pfpeople.viz.summary import render_summary
from pfpeople.viz.video import write_animation

__all__ = ["RunFrameRenderer", "ViewOptions", "read_tracks", "render_summary", "robot_path", "write_animation"]
