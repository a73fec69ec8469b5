"""Issue 46, findings 4, 8 and 12: messages that are large, broken or absent.

- 4: a CompressedImage declaring 20000 x 20000 pixels decoded to 1.2 GB before any size check;
- 8: NaN transforms on ``/tf`` during a run were dropped without a warning or a count;
- 12: ``BagSource.messages([])`` read every connection (rosbags takes no connections as all of them), so a run
  whose TF topics are ``[]`` or absent from the bag decoded scans as TF messages.

Bags are written under ``tmp_path`` (``bag_fixtures``).
"""

from __future__ import annotations

import logging
import math
import struct
import zlib
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np
import pytest
from bag_fixtures import PEOPLE, legs_only, write_bag, write_scan_bag

from gridbridge.grid import GridSpec
from pfpeople.io.bag import image_size, reader
from pfpeople.io.bag.reader import BagSource, MessageDataError, image_from_msg
from pfpeople.io.run_dir import load_run
from pfpeople.pipeline.runner import Pipeline
from pfpeople.sensors import Pose2D


def _png_header(width: int, height: int) -> bytes:
    """The signature and IHDR chunk of a PNG of ``width`` x ``height`` (8-bit grey), then IEND: a file of 57 bytes
    that declares the size (a bomb compresses its pixels to about 1 MB; the header is what matters)."""

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IEND", b"")


def _compressed(data: bytes) -> SimpleNamespace:
    return SimpleNamespace(data=data, format="png")


def test_a_huge_compressed_image_is_refused_before_it_is_decoded(monkeypatch: pytest.MonkeyPatch) -> None:
    """Finding 4: the size is read from the header; ``cv2.imdecode`` never runs on a 20000 x 20000 image."""
    calls = []
    monkeypatch.setattr(reader.cv2, "imdecode", lambda *a: calls.append(a))
    with pytest.raises(
        MessageDataError, match=r"topic '/cam': .*PNG image of 20000 x 20000 pixels, more than the limit"
    ):
        image_from_msg(
            _compressed(_png_header(20000, 20000)),
            "sensor_msgs/msg/CompressedImage",
            stamp_ns=1,
            frame_id="c",
            topic="/cam",
        )
    assert not calls


@pytest.mark.parametrize("ext", [".png", ".jpg"])
def test_the_header_size_of_real_png_and_jpeg_images_is_read(ext: str, monkeypatch: pytest.MonkeyPatch) -> None:
    pixels = np.random.default_rng(0).integers(0, 255, size=(48, 64, 3), dtype=np.uint8)
    ok, data = cv2.imencode(ext, pixels)
    assert ok
    assert image_size.encoded_size(data.tobytes())[1] == (64, 48)
    img = image_from_msg(_compressed(data.tobytes()), "sensor_msgs/msg/CompressedImage", stamp_ns=1, frame_id="c")
    assert img.pixels.shape == (48, 64, 3)
    monkeypatch.setattr(image_size, "MAX_IMAGE_PIXELS", 64 * 48 - 1)
    with pytest.raises(MessageDataError, match=r"image of 64 x 48 pixels, more than the limit of 3071 pixels"):
        image_from_msg(_compressed(data.tobytes()), "sensor_msgs/msg/CompressedImage", stamp_ns=1, frame_id="c")


def test_a_compressed_image_of_another_format_is_refused_before_decoding() -> None:
    ok, data = cv2.imencode(".bmp", np.zeros((4, 4), dtype=np.uint8))
    assert ok
    with pytest.raises(MessageDataError, match=r"not a PNG or JPEG image .*its size cannot be checked before decoding"):
        image_from_msg(_compressed(data.tobytes()), "sensor_msgs/msg/CompressedImage", stamp_ns=1, frame_id="c")


def test_messages_of_no_topic_are_none(tmp_path: Path) -> None:
    """Finding 12: rosbags reads every connection when given none."""
    bag = tmp_path / "b.bag"
    write_bag(bag, n_scans=3)
    with BagSource(bag) as src:
        assert list(src.messages([])) == []
        assert len(list(src.messages(["/scan"]))) == 3


@pytest.mark.parametrize("tf_topics", [(), ("/tf_static",), ("/nope",)])
def test_a_run_with_no_tf_topic_for_its_mount_does_not_decode_scans_as_tf(tmp_path: Path, tf_topics: tuple) -> None:
    """Finding 12: ``[tf] topics = []``, ``["/nope"]`` or only ``/tf_static`` without the mount read every message
    of the bag as TF ("cannot decode a tf2_msgs/msg/TFMessage ... KeyError: 0"); now only the TF topics are read:
    the mount that they do not give is an error naming the detector and the frames, or comes from ``[mounts]``."""
    bag = tmp_path / "b.bag"
    write_scan_bag(bag, 4, tf_mount=lambda k: Pose2D(x=0.2, y=0.0, yaw=0.0))  # the mount only on /tf
    cfg = legs_only(grid_frame="base_link", tf_topics=tf_topics, grid=GridSpec(x0=-1.0, y0=-4.5))
    with BagSource(bag) as src, pytest.raises(ValueError, match=r"detector 'legs': no transform from frame 'laser'"):
        Pipeline(cfg, front_process=False).run(src, None)
    with BagSource(bag) as src:
        summary, _ = Pipeline(replace(cfg, mounts={"laser": (0.2, 0.0, 0.0)}), front_process=False).run(src, None)
    assert summary.frames == 4


@pytest.mark.parametrize("two_processes", [False, True])
def test_nan_transforms_during_a_run_are_warned_once_and_counted(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, two_processes: bool
) -> None:
    """Finding 8: a NaN transform on ``/tf`` mid-run was dropped silently; now warned once per edge, counted in
    ``stats.bad_transforms``, and the edge keeps its last good transform."""
    good = Pose2D(x=0.2, y=0.1, yaw=0.3)
    bag = tmp_path / "nan.bag"
    write_scan_bag(bag, 12, tf_mount=lambda k: Pose2D(x=math.nan, y=0.1, yaw=0.3) if 5 <= k < 8 else good)
    cfg = legs_only(grid_frame="base_link", grid=GridSpec(x0=-1.0, y0=-4.5))
    with BagSource(bag) as src, caplog.at_level(logging.WARNING):
        summary, results = Pipeline(cfg, front_process=two_processes).run(src, tmp_path / "run", keep=True)
    assert summary.bad_transforms == {"base_link -> laser": 3}
    assert load_run(tmp_path / "run").meta["stats"]["bad_transforms"] == {"base_link -> laser": 3}
    warned = [r.message for r in caplog.records if "not finite" in r.message]
    assert len(warned) == 1 and "topic '/tf'" in warned[0] and "base_link -> laser" in warned[0]
    for r in results:  # every frame placed with the good mount
        assert r.detections[0] is not None
        assert np.min(np.linalg.norm(r.detections[0][:, None] - good.apply(PEOPLE)[None], axis=-1), axis=0).max() < 0.1
