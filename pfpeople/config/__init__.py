"""The configuration of a run: one typed schema, read from TOML (``docs/configuration.md`` is its reference).

A run is configured by a TOML file or the same keys given as a mapping; every table is optional except
``[frames] driver`` and at least one ``[[detectors]]``::

    [frames]
    driver = "/scan"

    [[detectors]]
    name = "laser_legs"
    kind = "leg"
    topic = "/scan"

Each table is a frozen, checked dataclass (:mod:`pfpeople.config.schema`, validated by pydantic): a wrong key or
value is a one-line :class:`ConfigError` naming the table and the key. Every default is a field's own; the paper
mode's differ where :mod:`pfpeople.config.modes` says. ``python -m pfpeople.docs.reference`` writes the reference
page from the schema. Angles are radians, lengths metres, times seconds (REP-103 frames).
"""

from __future__ import annotations

from pfpeople.config.detectors import DETECTOR_KINDS, KINDS, DetectorConfig, DetectorKind, DetectorModelConfig
from pfpeople.config.filtering import FilterConfig
from pfpeople.config.grid import GridConfig
from pfpeople.config.loading import builtin_config_path, config_from_mapping, load_config
from pfpeople.config.modes import MODES, PAPER_DEFAULTS, for_mode
from pfpeople.config.people import ClassifierConfig, TrackingConfig
from pfpeople.config.perception import ClutterSuppression, OutputConfig
from pfpeople.config.run import BagConfig, check_run_limits, run_topics
from pfpeople.config.schema import ConfigError

__all__ = [
    "DETECTOR_KINDS",
    "KINDS",
    "MODES",
    "PAPER_DEFAULTS",
    "BagConfig",
    "ClassifierConfig",
    "ClutterSuppression",
    "ConfigError",
    "DetectorConfig",
    "DetectorKind",
    "DetectorModelConfig",
    "FilterConfig",
    "GridConfig",
    "OutputConfig",
    "TrackingConfig",
    "builtin_config_path",
    "check_run_limits",
    "config_from_mapping",
    "for_mode",
    "load_config",
    "run_topics",
]
