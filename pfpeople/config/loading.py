"""Reading a run configuration: a TOML file or its parsed mapping to a :class:`~pfpeople.config.run.BagConfig`.

The tables map onto the schema (:mod:`pfpeople.config`); what earlier versions wrote still loads with the same
result: the former default detector names (``laser-legs``, ``laser-boosted:rear_scan``: read as today's, with one
warning) and a ``[detectors.model] name`` equal to the detector's (the schema has no such field: a detector's model
is named after the detector).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from gridbridge.params import current_detector_name
from pfpeople.config.run import FRAMES_KEYS, BagConfig
from pfpeople.config.schema import ConfigError

__all__ = ["TABLES", "builtin_config_path", "config_from_mapping", "load_config"]

log = logging.getLogger(__name__)

#: The tables of a run configuration.
TABLES: tuple[str, ...] = ("frames", "odometry", "tf", "mounts", "grid", "filter", "classifier", "tracking")
TABLES += ("clutter", "output", "detectors")
#: The keys of the tables that are fields of :class:`BagConfig` itself, and the fields they set.
_FLAT = {"odometry": {"topic": "odometry"}, "tf": {"topics": "tf_topics"}}


def _table(data: Mapping[str, Any], key: str) -> Mapping[str, Any]:
    value = data.get(key, {})
    if not isinstance(value, Mapping):
        raise ConfigError(f"[{key}] must be a table, got {type(value).__name__}")
    return value


def _only(table: Mapping[str, Any], allowed: Any, where: str) -> None:
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise ConfigError(f"{where} {unknown[0]}: unknown key; allowed: {sorted(allowed)}")


def config_from_mapping(data: Mapping[str, Any], *, source: str = "config") -> BagConfig:
    """A :class:`BagConfig` from a parsed TOML document (``docs/configuration.md``); ``source`` names it in the
    warning about detector names of earlier versions (:func:`gridbridge.params.current_detector_name`).

    Raises
    ------
    ConfigError
        (a ``ValueError``) One line naming the table and the key at fault.
    """
    _only(data, TABLES, "top level:")
    frames = _table(data, "frames")
    _only(frames, FRAMES_KEYS, "[frames]")
    if "driver" not in frames:
        raise ConfigError("[frames] driver: required (the topic whose messages make the frames)")
    kwargs: dict[str, Any] = dict(frames)
    for name, keys in _FLAT.items():
        table = _table(data, name)
        _only(table, keys, f"[{name}]")
        kwargs.update({keys[k]: v for k, v in table.items()})
    if isinstance(kwargs.get("tf_topics"), list):
        kwargs["tf_topics"] = tuple(kwargs["tf_topics"])
    for name in ("mounts", "grid", "filter", "classifier", "tracking", "clutter", "output"):
        if name in data:
            kwargs[name] = dict(_table(data, name))
    kwargs["detectors"] = _detectors(data.get("detectors", []), source)
    return BagConfig(**kwargs)


def _detectors(tables: object, source: str) -> tuple[dict[str, Any], ...]:
    """The ``[[detectors]]`` tables with the names of earlier versions as today's (warned once)."""
    if not isinstance(tables, list):
        raise ConfigError("[[detectors]]: must be an array of tables ([[detectors]] entries)")
    renamed: dict[str, str] = {}
    out = []
    for k, d in enumerate(tables):
        if not isinstance(d, Mapping):
            raise ConfigError(f"[[detectors]] #{k + 1}: must be a table, got {d!r}")
        out.append(_current(d, renamed))
    if renamed:
        pairs = [f"{old!r} as {new!r}" for old, new in renamed.items()]
        log.warning(
            "%s: %d detector name(s) are pfpeople's former default names, which are not valid ROS names: read with "
            "today's (%s); rename them in the config to silence this",
            source,
            len(pairs),
            ", ".join(pairs[:3] + (["..."] if len(pairs) > 3 else [])),
        )
    return tuple(out)


def _current(table: Mapping[str, Any], renamed: dict[str, str]) -> dict[str, Any]:
    """A ``[[detectors]]`` table as today's schema reads it: an old default name (``laser-legs``,
    ``laser-boosted:rear_scan``) as today's (``renamed`` gets ``old -> new``), and no ``[detectors.model] name``
    (the model is named after the detector: a different name is an error)."""
    out = dict(table)
    name = out.get("name")
    new = current_detector_name(name) if isinstance(name, str) else name
    if new != name:
        renamed[str(name)] = str(new)
        out["name"] = new
    model = out.get("model")
    if isinstance(model, Mapping) and "name" in model:
        if model["name"] not in (name, new):
            raise ConfigError(
                f"[detectors.model] name: must be the detector's name {new!r} (or be left out), got {model['name']!r}"
            )
        out["model"] = {k: v for k, v in model.items() if k != "name"}
    return out


def load_config(path: str | Path) -> BagConfig:
    """Read a TOML run configuration; errors name the file (:func:`pfpeople.io.tomlio.load_toml`: not UTF-8, not
    TOML, nested too deeply; then the table and key at fault)."""
    from pfpeople.io.tomlio import load_toml

    path = Path(path)
    data = load_toml(path, "config file")
    try:
        return config_from_mapping(data, source=f"config file {str(path)!r}")
    except (ValueError, TypeError) as exc:
        raise ConfigError(f"config file {str(path)!r}: {exc}") from None


def builtin_config_path(name: str) -> Path:
    """Path of a configuration shipped in ``pfpeople/configs`` (``name`` without ``.toml``)."""
    path = Path(__file__).parent.parent / "configs" / f"{name}.toml"
    if not path.is_file():
        have = sorted(p.stem for p in path.parent.glob("*.toml"))
        raise FileNotFoundError(f"no built-in config {name!r}; available: {have}")
    return path
