"""Replacing a rosbag2 result folder with ``overwrite``: exactly the old bag's files, never the others in it.

A rosbag2 bag is a folder: its ``metadata.yaml`` and the storage files that file lists (``relative_file_paths``).
A user may keep other files in it (notes, a README, plots); ``overwrite`` replaces the bag, not them:

- :func:`check_replaceable` (before the run) reads the old ``metadata.yaml`` (a folder whose file cannot be read is
  not replaced) and refuses a folder where the new bag would write a file the old bag does not list (e.g. a
  ``res.mcap`` of the user's when the old bag was sqlite3), naming it;
- :func:`move_in` (when the new bag is complete) moves the old bag's files aside, into the writer's temporary
  folder (removed with it), then the new bag's files in; every other file of the folder stays as it was.
"""

from __future__ import annotations

import os
from pathlib import Path

from pfpeople.io.bag.rosbag2_meta import parse_metadata, storage_files

__all__ = ["check_replaceable", "move_in", "new_bag_files", "old_bag_files"]

#: Bytes of an old ``metadata.yaml`` read (a real one is a few kB).
_MAX_METADATA_BYTES = 16 * 2**20


def new_bag_files(folder: Path, bag_format: str) -> list[str]:
    """The files a rosbag2 written by rosbags into ``folder`` has: ``metadata.yaml`` and ``<folder name>.db3`` (or
    ``.mcap``)."""
    return ["metadata.yaml", f"{folder.name}.{'mcap' if bag_format == 'mcap' else 'db3'}"]


def old_bag_files(folder: Path, where: str) -> list[str]:
    """The files of the rosbag2 in ``folder`` that exist: ``metadata.yaml`` and the storage files it lists (plain
    names in the folder only); ``[]`` for an empty folder.

    Raises
    ------
    ValueError
        Naming ``where``: the ``metadata.yaml`` cannot be read or parsed, or lists a path outside the folder.
    """
    meta = folder / "metadata.yaml"
    if not meta.exists() and not any(folder.iterdir()):
        return []
    try:
        with meta.open("rb") as fh:
            listed = storage_files(parse_metadata(fh.read(_MAX_METADATA_BYTES), f"{where}: {str(meta)!r}"), where)
    except OSError as exc:
        raise ValueError(f"{where}: its metadata.yaml cannot be read ({exc}): not replaced") from None
    bad = [f for f in listed if "/" in f or "\\" in f or f in ("", ".", "..")]
    if bad:
        raise ValueError(f"{where}: its metadata.yaml lists {bad[0]!r}, not a file of the folder: not replaced")
    return [name for name in ("metadata.yaml", *listed) if os.path.lexists(folder / name)]


def check_replaceable(folder: Path, bag_format: str, where: str) -> None:
    """Refuse to replace the rosbag2 in ``folder`` when the new bag would write over a file the old one does not
    list (see the module docstring).

    Raises
    ------
    ValueError
        Naming ``where`` and the file.
    """
    old = set(old_bag_files(folder, where))
    for name in new_bag_files(folder, bag_format):
        if name not in old and os.path.lexists(folder / name):
            raise ValueError(
                f"{where} holds {name!r}, which its metadata.yaml does not list: not the bag's own file, not replaced "
                "(move it, or choose another --bag-out)"
            )


def move_in(new: Path, folder: Path, aside: Path, where: str) -> None:
    """Move the old bag's files of ``folder`` into ``aside`` (a new folder), then every file of the complete bag
    ``new`` into ``folder``."""
    old = old_bag_files(folder, where)
    aside.mkdir()
    for name in old:
        os.rename(folder / name, aside / name)
    for item in sorted(new.iterdir()):
        os.rename(item, folder / item.name)
