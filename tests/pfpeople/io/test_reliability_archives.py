"""Issue 46, findings 1, 2 and 15 (metadata.yaml): zipped bags are read by their validated member names only, only
the bag is unpacked, and the archive is bounded before anything is written.

Every archive is written under ``tmp_path``; "host" files stand for files outside the cache (``tmp_path / "host"``).
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import pytest
from bag_fixtures import write_bag, write_scan_bag

from pfpeople.cli import main
from pfpeople.io.bag import archive
from pfpeople.io.bag.reader import BagReadError, BagSource


def _files(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file())


def test_a_member_with_an_absolute_name_is_refused_and_the_host_file_never_read(tmp_path: Path) -> None:
    """Finding 1: a member named like a host path made the run process that host file (rc 0)."""
    host = tmp_path / "host" / "other.bag"
    host.parent.mkdir()
    write_scan_bag(host, 3)  # a real bag: before the fix BagSource opened it and read its scans
    z = tmp_path / "a.zip"
    with zipfile.ZipFile(z, "w") as zf:
        zf.writestr(str(host), b"x")
    with pytest.raises(BagReadError, match=r"a\.zip' has a member named '/.*other\.bag': an absolute path"):
        BagSource(z, cache_dir=tmp_path / "cache")
    assert not (tmp_path / "cache").exists() or not _files(tmp_path / "cache")


@pytest.mark.parametrize("name", ["../../x.bag", "d/../../x.bag", "./x.bag", "C:/x.bag", "d\\..\\x.bag", "a//x.bag"])
def test_a_member_leaving_its_folder_is_refused_and_nothing_is_written(tmp_path: Path, name: str) -> None:
    """Finding 1: ``../../x.bag`` left the cache (the run read ``cache/../../x.bag``)."""
    bag = tmp_path / "s.bag"
    write_scan_bag(bag, 3)
    cache = tmp_path / "deep" / "er" / "cache"
    (tmp_path / "x.bag").write_bytes(bag.read_bytes())  # where ../../x.bag from the cache entry would land
    z = tmp_path / "up.zip"
    with zipfile.ZipFile(z, "w") as zf:
        zf.writestr(name, bag.read_bytes())
    with pytest.raises(BagReadError, match=r"has a member named .*refused"):
        BagSource(z, cache_dir=cache)
    assert not cache.exists() or not _files(cache)


def test_the_cli_refuses_a_zip_naming_a_host_file_with_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    host = tmp_path / "host" / "other.bag"
    host.parent.mkdir()
    write_scan_bag(host, 3)
    z = tmp_path / "a.zip"
    with zipfile.ZipFile(z, "w") as zf:
        zf.writestr(str(host), b"x")
    code = main(
        ["run", str(z), "--driver", "/scan", "--out", str(tmp_path / "r"), "--bag-out", str(tmp_path / "o.bag")]
    )
    assert code == 2
    assert "absolute path" in capsys.readouterr().err
    assert not (tmp_path / "r").exists() and not (tmp_path / "o.bag").exists()


def test_only_the_bag_member_is_unpacked(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Finding 2: one bag and 20 members of zeros unpacked 1.3 GB (``extractall``): now only the bag is written."""
    monkeypatch.setattr(archive, "ZIP_RATIO_MIN_BYTES", 2**20)  # the real threshold is 64 MiB
    bag = tmp_path / "s.bag"
    write_scan_bag(bag, 3)
    z = tmp_path / "many.zip"
    with zipfile.ZipFile(z, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        zf.write(bag, "s.bag")
        for k in range(20):
            zf.writestr(f"zeros/{k}.bin", b"\0" * 2**20)  # each under the ratio threshold, 20 MiB together
    cache = tmp_path / "cache"
    with BagSource(z, cache_dir=cache) as src:
        assert src.message_counts["/scan"] == 3
    (entry,) = [p for p in cache.iterdir()]
    assert _files(entry) == [".complete", ".source", "s.bag"]


def test_the_bag_members_total_size_and_ratio_are_bounded(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Finding 2: the ratio covered each member alone, above 64 MiB; now the bag's members together."""
    monkeypatch.setattr(archive, "ZIP_RATIO_MIN_BYTES", 2**20)
    write_bag(tmp_path / "r2", n_scans=3, ros2=True)
    z = tmp_path / "r2.zip"
    with zipfile.ZipFile(z, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        zf.write(tmp_path / "r2" / "metadata.yaml", "r2/metadata.yaml")
        zf.write(tmp_path / "r2" / "r2.db3", "r2/r2.db3")
        zf.writestr("r2/padding.db3", b"\0" * (8 * 2**20))  # not listed in metadata.yaml: never unpacked
    with BagSource(z, cache_dir=tmp_path / "c1") as src:
        assert "/scan" in src.topics
    assert not list((tmp_path / "c1").rglob("padding.db3"))
    monkeypatch.setenv("PFPEOPLE_MAX_ZIP_BYTES", "1000")
    with pytest.raises(
        BagReadError, match=r"its 2 bag members are \d+ bytes uncompressed, more than the limit of 1000"
    ):
        BagSource(z, cache_dir=tmp_path / "c2")
    monkeypatch.delenv("PFPEOPLE_MAX_ZIP_BYTES")
    bomb = tmp_path / "bomb.zip"
    text = (tmp_path / "r2" / "metadata.yaml").read_text()
    listed = text.replace("- r2.db3", "- r2_0.db3\n  - r2_1.db3\n  - r2_2.db3\n  - r2_3.db3")
    assert listed != text
    with zipfile.ZipFile(bomb, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("metadata.yaml", listed)
        for k in range(4):  # four members of 1 MiB of zeros: each alone at the threshold, 4 MiB together
            zf.writestr(f"r2_{k}.db3", b"\0" * 2**20)
    with pytest.raises(BagReadError, match=r"its 5 bag members are \d+ bytes uncompressed from \d+ bytes .*zip bomb"):
        BagSource(bomb, cache_dir=tmp_path / "c3")
    assert not list((tmp_path / "c3").rglob("*.db3"))


def test_the_member_count_is_bounded(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    bag = tmp_path / "s.bag"
    write_scan_bag(bag, 2)
    z = tmp_path / "count.zip"
    with zipfile.ZipFile(z, "w") as zf:
        zf.write(bag, "s.bag")
        for k in range(30):
            zf.writestr(f"e/{k}", b"")
    monkeypatch.setenv("PFPEOPLE_MAX_ZIP_MEMBERS", "20")
    with pytest.raises(BagReadError, match=r"holds 31 members, more than the limit of 20"):
        BagSource(z, cache_dir=tmp_path / "cache")


def test_a_listed_storage_file_missing_from_the_archive_is_named(tmp_path: Path) -> None:
    write_bag(tmp_path / "r2", n_scans=2, ros2=True)
    z = tmp_path / "r2.zip"
    with zipfile.ZipFile(z, "w") as zf:
        zf.write(tmp_path / "r2" / "metadata.yaml", "r2/metadata.yaml")
    with pytest.raises(BagReadError, match=r"lists the storage file 'r2\.db3', which the archive does not hold"):
        BagSource(z, cache_dir=tmp_path / "cache")


@pytest.mark.parametrize("value", ["inf", "1e400", "nan", "-5", "0", "lots"])
def test_a_zip_limit_in_the_environment_that_is_not_a_number_is_named(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, value: str
) -> None:
    """Finding 13: ``PFPEOPLE_MAX_ZIP_BYTES=inf`` ended in an OverflowError."""
    bag = tmp_path / "s.bag"
    write_scan_bag(bag, 2)
    z = tmp_path / "s.zip"
    with zipfile.ZipFile(z, "w") as zf:
        zf.write(bag, "s.bag")
    monkeypatch.setenv("PFPEOPLE_MAX_ZIP_BYTES", value)
    with pytest.raises(ValueError, match=rf"environment variable PFPEOPLE_MAX_ZIP_BYTES='{value}' must be a finite"):
        BagSource(z, cache_dir=tmp_path / "cache")


def test_a_malformed_metadata_yaml_is_one_line_naming_the_file_and_line(tmp_path: Path) -> None:
    """Finding 15: rosbags' error quoted the YAML parser over 8 lines."""
    b = tmp_path / "r2"
    write_bag(b, n_scans=2, ros2=True)
    (b / "metadata.yaml").write_text("rosbag2_bagfile_information:\n  version: 5\n  foo: [1, 2\n")
    with pytest.raises(BagReadError) as info:
        BagSource(b)
    text = str(info.value)
    assert "\n" not in text
    assert "metadata.yaml' is not valid YAML at line 4, column 1: expected ',' or ']'" in text
    (b / "metadata.yaml").write_text("rosbag2_bagfile_information:\n  version: 5\n")
    with pytest.raises(BagReadError, match=r"metadata\.yaml': relative_file_paths must list the bag's storage files"):
        BagSource(b)
    (b / "metadata.yaml").write_bytes(b"rosbag2_bagfile_information: \xff\xfe\n")
    with pytest.raises(BagReadError, match=r"metadata\.yaml' is not UTF-8 text \(byte 0xff at 29\)"):
        BagSource(b)
