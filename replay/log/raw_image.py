"""Raw ``sensor_msgs/Image`` pixels to BGR, for every colour and grey encoding ROS 2 defines.

The encodings are those of ROS 2's ``sensor_msgs/image_encodings.hpp`` that hold a colour or
grey image (the generic ``8UC3``-style types say nothing about colour and are refused):

- packed: ``bgr8 rgb8 bgra8 rgba8 mono8`` and their 16-bit forms ``bgr16 rgb16 bgra16
  rgba16 mono16`` (``is_bigendian`` honoured);
- Bayer mosaics: ``bayer_rggb8 bayer_bggr8 bayer_gbrg8 bayer_grbg8`` and the ``*16`` forms;
- YUV: ``yuv422`` (UYVY; ``uyvy`` too) and ``yuv422_yuy2`` (YUYV; ``yuyv`` too), ``nv21``
  (4:2:0) and ``nv24`` (4:4:4).

Every conversion is OpenCV's (``cv2.cvtColor``): demosaicing is its bilinear one, YUV is
BT.601 as OpenCV reads it; ``nv24`` is first packed to 4:2:2 (each pair of chroma samples
averaged) and read as UYVY. 16-bit values become 8-bit by dividing by 256, as cv_bridge does.

Bounds come first, from the header: the pixel count against ``max_pixels``, the row step
against the width, the buffer against step x rows; nothing is allocated for a message that
fails them. :func:`raw_problem` says in words why a message does not decode.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["RAW_ENCODINGS", "decode_raw", "raw_problem"]


@dataclass(frozen=True)
class _Layout:
    """How one encoding lays out its pixels."""

    kind: str
    """"packed", "bayer", "yuv422", "nv21" or "nv24"."""
    channels: int = 1
    """Samples per pixel (packed: 1, 3 or 4; YUV 4:2:2: 2)."""
    bytes_per_sample: int = 1
    code: int = -1
    """The cv2.COLOR_* conversion to BGR (-1: none, the samples are BGR already)."""


_PACKED = {
    "bgr8": _Layout("packed", 3), "rgb8": _Layout("packed", 3, code=cv2.COLOR_RGB2BGR),
    "bgra8": _Layout("packed", 4, code=cv2.COLOR_BGRA2BGR),
    "rgba8": _Layout("packed", 4, code=cv2.COLOR_RGBA2BGR),
    "mono8": _Layout("packed", 1, code=cv2.COLOR_GRAY2BGR),
}
# ROS names a Bayer pattern by its first two rows (rggb: R G / G B); OpenCV by the second
# row's second and third samples, so rggb is OpenCV's "BG" (cv_bridge's mapping)
_BAYER = {"rggb": cv2.COLOR_BayerBG2BGR, "bggr": cv2.COLOR_BayerRG2BGR,
          "gbrg": cv2.COLOR_BayerGR2BGR, "grbg": cv2.COLOR_BayerGB2BGR}

RAW_ENCODINGS: dict[str, _Layout] = {
    **_PACKED,
    **{name.replace("8", "16"): _Layout("packed", lay.channels, 2, lay.code)
       for name, lay in _PACKED.items()},
    **{f"bayer_{p}8": _Layout("bayer", code=c) for p, c in _BAYER.items()},
    **{f"bayer_{p}16": _Layout("bayer", bytes_per_sample=2, code=c) for p, c in _BAYER.items()},
    "yuv422": _Layout("yuv422", 2, code=cv2.COLOR_YUV2BGR_UYVY),
    "uyvy": _Layout("yuv422", 2, code=cv2.COLOR_YUV2BGR_UYVY),
    "yuv422_yuy2": _Layout("yuv422", 2, code=cv2.COLOR_YUV2BGR_YUYV),
    "yuyv": _Layout("yuv422", 2, code=cv2.COLOR_YUV2BGR_YUYV),
    "nv21": _Layout("nv21", code=cv2.COLOR_YUV2BGR_NV21),
    "nv24": _Layout("nv24", code=cv2.COLOR_YUV2BGR_UYVY),
}
"""Encoding name (lower case) -> its layout: what replay decodes."""


def _rows(layout: _Layout, height: int) -> tuple[int, int]:
    """(rows of ``step`` bytes the buffer needs, as a numerator over 2) for ``height``."""
    if layout.kind == "nv21":
        return 3 * height, 2  # the Y plane, then half as many rows of interleaved V/U
    if layout.kind == "nv24":
        return 6 * height, 2  # the Y plane, then rows of interleaved U/V twice as long
    return 2 * height, 2


def raw_problem(encoding: str, width: int, height: int, step: int, size: int,
                max_pixels: int) -> str | None:
    """Why a raw image with this header and ``size`` bytes of data does not decode (None:
    it would)."""
    enc = encoding.lower()
    layout = RAW_ENCODINGS.get(enc)
    if layout is None:
        return (f"encoding {encoding[:40]!r} is not one replay reads "
                f"(it reads {', '.join(RAW_ENCODINGS)})")
    if width <= 0 or height <= 0:
        return f"{enc} image of {width} x {height} px"
    if width * height > max_pixels:
        return f"{enc} image of {width} x {height} px is over {max_pixels / 1e6:g} Mpx"
    if layout.kind in ("yuv422", "nv21", "nv24") and width % 2:
        return f"{enc} image {width} px wide: the width must be even"
    if layout.kind == "nv21" and height % 2:
        return f"{enc} image {height} px high: the height must be even"
    row = width * layout.channels * layout.bytes_per_sample
    step = step or row
    if step < row:
        return f"{enc} row step {step} is less than {width} px x {row // width} bytes"
    num, den = _rows(layout, height)
    if size < step * num // den:
        return f"{enc} data of {size} bytes is less than the {step * num // den} it declares"
    return None


def decode_raw(data: bytes, encoding: str, width: int, height: int, step: int, *,
               big_endian: bool = False, max_pixels: int) -> np.ndarray | None:
    """BGR pixels (uint8, height x width x 3) of a raw image, None when it does not decode
    (:func:`raw_problem` says why)."""
    if raw_problem(encoding, width, height, step, len(data), max_pixels) is not None:
        return None
    layout = RAW_ENCODINGS[encoding.lower()]
    row = width * layout.channels * layout.bytes_per_sample
    step = step or row
    try:
        if layout.kind == "nv21":
            planes = np.frombuffer(data, np.uint8, count=step * height * 3 // 2)
            yuv = planes.reshape(height * 3 // 2, step)[:, :width]
            return cv2.cvtColor(np.ascontiguousarray(yuv), layout.code)
        if layout.kind == "nv24":
            return _nv24(data, width, height, step)
        px: np.ndarray = np.frombuffer(data, np.uint8, count=step * height)
        px = px.reshape(height, step)[:, :row]
        if layout.bytes_per_sample == 2:  # to native 16-bit samples (a contiguous copy)
            px = px.view(">u2" if big_endian else "<u2").astype(np.uint16)
        px = np.ascontiguousarray(px.reshape(height, width, layout.channels))
        if layout.kind == "bayer":
            px = cv2.cvtColor(px[..., 0], layout.code)
        elif layout.code >= 0:
            px = cv2.cvtColor(px, layout.code)
        if px.dtype != np.uint8:
            px = np.right_shift(px, 8).astype(np.uint8)  # 16 bits -> 8, as cv_bridge does
        return np.ascontiguousarray(px)
    except cv2.error:
        return None


def _nv24(data: bytes, width: int, height: int, step: int) -> np.ndarray:
    """NV24 (a Y plane, then full-resolution interleaved U/V) through OpenCV's UYVY reading:
    each pair of pixels' chroma averaged into 4:2:2."""
    y_plane = np.frombuffer(data, np.uint8, count=step * height).reshape(height, step)[:, :width]
    uv = np.frombuffer(data, np.uint8, count=2 * step * height, offset=step * height)
    uv = uv.reshape(height, 2 * step)[:, : 2 * width].reshape(height, width // 2, 2, 2)
    u = (uv[:, :, :, 0].astype(np.uint16).sum(axis=2) + 1) >> 1
    v = (uv[:, :, :, 1].astype(np.uint16).sum(axis=2) + 1) >> 1
    uyvy = np.empty((height, width // 2, 4), np.uint8)
    uyvy[..., 0] = u
    uyvy[..., 1] = y_plane[:, 0::2]
    uyvy[..., 2] = v
    uyvy[..., 3] = y_plane[:, 1::2]
    return cv2.cvtColor(uyvy.reshape(height, width, 2), cv2.COLOR_YUV2BGR_UYVY)
