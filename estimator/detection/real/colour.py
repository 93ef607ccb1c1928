"""Per-pixel maps from a venue's colour tables: how ball-like, and whether field green.

Both are table look-ups over the image's YCrCb pixels (:mod:`model` for the tables):
each pixel's bin number ``(Y // 32) * 1024 + (Cr // 8) * 32 + Cb // 8`` is built from the
three bytes with shifts and masks, and the flat table is indexed by it (NumPy's ``take``).
OpenCV's ``calcBackProject`` would do it in one call, but OpenCV 5's Python binding reads
a 3-D NumPy table as a 2-D table of 32 channels (wrong values), and its 2-D form needs
the channels packed first, which costs more than the indexing.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from estimator.detection.real.model import BallModel

__all__ = ["ColourTables", "ball_map", "field_map", "to_ycrcb"]

@dataclass(frozen=True)
class ColourTables:
    """A model's tables, flat, for indexing by bin number."""

    ball: npt.NDArray[np.uint8]
    """8192 colour bytes, by ``(Y // 32) * 1024 + (Cr // 8) * 32 + Cb // 8``."""
    field: npt.NDArray[np.uint8]
    """1024 field flags, by ``(Cr // 8) * 32 + Cb // 8``."""

    @classmethod
    def of(cls, model: BallModel) -> ColourTables:
        return cls(np.ascontiguousarray(model.colour_lut.ravel()),
                   np.ascontiguousarray(model.field_mask.ravel()))


def to_ycrcb(image_bgr: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    """OpenCV's 8-bit YCrCb of a BGR image."""
    return np.asarray(cv2.cvtColor(image_bgr, cv2.COLOR_BGR2YCrCb), np.uint8)


def _chroma_bins(ycrcb: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint16]:
    """``(Cr // 8) * 32 + Cb // 8`` per pixel."""
    bins = (ycrcb[..., 1] >> 3).astype(np.uint16)
    bins <<= 5
    bins |= ycrcb[..., 2] >> 3
    return bins


def ball_map(ycrcb: npt.NDArray[np.uint8], tables: ColourTables) -> npt.NDArray[np.uint8]:
    """The colour table's byte at every pixel (128 + 16 ln likelihood ratio)."""
    bins = _chroma_bins(ycrcb)
    bins |= (ycrcb[..., 0] & 0xE0).astype(np.uint16) << 5
    return np.asarray(tables.ball.take(bins), np.uint8)


def field_map(ycrcb: npt.NDArray[np.uint8], tables: ColourTables) -> npt.NDArray[np.uint8]:
    """1 where a pixel's (Cr, Cb) is the field's green, else 0."""
    return np.asarray(tables.field.take(_chroma_bins(ycrcb)), np.uint8)
