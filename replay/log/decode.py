"""Image messages to pixels: compressed (PNG, JPEG, BMP) through OpenCV, raw
``sensor_msgs/Image`` in every colour and grey encoding ROS 2 defines
(:mod:`replay.log.raw_image`).

Untrusted bytes are checked before OpenCV sees them: the dimensions are read from the
header (PNG IHDR, JPEG SOF, BMP info header) and an image over ``max_pixels`` is refused
before anything is allocated; a PNG's chunk CRCs are checked so a damaged one is refused
without libpng printing to stderr, and libjpeg's warnings about damaged data are silenced.
Anything that does not decode gives None; :func:`image_problem` says why in words (the
encoding it does not read, the size over the limit, ...).
"""

from __future__ import annotations

import contextlib
import os
import struct
import sys
import threading
import zlib
from collections.abc import Iterator

import cv2
import numpy as np

from replay.log.messages import ImageMessage
from replay.log.raw_image import decode_raw, raw_problem

__all__ = ["DEFAULT_MAX_PIXELS", "decode_image", "image_problem", "image_size"]

DEFAULT_MAX_PIXELS = 40_000_000
"""Largest image decoded (pixels): 40 Mpx, e.g. 6300 x 6300; a 4K camera has 8.8 Mpx."""

_PNG = b"\x89PNG\r\n\x1a\n"
_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}

# errors only: no "[ WARN ] ... PNG input buffer is incomplete" lines on stderr
cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)


_STDERR_LOCK = threading.Lock()
_stderr_users = 0
_stderr_saved = -1


@contextlib.contextmanager
def _quiet_stderr() -> Iterator[None]:
    """File descriptor 2 to /dev/null while any thread decodes a JPEG (libjpeg's warnings
    bypass Python); decoding threads share the redirection, none waits for another."""
    global _stderr_users, _stderr_saved
    with _STDERR_LOCK:
        if _stderr_users == 0:
            sys.stderr.flush()
            _stderr_saved = os.dup(2)
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, 2)
            os.close(devnull)
        _stderr_users += 1
    try:
        yield
    finally:
        with _STDERR_LOCK:
            _stderr_users -= 1
            if _stderr_users == 0:
                os.dup2(_stderr_saved, 2)
                os.close(_stderr_saved)


def _png_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) of a PNG whose chunks are all intact up to IEND, else None."""
    pos, n = 8, len(data)
    size = None
    while pos + 12 <= n:
        length = int.from_bytes(data[pos:pos + 4], "big")
        kind = data[pos + 4:pos + 8]
        end = pos + 12 + length
        if end > n:
            return None
        if zlib.crc32(data[pos + 4:pos + 8 + length]) != int.from_bytes(data[end - 4:end], "big"):
            return None
        if size is None:
            if kind != b"IHDR" or length != 13:
                return None
            size = struct.unpack(">II", data[pos + 8:pos + 16])
        if kind == b"IEND":
            return size
        pos = end
    return None


def _jpeg_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) from a JPEG's first SOF segment, None when there is none."""
    pos, n = 2, len(data)
    while pos + 4 <= n:
        if data[pos] != 0xFF:
            return None
        marker = data[pos + 1]
        if marker == 0xFF:  # fill byte
            pos += 1
            continue
        if marker in (0x01, *range(0xD0, 0xD8)):  # standalone markers
            pos += 2
            continue
        length = int.from_bytes(data[pos + 2:pos + 4], "big")
        if marker in _SOF:
            if pos + 9 > n:
                return None
            height, width = struct.unpack(">HH", data[pos + 5:pos + 9])
            return int(width), int(height)
        if marker == 0xDA or length < 2:  # scan data before any frame header
            return None
        pos += 2 + length
    return None


def _bmp_size(data: bytes) -> tuple[int, int] | None:
    if len(data) < 26:
        return None
    width, height = struct.unpack("<ii", data[18:26])
    return abs(int(width)), abs(int(height))


def image_size(data: bytes) -> tuple[str, int, int] | None:
    """(format, width, height) from a compressed image's header; None when the bytes are
    not an intact PNG, a JPEG or a BMP."""
    if data.startswith(_PNG):
        size = _png_size(data)
        return None if size is None else ("png", *size)
    if data.startswith(b"\xff\xd8\xff"):
        size = _jpeg_size(data)
        return None if size is None else ("jpeg", *size)
    if data.startswith(b"BM"):
        size = _bmp_size(data)
        return None if size is None else ("bmp", *size)
    return None


def decode_image(msg: ImageMessage, *, max_pixels: int = DEFAULT_MAX_PIXELS) -> np.ndarray | None:
    """BGR pixels of an image message, None when it does not decode or is over
    ``max_pixels``."""
    if msg.fmt == "raw":
        return decode_raw(msg.data, msg.encoding, msg.width_px, msg.height_px, msg.step,
                          big_endian=msg.big_endian, max_pixels=max_pixels)
    header = image_size(msg.data)
    if header is None:
        return None
    _fmt, width, height = header
    if width <= 0 or height <= 0 or width * height > max_pixels:
        return None
    try:
        if _fmt == "jpeg":
            with _quiet_stderr():  # libjpeg prints "Corrupt JPEG data: ..." on fd 2
                img = cv2.imdecode(np.frombuffer(msg.data, np.uint8), cv2.IMREAD_COLOR)
        else:
            img = cv2.imdecode(np.frombuffer(msg.data, np.uint8), cv2.IMREAD_COLOR)
    except cv2.error:
        return None
    if img is None or not img.size or img.shape[0] * img.shape[1] > max_pixels:
        return None
    return img


def image_problem(msg: ImageMessage, *, max_pixels: int = DEFAULT_MAX_PIXELS) -> str:
    """Why an image message does not decode, in words (for one that :func:`decode_image`
    gave None for)."""
    if msg.fmt == "raw":
        problem = raw_problem(msg.encoding, msg.width_px, msg.height_px, msg.step,
                              len(msg.data), max_pixels)
        return problem or f"{msg.encoding[:40]} pixels do not convert"
    header = image_size(msg.data)
    if header is None:
        return f"format {msg.fmt[:40]!r}: not an intact PNG, JPEG or BMP"
    fmt, width, height = header
    if width <= 0 or height <= 0 or width * height > max_pixels:
        return f"{fmt} image of {width} x {height} px (at most {max_pixels / 1e6:g} Mpx)"
    return f"{fmt} data does not decode"
