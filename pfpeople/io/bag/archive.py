"""Zipped bags: the bag members of a ``.zip`` extracted once, checked, into a bounded cache.

A ``.zip`` may hold one bag: a ROS1 ``.bag`` member, or a ROS2 bag folder (a folder with a ``metadata.yaml``; the
archive's root counts as a folder). :func:`extract_zip` extracts it into ``$PFPEOPLE_CACHE/bags`` (default
``~/.cache/pfpeople/bags``) and returns the extracted bag. What it holds to:

- **Names.** Every member name must be a plain relative path (:func:`member_name`): no leading ``/``, no ``..`` or
  ``.`` component, no backslash, no drive (``C:``), no NUL; an archive with another name is refused naming it. A
  member is only ever read from the archive and written under the cache folder by its validated name, never opened
  through a path of the host (a member named ``/home/user/other.bag`` once made a run read that host file).
- **Only the bag.** Only the bag's members are unpacked: the ``.bag`` member, or the folder's ``metadata.yaml`` and
  the storage files it lists (``relative_file_paths``, which are all a reader opens; a listed file missing from the
  archive is refused naming it). Other members are never read.
- **Bounds**, checked before anything is written: at most :data:`MAX_ZIP_MEMBERS` members in the archive
  (``$PFPEOPLE_MAX_ZIP_MEMBERS``); the bag members' total uncompressed size at most :data:`MAX_ZIP_BYTES`
  (``$PFPEOPLE_MAX_ZIP_BYTES``) and the free space of the cache; their total compressed at most
  :data:`MAX_ZIP_RATIO` times when above :data:`ZIP_RATIO_MIN_BYTES` (a zip bomb); a ``metadata.yaml`` of at most
  :data:`MAX_METADATA_BYTES`. While a member is written, it may not give more bytes than its header declares.
- **Atomic.** Extraction goes to a temporary folder of the cache, renamed into place when complete. The cache keeps
  at most :data:`MAX_CACHE_ENTRIES` extracted bags and :data:`MAX_CACHE_BYTES` bytes (``$PFPEOPLE_CACHE_MAX_BYTES``;
  least recently used evicted first; older copies of the same zip at once).

Every error is a :class:`BagReadError` naming the archive and, where one is at fault, the member. The limits from
the environment are read by :func:`gridbridge.limits.env_limit` (a bad value is an error naming the variable).
"""

from __future__ import annotations

import contextlib
import hashlib
import logging
import os
import shutil
import tempfile
import time
import zipfile
from pathlib import Path

from gridbridge.limits import env_limit
from pfpeople.io.bag.rosbag2_meta import parse_metadata, storage_files

__all__ = [
    "MAX_CACHE_BYTES",
    "MAX_CACHE_ENTRIES",
    "MAX_METADATA_BYTES",
    "MAX_ZIP_BYTES",
    "MAX_ZIP_MEMBERS",
    "MAX_ZIP_RATIO",
    "ZIP_RATIO_MIN_BYTES",
    "BagReadError",
    "evict_cache",
    "extract_zip",
    "member_name",
]

log = logging.getLogger(__name__)

#: Largest total uncompressed size of a zip's bag members (bytes); ``$PFPEOPLE_MAX_ZIP_BYTES`` overrides.
MAX_ZIP_BYTES = 64 * 2**30
#: Most members an archive may hold (a ROS2 bag is a few files; a zip of a million empty members is an attack);
#: ``$PFPEOPLE_MAX_ZIP_MEMBERS`` overrides.
MAX_ZIP_MEMBERS = 10_000
#: Largest compression ratio of the bag members together when they are larger than :data:`ZIP_RATIO_MIN_BYTES` (bags
#: compress 2-20 times; a zip bomb hundreds or thousands of times).
MAX_ZIP_RATIO = 200.0
ZIP_RATIO_MIN_BYTES = 64 * 2**20
#: Largest ``metadata.yaml`` read from an archive (bytes; a real one is a few kB).
MAX_METADATA_BYTES = 2**20
#: Extracted bags kept in the cache, and their total size (bytes; ``$PFPEOPLE_CACHE_MAX_BYTES`` overrides).
MAX_CACHE_ENTRIES = 8
MAX_CACHE_BYTES = 100 * 2**30
_COPY_CHUNK = 2**20


class BagReadError(RuntimeError):
    """A bag could not be opened or read (corrupt, truncated, unknown format or type)."""


def cache_root() -> Path:
    """The folder of the extracted bags' cache: ``$PFPEOPLE_CACHE`` or ``~/.cache/pfpeople``."""
    env = os.environ.get("PFPEOPLE_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "pfpeople"


def member_name(archive: Path, name: str) -> str:
    """``name`` checked as a plain relative path (see the module docstring); returned without a trailing ``/``.

    Raises
    ------
    BagReadError
        Naming the archive and the member.
    """
    parts = name[:-1].split("/") if name.endswith("/") else name.split("/")  # a folder's entry ends in "/"
    bad = "\\" in name or "\0" in name or parts[0].endswith(":") or any(p in ("", ".", "..") for p in parts)
    if bad:
        raise BagReadError(
            f"bag archive {str(archive)!r} has a member named {name!r}: an absolute path or one leaving its folder "
            "(.., /, \\, a drive); refused (extract it yourself if you trust it)"
        )
    return "/".join(parts)


def _checked_infos(archive: Path, zf: zipfile.ZipFile) -> dict[str, zipfile.ZipInfo]:
    """Validated member name -> its entry (no ``__MACOSX/`` entries), after the member count is checked."""
    infos = zf.infolist()
    limit = env_limit("PFPEOPLE_MAX_ZIP_MEMBERS", MAX_ZIP_MEMBERS)
    if len(infos) > limit:
        raise BagReadError(
            f"bag archive {str(archive)!r} holds {len(infos)} members, more than the limit of {limit} "
            "(set PFPEOPLE_MAX_ZIP_MEMBERS to allow it)"
        )
    out: dict[str, zipfile.ZipInfo] = {}
    for info in infos:
        name = member_name(archive, info.filename)
        if not name.startswith("__MACOSX/") and name != "__MACOSX":
            out[name] = info
    return out


def _find_bag(archive: Path, infos: dict[str, zipfile.ZipInfo]) -> str:
    """The one bag of an archive: a ``.bag`` member, or a folder with a ``metadata.yaml`` (``"dir/"``; ``""`` for the
    archive's root)."""
    files = [n for n, i in infos.items() if not i.is_dir()]
    bags = sorted(n for n in files if n.endswith(".bag"))
    meta = "metadata.yaml"
    folders = sorted({n[: -len(meta)] for n in files if n == meta or n.endswith(f"/{meta}")})
    found = bags + folders
    if not found:
        raise BagReadError(f"bag archive {str(archive)!r} holds no .bag file and no ROS2 bag folder")
    if len(found) > 1:
        listing = ", ".join(f or "./" for f in found)
        raise BagReadError(
            f"bag archive {str(archive)!r} holds {len(found)} bags ({listing}); unzip it and give the bag to use"
        )
    return found[0]


def _bag_members(archive: Path, zf: zipfile.ZipFile, infos: dict[str, zipfile.ZipInfo], bag: str) -> list[str]:
    """The members to unpack for ``bag``: the ``.bag`` member, or a folder's ``metadata.yaml`` and its storage
    files."""
    if bag.endswith(".bag"):
        return [bag]
    meta = f"{bag}metadata.yaml"
    where = f"bag archive {str(archive)!r}: member {meta!r}"
    if infos[meta].file_size > MAX_METADATA_BYTES:
        raise BagReadError(
            f"{where} is {infos[meta].file_size} bytes, more than {MAX_METADATA_BYTES}: not a metadata file"
        )
    with zf.open(infos[meta]) as fh:
        text = fh.read(MAX_METADATA_BYTES + 1)
    try:
        files = storage_files(parse_metadata(text, where), where)
    except ValueError as exc:
        raise BagReadError(str(exc)) from None
    names = [meta]
    for f in files:
        name = f"{bag}{member_name(archive, f)}"
        if name not in infos or infos[name].is_dir():
            raise BagReadError(f"{where} lists the storage file {f!r}, which the archive does not hold")
        names.append(name)
    return names


def _check_sizes(archive: Path, infos: list[zipfile.ZipInfo], free: int) -> None:
    """Refuse bag members too large together, compressed like a zip bomb, or beyond the free space."""
    limit = env_limit("PFPEOPLE_MAX_ZIP_BYTES", MAX_ZIP_BYTES)
    total = sum(i.file_size for i in infos)
    packed = sum(i.compress_size for i in infos)
    what = f"member {infos[0].filename!r} is" if len(infos) == 1 else f"its {len(infos)} bag members are"
    if total > limit:
        raise BagReadError(
            f"bag archive {str(archive)!r}: {what} {total} bytes uncompressed, more than the limit of {limit} bytes "
            "(set PFPEOPLE_MAX_ZIP_BYTES to allow it)"
        )
    ratio = total / max(packed, 1)
    if total > ZIP_RATIO_MIN_BYTES and ratio > MAX_ZIP_RATIO:
        raise BagReadError(
            f"bag archive {str(archive)!r}: {what} {total} bytes uncompressed from {packed} bytes (ratio {ratio:.0f}, "
            f"more than {MAX_ZIP_RATIO:.0f}): refused as a possible zip bomb; unzip it yourself if it is genuine"
        )
    if total > free:
        raise BagReadError(
            f"bag archive {str(archive)!r} needs {total} bytes to extract; the cache has {free} bytes free "
            "(set PFPEOPLE_CACHE to a larger disk)"
        )


def _unpack(archive: Path, zf: zipfile.ZipFile, info: zipfile.ZipInfo, name: str, into: Path) -> None:
    """Write member ``info`` to ``into / name`` (a new file under a new folder: no link is followed), refusing
    more bytes than its header declares."""
    target = into.joinpath(*name.split("/"))
    target.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC, 0o644)
    written = 0
    with os.fdopen(fd, "wb") as out, zf.open(info) as src:
        while chunk := src.read(_COPY_CHUNK):
            written += len(chunk)
            if written > info.file_size:
                raise BagReadError(
                    f"bag archive {str(archive)!r}: member {info.filename!r} gives more than the {info.file_size} "
                    "bytes its header declares; refused"
                )
            out.write(chunk)


def _dir_size(path: Path) -> int:
    total = 0
    for p in path.rglob("*"):
        with contextlib.suppress(OSError):
            if p.is_file() and not p.is_symlink():
                total += p.stat().st_size
    return total


def evict_cache(root: Path, *, keep: Path | None = None, source: Path | None = None) -> list[Path]:
    """Bound the zip extraction cache ``root``; returns the folders removed.

    Removes older copies of the zip ``source`` (same zip path, another key: the zip changed), extraction folders left
    by a crash more than an hour ago, then the least recently used entries beyond :data:`MAX_CACHE_ENTRIES`
    or :data:`MAX_CACHE_BYTES` (``$PFPEOPLE_CACHE_MAX_BYTES``). ``keep`` is never removed.
    """
    if not root.is_dir():
        return []
    removed: list[Path] = []
    entries: list[tuple[float, Path]] = []
    now = time.time()
    for d in root.iterdir():
        if not d.is_dir() or d.is_symlink() or d == keep:
            continue
        done = d / ".complete"
        try:
            if d.name.startswith(".extract-"):
                if now - d.stat().st_mtime > 3600:
                    removed.append(d)
                continue
            if not done.exists():
                continue
            origin = d / ".source"
            if source is not None and origin.is_file() and origin.read_text() == str(source):
                removed.append(d)
                continue
            entries.append((done.stat().st_mtime, d))
        except OSError:
            continue
    entries.sort(reverse=True)  # most recently used first
    max_bytes = env_limit("PFPEOPLE_CACHE_MAX_BYTES", MAX_CACHE_BYTES)
    used = _dir_size(keep) if keep is not None and keep.is_dir() else 0
    n = 1 if keep is not None else 0
    for _, d in entries:
        size = _dir_size(d)
        if n + 1 > MAX_CACHE_ENTRIES or used + size > max_bytes:
            removed.append(d)
        else:
            n += 1
            used += size
    for d in removed:
        shutil.rmtree(d, ignore_errors=True)
        log.info("bag cache: removed %s", d)
    return removed


def _extract_into(
    archive: Path, zf: zipfile.ZipFile, members: dict[str, zipfile.ZipInfo], root: Path, dest: Path
) -> None:
    """Unpack ``members`` (validated name -> entry) into a temporary folder of ``root`` and rename it to ``dest``."""
    tmp = Path(tempfile.mkdtemp(prefix=".extract-", dir=root))
    try:
        for name, info in members.items():
            _unpack(archive, zf, info, name, tmp)
        (tmp / ".source").write_text(str(archive.resolve()))
        (tmp / ".complete").touch()
        try:
            tmp.rename(dest)
        except OSError:  # another process finished the same extraction first
            if not (dest / ".complete").exists():
                raise
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def extract_zip(path: Path, cache_dir: Path | None = None) -> Path:
    """Extract the bag of the zip ``path`` once (see the module docstring); returns the ``.bag`` file or ROS2 folder.

    Parameters
    ----------
    path : Path
        The archive.
    cache_dir : Path, optional
        Where bags are extracted (default ``$PFPEOPLE_CACHE/bags``).

    Raises
    ------
    BagReadError
        Naming the archive (and the member at fault).
    ValueError
        A limit in the environment that is not a number (naming the variable).
    """
    stat = path.stat()
    key = hashlib.sha1(f"{path.resolve()}:{stat.st_size}:{stat.st_mtime_ns}".encode()).hexdigest()[:12]
    root = Path(cache_dir) if cache_dir is not None else cache_root() / "bags"
    dest = root / f"{path.stem}-{key}"
    try:
        with zipfile.ZipFile(path) as zf:
            infos = _checked_infos(path, zf)
            bag = _find_bag(path, infos)
            if not (dest / ".complete").exists():
                members = {n: infos[n] for n in _bag_members(path, zf, infos, bag)}
                root.mkdir(parents=True, exist_ok=True)
                _check_sizes(path, list(members.values()), shutil.disk_usage(root).free)
                _extract_into(path, zf, members, root, dest)
    except zipfile.BadZipFile as exc:
        raise BagReadError(f"bag archive {str(path)!r} is not a valid zip file: {exc}") from None
    except OSError as exc:
        raise BagReadError(f"cannot extract bag archive {str(path)!r} into {str(root)!r}: {exc}") from None
    (dest / ".complete").touch()  # last use, for the cache's least-recently-used eviction
    evict_cache(root, keep=dest, source=path.resolve())
    return dest.joinpath(*bag.rstrip("/").split("/")) if bag else dest
