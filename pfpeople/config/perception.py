"""``[clutter]`` and ``[output]``: static-clutter suppression and laser odometry; the frame of the results."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any, ClassVar

from pfpeople.config.people import check_params
from pfpeople.config.schema import ConfigError, Flag, Table, Text, table

__all__ = ["ClutterSuppression", "OutputConfig"]


@table
class ClutterSuppression(Table):
    """Static-clutter suppression and laser odometry (``[clutter]``, :mod:`pfpeople.perception.clutter_map`).

    Parameters
    ----------
    enabled : bool
        Drop laser detections on places that have been occupied for a long time (chair and table legs, posts),
        unless they arrived there (the laser saw through the place a moment earlier); the detectors with
        ``hold_arrivals`` keep an arrival's place for 2 s.
    laser_odometry : bool
        Without an odometry topic, move the grid with the driving laser's scan matching (where it succeeds).
    params : table
        ``[clutter.params]``: fields of :class:`pfpeople.perception.clutter_map.ClutterConfig` (its own table in this
        reference).
    """

    TABLE: ClassVar[str] = "[clutter]"

    enabled: Flag = True
    laser_odometry: Flag = True
    params: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    def check(self) -> None:
        """``params`` must build a :class:`pfpeople.perception.clutter_map.ClutterConfig`."""
        from pfpeople.perception.clutter_map import ClutterConfig

        check_params(ClutterConfig, self.params, "[clutter.params]")


@table
class OutputConfig(Table):
    """Where a run's results are given besides the grid frame (``[output]``).

    Parameters
    ----------
    frame : str
        The frame of the people, tracks and markers a run writes (``people.csv`` and ``tracks.csv`` ``out_*``
        columns, the result bag, the node's topics): the odometry's frame or any frame TF connects to the grid
        frame, e.g. ``"odom"``; ``""``: the grid frame only. The grid stays in the grid frame.
    """

    TABLE: ClassVar[str] = "[output]"

    frame: Text = ""

    def check(self) -> None:
        """A TF frame id has no leading ``/``."""
        if self.frame.startswith("/"):
            raise ConfigError(f"[output] frame: a TF frame id has no leading '/', got {self.frame!r}")
