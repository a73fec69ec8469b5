"""Issue 46, findings 3, 5, 9 and 15 (outputs): outputs never follow a symbolic link they did not create, never
delete a file they did not write, and name the file of every error.

Every "victim" file stands for a file outside the outputs; all live under ``tmp_path``.
"""

from __future__ import annotations

import contextlib
import errno
import os
from pathlib import Path

import numpy as np
import pytest
from bag_fixtures import write_scan_bag
from rosbags.highlevel import AnyReader

from gridbridge.grid import GridSpec
from pfpeople.cli import main
from pfpeople.io import locks
from pfpeople.io.bag.writer import BagLockedError, ResultBagWriter, lock_path
from pfpeople.io.run_dir import RunLockedError, RunWriter, load_run

SPEC = GridSpec(nx=10, ny=10)


def _victim(tmp_path: Path) -> Path:
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    return victim


def _run(bag: Path, out: Path, *extra: str) -> int:
    return main(["run", str(bag), "--driver", "/scan", "--out", str(out), "--no-progress", "--one-process", *extra])


def test_a_lock_file_that_is_a_symlink_is_refused_and_not_written_through(tmp_path: Path) -> None:
    """Finding 3: ``mkdir o; ln -s ~/victim o/.lock; pfpeople run B --out o`` wrote a pid into the victim."""
    victim = _victim(tmp_path)
    out = tmp_path / "o"
    out.mkdir()
    (out / ".lock").symlink_to(victim)
    with pytest.raises(RunLockedError, match=r"lock file '.*/o/\.lock' is a symbolic link: not followed"):
        RunWriter(out, spec=SPEC, detector_names=["d"])
    assert victim.read_text() == "precious\n"
    assert sorted(p.name for p in out.iterdir()) == [".lock"] and (out / ".lock").is_symlink()


def test_the_cli_refuses_a_run_whose_lock_is_a_symlink(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    victim = _victim(tmp_path)
    bag = tmp_path / "b.bag"
    write_scan_bag(bag, 3)
    out = tmp_path / "o"
    out.mkdir()
    (out / ".lock").symlink_to(victim)
    assert _run(bag, out) == 2
    assert "is a symbolic link" in capsys.readouterr().err
    assert victim.read_text() == "precious\n"


@pytest.mark.parametrize("name", ["tracks.csv", "support.csv", "grids.npy", "frames.csv", "view.mp4"])
def test_overwrite_refuses_a_run_file_that_is_a_symlink_before_changing_anything(tmp_path: Path, name: str) -> None:
    """Finding 3: ``tracks.csv`` and ``support.csv`` were written through a symlink under ``--overwrite``."""
    victim = _victim(tmp_path)
    bag = tmp_path / "b.bag"
    write_scan_bag(bag, 3)
    out = tmp_path / "run"
    assert _run(bag, out) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    (out / name).unlink(missing_ok=True)
    (out / name).symlink_to(victim)
    with pytest.raises(FileExistsError, match=rf"'{name}' is a symbolic link .*not writing through it"):
        RunWriter(out, spec=SPEC, detector_names=["legs"], overwrite=True)
    assert victim.read_text() == "precious\n"
    assert all((out / k).read_bytes() == v for k, v in before.items() if k != name)


def test_new_run_files_are_never_opened_through_a_link(tmp_path: Path) -> None:
    """Files a writer creates are created anew (``O_EXCL | O_NOFOLLOW``): a link put in place after the checks (a
    race) makes the writer fail, naming the file, instead of writing through it."""
    victim = _victim(tmp_path)
    out = tmp_path / "run"
    w = RunWriter(out, spec=SPEC, detector_names=["d"])
    (out / "tracks.csv").symlink_to(victim)
    frame = {"driver_index": 0, "bag_time_ns": 1, "dt_s": 0.1, "odometry": None, "forced": False}
    with pytest.raises(OSError, match=r"File exists: '.*tracks\.csv'"):
        w.write_frame(
            frame=0,
            stamp_ns=1,
            belief=np.full(SPEC.shape, 0.5),
            people=np.zeros((0, 2)),
            detections=[np.zeros((0, 2))],
            tracks=[],
            **frame,  # type: ignore[arg-type]
        )
    w.close(status="failed")
    assert victim.read_text() == "precious\n"


def test_overwrite_replaces_the_previous_runs_tracks_and_view_files(tmp_path: Path) -> None:
    """Finding 9: ``run --overwrite`` left the previous run's ``view.mp4``, ``view.gif`` and ``summary.png`` (and
    its ``tracks.csv`` stayed when the new run had no tracking)."""
    bag = tmp_path / "b.bag"
    write_scan_bag(bag, 3)
    out = tmp_path / "run"
    assert _run(bag, out) == 0
    for name in ("view.mp4", "view.gif", "summary.png"):
        (out / name).write_bytes(b"old picture")
    (out / "notes.txt").write_text("mine\n")
    assert (out / "tracks.csv").is_file()
    RunWriter(out, spec=SPEC, detector_names=["d"], overwrite=True).close()
    assert sorted(p.name for p in out.iterdir()) == [  # a finished run holds no .lock
        "detections.csv",
        "frames.csv",
        "grids.npy",
        "notes.txt",
        "people.csv",
        "run.json",
    ]
    assert (out / "notes.txt").read_text() == "mine\n"


def test_a_refused_directory_gets_no_lock_file(tmp_path: Path) -> None:
    """Finding 15: ``.lock`` was created in a directory ``run`` then refused (it holds other files)."""
    out = tmp_path / "mine"
    out.mkdir()
    (out / "thesis.tex").write_text("x")
    with pytest.raises(FileExistsError, match=r"is not empty and holds no run\.json \(thesis\.tex\)"):
        RunWriter(out, spec=SPEC, detector_names=["d"])
    assert sorted(p.name for p in out.iterdir()) == ["thesis.tex"]


def test_a_dangling_symlink_out_is_named(tmp_path: Path) -> None:
    """Finding 15: a dangling-symlink ``--out`` gave ``[Errno 17] File exists``."""
    out = tmp_path / "out"
    out.symlink_to(tmp_path / "nowhere")
    with pytest.raises(FileExistsError, match=r"output directory '.*/out' is a symbolic link to '.*/nowhere', which "):
        RunWriter(out, spec=SPEC, detector_names=["d"])
    assert not (tmp_path / "nowhere").exists()


def test_enospc_writing_the_lock_names_the_lock_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Finding 15: ENOSPC for the run directory named no file (the pid written into its lock)."""

    def full(fd: int, data: bytes, offset: int) -> int:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(locks, "_pwrite", full)
    with pytest.raises(OSError, match=r"No space left on device: '.*/run/\.lock'") as info:
        RunWriter(tmp_path / "run", spec=SPEC, detector_names=["d"])
    assert info.value.errno == errno.ENOSPC


@pytest.mark.parametrize("name", ["out.bag", "out_ros2"])
def test_enospc_in_the_result_bag_names_it(tmp_path: Path, name: str) -> None:
    """Finding 15: ENOSPC for ``--bag-out`` named no file."""
    w = ResultBagWriter(tmp_path / name, spec=SPEC, frame_id="laser", detector_names=["d"])
    full = open("/dev/full", "wb")  # every write to it fails with ENOSPC
    if name.endswith(".bag"):
        w._writer.bio.close()
        w._writer.bio = full
    else:

        def write(*_: object) -> None:
            full.write(b"x" * 2**16)
            full.flush()

        w._writer.storage.write = write
    try:
        with pytest.raises(OSError, match=rf"No space left on device: '.*{name}'"):
            for k in range(2000):
                w.write(k + 1, k + 1, np.full(SPEC.shape, 0.5), np.zeros((0, 2)), [None])
            w.close()
    finally:
        with contextlib.suppress(OSError):
            full.close()
        w._discard()
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_bag_out_lock_that_is_a_symlink_is_refused(tmp_path: Path) -> None:
    """Finding 3: ``OUT.bag.lock`` was written through a symlink."""
    victim = _victim(tmp_path)
    lock_path(tmp_path / "out.bag").symlink_to(victim)
    with pytest.raises(BagLockedError, match=r"lock file '.*out\.bag\.lock' is a symbolic link: not followed"):
        ResultBagWriter(tmp_path / "out.bag", spec=SPEC, frame_id="laser", detector_names=["d"])
    assert victim.read_text() == "precious\n"


def test_bag_out_overwrite_keeps_the_other_files_of_a_ros2_folder(tmp_path: Path) -> None:
    """Finding 5: ``--bag-out FOLDER --overwrite`` on a ROS 2 bag folder deleted the other files in it."""
    path = tmp_path / "res"
    kw = {"spec": SPEC, "frame_id": "laser", "detector_names": ["d"]}
    with ResultBagWriter(path, **kw) as old:
        old.write(1, 1, np.full(SPEC.shape, 0.5), np.zeros((0, 2)), [None])
    (path / "notes.txt").write_text("mine\n")
    (path / "sub").mkdir()
    (path / "sub" / "more.txt").write_text("mine too\n")
    with ResultBagWriter(path, overwrite=True, **kw) as new:
        for k in range(3):
            new.write(k + 1, k + 1, np.full(SPEC.shape, 0.5), np.zeros((0, 2)), [None])
    assert (path / "notes.txt").read_text() == "mine\n" and (path / "sub" / "more.txt").read_text() == "mine too\n"
    with AnyReader([path]) as r:
        assert {c.topic: c.msgcount for c in r.connections}["/pfpeople/belief"] == 3
    assert sorted(p.name for p in path.iterdir()) == ["metadata.yaml", "notes.txt", "res.db3", "sub"]


def test_bag_out_overwrite_refuses_a_storage_name_the_old_bag_did_not_list(tmp_path: Path) -> None:
    """A file named like the new bag's storage file that the old ``metadata.yaml`` does not list is not the bag's:
    refused before the run, naming it, and kept."""
    path = tmp_path / "res"
    kw = {"spec": SPEC, "frame_id": "laser", "detector_names": ["d"]}
    with ResultBagWriter(path, **kw) as old:
        old.write(1, 1, np.full(SPEC.shape, 0.5), np.zeros((0, 2)), [None])
    (path / "res.mcap").write_text("mine\n")
    with pytest.raises(ValueError, match=r"holds 'res\.mcap', which its metadata\.yaml does not list"):
        ResultBagWriter(path, overwrite=True, bag_format="mcap", **kw)
    assert (path / "res.mcap").read_text() == "mine\n"


def test_the_run_directory_is_readable_after_a_refused_overwrite(tmp_path: Path) -> None:
    bag = tmp_path / "b.bag"
    write_scan_bag(bag, 3)
    out = tmp_path / "run"
    assert _run(bag, out) == 0
    (out / "support.csv").unlink(missing_ok=True)
    (out / "support.csv").symlink_to(tmp_path / "x")
    with pytest.raises(FileExistsError):
        RunWriter(out, spec=SPEC, detector_names=["legs"], overwrite=True)
    assert load_run(out).n_frames == 3
