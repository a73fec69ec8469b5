"""The pixel size of a compressed image, read from its header before it is decoded.

A ``sensor_msgs/CompressedImage`` of a few kB can declare 20000 x 20000 pixels: decoding it allocates 1.2 GB before
any size check. :func:`check_encoded_size` reads the width and height from the header of the two formats ROS image
transports publish, PNG (the ``IHDR`` chunk) and JPEG (the first start-of-frame marker), and refuses an image of more
than :data:`MAX_IMAGE_PIXELS` pixels, or another format (whose size cannot be read without decoding it), before
``cv2.imdecode`` runs.
"""

from __future__ import annotations

import struct

__all__ = ["MAX_IMAGE_PIXELS", "check_encoded_size", "encoded_size"]

#: Largest image decoded (pixels): 40 million, e.g. 7680 x 5200 (120 MB as 8-bit BGR).
MAX_IMAGE_PIXELS = 40_000_000
_PNG = b"\x89PNG\r\n\x1a\n"
#: JPEG start-of-frame markers (they carry the size): C0-CF but DHT (C4), JPG (C8) and DAC (CC).
_SOF = frozenset(range(0xC0, 0xD0)) - {0xC4, 0xC8, 0xCC}
#: JPEG markers without a length field.
_STANDALONE = frozenset((0x01, *range(0xD0, 0xD9)))


def _jpeg_size(data: bytes) -> tuple[int, int] | None:
    """``(width, height)`` from the first start-of-frame segment of a JPEG stream, None if there is none."""
    i = 2
    while i + 4 <= len(data):
        if data[i] != 0xFF:
            return None
        marker = data[i + 1]
        if marker == 0xFF:  # fill byte
            i += 1
            continue
        if marker in _STANDALONE:
            i += 2
            continue
        if marker in _SOF and i + 9 <= len(data):
            height, width = struct.unpack(">HH", data[i + 5 : i + 9])
            return width, height
        (length,) = struct.unpack(">H", data[i + 2 : i + 4])
        i += 2 + length
    return None


def encoded_size(data: bytes) -> tuple[str, tuple[int, int] | None]:
    """The format (``"png"``, ``"jpeg"`` or ``""``) and ``(width, height)`` of an encoded image (None: not found)."""
    if data[:8] == _PNG:
        if len(data) >= 24 and data[12:16] == b"IHDR":
            width, height = struct.unpack(">II", data[16:24])
            return "png", (width, height)
        return "png", None
    if data[:2] == b"\xff\xd8":
        return "jpeg", _jpeg_size(data)
    return "", None


def check_encoded_size(data: bytes, where: str) -> None:
    """Refuse, before decoding, an encoded image that is not PNG or JPEG, has no readable size, or has more than
    :data:`MAX_IMAGE_PIXELS` pixels.

    Raises
    ------
    ValueError
        Naming ``where`` (the topic and the stamp), the format and the size.
    """
    fmt, size = encoded_size(data)
    if not fmt:
        raise ValueError(
            f"{where}: not a PNG or JPEG image (it starts with {data[:8]!r}): its size cannot be checked before "
            "decoding; publish PNG or JPEG"
        )
    if size is None:
        raise ValueError(f"{where}: {fmt.upper()} image without a readable size in its header (damaged)")
    width, height = size
    if width * height > MAX_IMAGE_PIXELS:
        raise ValueError(
            f"{where}: {fmt.upper()} image of {width} x {height} pixels, more than the limit of {MAX_IMAGE_PIXELS} "
            "pixels: not decoded"
        )
