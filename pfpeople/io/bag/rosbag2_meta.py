"""rosbag2 ``metadata.yaml`` that ROS 2 Humble reads: version 5.

rosbags' :class:`rosbags.rosbag2.Writer` writes metadata versions 8 and 9 only (its ``version`` parameter is
``Literal[8, 9]``; anything else raises ``WriterError``). ROS 2 Humble's ``rosbag2_storage`` (0.15.x) has
``BagMetadata::version = 5``: the ``custom_data`` field that makes version 6 was reverted before Humble's
release (rosbag2 0.15.1, ros2/rosbag2#984) and version 6-9 came with Iron and Jazzy. Later distributions
decode every older version (each field is read only when ``version`` is high enough), so a version 5
``metadata.yaml`` is read by Humble, Iron, Jazzy and rolling, and by rosbags' reader.

:func:`humble_metadata` rewrites a version 8 ``metadata.yaml`` as version 5: ``version: 5``, and the fields
versions 6-8 added (``custom_data``, ``ros_distro``, ``topic_metadata.type_description_hash``) dropped. The
``offered_qos_profiles`` string of version 8 (a YAML list of profiles with integer policies) is the format
versions 4-8 share, so it stays. The storage file itself is not touched: a sqlite3 ``.db3`` by rosbags has
schema 4 (extra tables and columns that Humble's plugin does not query); its ``metadata`` table, read only
by Iron and later when ``metadata.yaml`` is missing (``ros2 bag reindex``), keeps the version 8 text.

:func:`parse_metadata` reads a ``metadata.yaml`` before ``rosbags`` does (a bag folder, or a folder inside a zip) and
gives a one-line error naming the file, the line and the problem for a file that is not YAML or lists no storage
files (rosbags' own error quotes the YAML parser's several lines); :func:`storage_files` gives the storage files it
lists, which are all a reader opens.
"""

from __future__ import annotations

import os
from io import StringIO
from pathlib import Path
from typing import Any

from ruamel.yaml import YAML
from ruamel.yaml.error import YAMLError

__all__ = ["ROSBAG2_METADATA_VERSION", "humble_metadata", "parse_metadata", "storage_files"]

#: The rosbag2 metadata version written (ROS 2 Humble's).
ROSBAG2_METADATA_VERSION = 5

#: Keys of ``rosbag2_bagfile_information`` in version 5.
_V5_KEYS = (
    "version",
    "storage_identifier",
    "duration",
    "starting_time",
    "message_count",
    "topics_with_message_count",
    "compression_format",
    "compression_mode",
    "relative_file_paths",
    "files",
)
_V5_TOPIC_KEYS = ("name", "type", "serialization_format", "offered_qos_profiles")


def humble_metadata(path: str | Path) -> dict[str, Any]:
    """Rewrite the ``metadata.yaml`` at ``path`` (version 8, by rosbags) as version 5; returns the new content.

    Raises
    ------
    ValueError
        The file is not a rosbag2 metadata file of version 5 to 8.
    """
    p = Path(path)
    yaml = YAML(typ="safe")
    doc = yaml.load(p.read_text("utf8"))
    info = doc.get("rosbag2_bagfile_information") if isinstance(doc, dict) else None
    if not isinstance(info, dict) or not 5 <= int(info.get("version", 0)) <= 8:
        raise ValueError(f"{str(p)!r} is not a rosbag2 metadata.yaml of version 5 to 8")
    info = {k: info[k] for k in _V5_KEYS if k in info}
    info["version"] = ROSBAG2_METADATA_VERSION
    for entry in info["topics_with_message_count"]:
        meta = entry["topic_metadata"]
        entry["topic_metadata"] = {k: meta[k] for k in _V5_TOPIC_KEYS if k in meta}
    out = {"rosbag2_bagfile_information": info}
    yaml.default_flow_style = False
    text = StringIO()
    yaml.dump(out, text)
    tmp = p.with_name(f".{p.name}.tmp")
    tmp.write_text(text.getvalue(), "utf8")
    os.replace(tmp, p)
    return out


def parse_metadata(text: str | bytes, where: str) -> dict[str, Any]:
    """The ``rosbag2_bagfile_information`` mapping of the ``metadata.yaml`` text ``text``.

    Parameters
    ----------
    text : str or bytes
        The file's content (bytes are decoded as UTF-8).
    where : str
        The file, as errors name it.

    Raises
    ------
    ValueError
        One line naming ``where``: not UTF-8, not YAML (with the line and column), nested beyond the parser's
        recursion limit, no ``rosbag2_bagfile_information`` mapping, or no storage file listed (:func:`storage_files`).
    """
    try:
        doc = YAML(typ="safe").load(text.decode("utf8") if isinstance(text, bytes) else text)
    except UnicodeDecodeError as exc:
        raise ValueError(f"{where} is not UTF-8 text (byte {exc.object[exc.start]:#04x} at {exc.start})") from None
    except YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = " ".join(str(getattr(exc, "problem", None) or type(exc).__name__).split())
        raise ValueError(f"{where} is not valid YAML{at}: {problem}") from None
    except RecursionError:
        raise ValueError(f"{where} is nested too deeply to be a rosbag2 metadata file") from None
    info = doc.get("rosbag2_bagfile_information") if isinstance(doc, dict) else None
    if not isinstance(info, dict):
        raise ValueError(f"{where} has no rosbag2_bagfile_information mapping: not a rosbag2 metadata file")
    storage_files(info, where)
    return info


def storage_files(info: dict[str, Any], where: str) -> list[str]:
    """The storage files (names relative to the bag folder) that a metadata mapping lists.

    Raises
    ------
    ValueError
        ``relative_file_paths`` is missing, empty, or holds something other than non-empty strings.
    """
    files = info.get("relative_file_paths")
    if not isinstance(files, list) or not files or not all(isinstance(f, str) and f for f in files):
        raise ValueError(f"{where}: relative_file_paths must list the bag's storage files, got {files!r}")
    return list(files)
