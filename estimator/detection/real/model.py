"""A venue's ball model: the ball's colour, its size range and the field's colour.

What a team fits at a new venue from a few labelled frames (:mod:`fit`) and the
real-ball detector (:mod:`detector`) reads. It holds no learned weights of the shared check;
those are a separate artifact (:mod:`check`).

Colour. A look-up table over YCrCb (OpenCV's 8-bit ``COLOR_BGR2YCrCb``) quantised to
``COLOUR_BINS`` = 8 x 32 x 32 bins (Y in steps of 32, Cr and Cb in steps of 8): each bin
holds the log-likelihood ratio ``ln p(c | ball) - ln p(c | not ball)`` of the venue's
pixels, as a byte ``128 + 16 * ratio`` (clipped to 0-255; 128: as likely ball as not).
Brightness is coarse so shading does not matter much; chroma is fine so a yellow ball and a
yellow shirt can differ in the last few steps.

Field. A 32 x 32 (Cr, Cb) mask of the field's green, used as context (a ball lies on or
near the field) by the ranking.

Sizes are in pixels of the full image the model was fitted on (ball diameters: the larger
side of a labelled box).

JSON form (``to_dict`` / ``from_dict``; reading and writing files is the caller's)::

    {"format": "dual-sight ball model", "version": 1,
     "colour": {"space": "YCrCb", "bins": [8, 32, 32], "offset": 128, "scale": 16,
                "lut_b64": "..."},
     "field": {"space": "CrCb", "bins": [32, 32], "mask_b64": "..."},
     "levels": [150, 166, 182], "diameter_px": [4.0, 160.0], "threshold": 0.5,
     "size_line": [a, b], "check_head": [40 numbers] or null, "centre_blend": w,
     "fit": {"images": 10, "balls": 11, ...}}
"""

from __future__ import annotations

import base64
import binascii
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from estimator.errors import BallModelError

__all__ = ["COLOUR_BINS", "FIELD_BINS", "FORMAT", "MAX_LEVELS", "MAX_SIZE_OFFSET_PX",
           "MAX_SIZE_SLOPE", "BallModel", "model_from_dict", "model_to_dict"]

FORMAT = "dual-sight ball model"
VERSION = 1
COLOUR_BINS = (8, 32, 32)
"""Y, Cr, Cb bins of the colour table (steps of 32, 8 and 8 of OpenCV's 0-255)."""
FIELD_BINS = (32, 32)
"""Cr, Cb bins of the field mask."""
HEAD_SIZE = 40
"""Weights of the check's 32 features, 3 context and 4 blob features, and a bias."""
OFFSET = 128
SCALE = 16.0
"""A table byte b stands for the log-likelihood ratio ``(b - OFFSET) / SCALE``."""


MAX_LEVELS = 16
"""The most table levels a ball model may cut blobs at (each is a pass over every image;
a fitted model has 3)."""
MAX_SIZE_SLOPE = 100.0
"""The steepest size line [px of diameter per px of row] a ball model may hold (a fitted
one is under 1)."""
MAX_DIAMETER_PX = 1e4
"""The widest ball a model may allow [px]: wider than any camera's image."""
MAX_SIZE_OFFSET_PX = 1e5
"""The largest size line offset [px] a ball model may hold."""


@dataclass(frozen=True)
class BallModel:
    """One venue's ball: colour table, candidate levels, size range, check threshold."""

    colour_lut: npt.NDArray[np.uint8] = field(compare=False, repr=False)
    """COLOUR_BINS bytes: ``OFFSET + SCALE * ln(p(c | ball) / p(c | not ball))``."""
    field_mask: npt.NDArray[np.uint8] = field(compare=False, repr=False)
    """FIELD_BINS, 1 where (Cr, Cb) is the field's green, else 0."""
    levels: tuple[int, ...] = (150, 166, 182)
    """Table bytes at which blobs are cut out, lowest first (see :mod:`candidates`)."""
    min_diameter_px: float = 4.0
    max_diameter_px: float = 160.0
    threshold: float = 0.5
    """The learned check's probability from which a candidate is reported as the ball."""
    size_line: tuple[float, float] = (0.0, 0.0)
    """A ball's expected diameter [px] at the row of its lowest pixel y: ``a * y + b``
    (fitted on the labelled balls; (0, 0): no expectation)."""
    check_head: tuple[float, ...] | None = None
    """The venue's correction of the check's logit (:mod:`head`; None: none)."""
    centre_blend: float = 0.5
    """Weight of the check's regressed centre in the reported centroid; the rest is the
    centre of the winner's colour blob's box at full resolution (:mod:`detector`)."""
    fit: Mapping[str, Any] = field(default_factory=dict, compare=False)
    """What the model was fitted from (counts, names); informative only."""

    def __post_init__(self) -> None:
        if self.colour_lut.shape != COLOUR_BINS or self.colour_lut.dtype != np.uint8:
            raise BallModelError(f"colour table has shape {self.colour_lut.shape} and dtype "
                                 f"{self.colour_lut.dtype}; expected {COLOUR_BINS} uint8")
        if self.field_mask.shape != FIELD_BINS or self.field_mask.dtype != np.uint8:
            raise BallModelError(f"field mask has shape {self.field_mask.shape}; expected "
                                 f"{FIELD_BINS} uint8")
        if not self.levels or list(self.levels) != sorted(set(self.levels)) or not all(
                0 < t <= 255 for t in self.levels) or len(self.levels) > MAX_LEVELS:
            raise BallModelError(f"levels {self.levels} must be at most {MAX_LEVELS} distinct "
                                 "bytes 1-255, ascending")
        if not 0 < self.min_diameter_px <= self.max_diameter_px <= MAX_DIAMETER_PX:
            raise BallModelError(f"diameter range [{self.min_diameter_px}, "
                                 f"{self.max_diameter_px}] px is not 0 < min <= max <= "
                                 f"{MAX_DIAMETER_PX:g}")
        if not 0.0 <= self.threshold <= 1.0:
            raise BallModelError(f"threshold {self.threshold} is not a probability 0-1")
        if not 0.0 <= self.centre_blend <= 1.0:
            raise BallModelError(f"centre_blend {self.centre_blend} is not a weight 0-1")
        a, b = self.size_line
        if not (math.isfinite(a) and math.isfinite(b) and 0.0 <= a <= MAX_SIZE_SLOPE
                and abs(b) <= MAX_SIZE_OFFSET_PX):
            raise BallModelError(f"size_line ({a}, {b}) must be finite, its slope in "
                                 f"[0, {MAX_SIZE_SLOPE:g}] and its offset within "
                                 f"{MAX_SIZE_OFFSET_PX:g} px")
        if self.check_head is not None and (len(self.check_head) != HEAD_SIZE or not all(
                math.isfinite(v) for v in self.check_head)):
            raise BallModelError(f"check_head must be {HEAD_SIZE} finite numbers")
        for array in (self.colour_lut, self.field_mask):
            array.setflags(write=False)


def _b64(array: npt.NDArray[np.uint8]) -> str:
    return base64.b64encode(np.ascontiguousarray(array).tobytes()).decode("ascii")


def _unb64(text: object, shape: tuple[int, ...], name: str) -> npt.NDArray[np.uint8]:
    if not isinstance(text, str):
        raise BallModelError(f"{name} must be a base64 string, not {type(text).__name__}")
    try:
        raw = base64.b64decode(text, validate=True)
    except (binascii.Error, ValueError) as err:
        raise BallModelError(f"{name} is not valid base64: {err}") from err
    if len(raw) != math.prod(shape):
        raise BallModelError(f"{name} holds {len(raw)} bytes; expected {math.prod(shape)}")
    return np.asarray(np.frombuffer(raw, np.uint8).reshape(shape).copy(), np.uint8)


def model_to_dict(model: BallModel) -> dict[str, Any]:
    """The model's JSON form (see the module docstring)."""
    return {
        "format": FORMAT, "version": VERSION,
        "colour": {"space": "YCrCb", "bins": list(COLOUR_BINS), "offset": OFFSET,
                   "scale": SCALE, "lut_b64": _b64(model.colour_lut)},
        "field": {"space": "CrCb", "bins": list(FIELD_BINS),
                  "mask_b64": _b64(model.field_mask)},
        "levels": list(model.levels),
        "diameter_px": [round(model.min_diameter_px, 3), round(model.max_diameter_px, 3)],
        "threshold": round(model.threshold, 6),
        "size_line": [round(v, 6) for v in model.size_line],
        "check_head": None if model.check_head is None else [
            round(v, 6) for v in model.check_head],
        "centre_blend": round(model.centre_blend, 6),
        "fit": dict(model.fit),
    }


def _section(data: Mapping[str, Any], key: str) -> Mapping[str, Any]:
    value = data.get(key)
    if not isinstance(value, Mapping):
        raise BallModelError(f"'{key}' must be an object")
    return value


def model_from_dict(data: Mapping[str, Any]) -> BallModel:
    """A model from its JSON form; :class:`BallModelError` naming the first bad field."""
    if not isinstance(data, Mapping) or data.get("format") != FORMAT:
        raise BallModelError(f"not a ball model: 'format' must be '{FORMAT}'")
    if data.get("version") != VERSION:
        raise BallModelError(f"ball model version {data.get('version')!r}; this reads "
                             f"version {VERSION}")
    colour, fld = _section(data, "colour"), _section(data, "field")
    if (colour.get("space"), list(colour.get("bins", ())), colour.get("offset"),
            colour.get("scale")) != ("YCrCb", list(COLOUR_BINS), OFFSET, SCALE):
        raise BallModelError(f"colour must be YCrCb, bins {list(COLOUR_BINS)}, offset "
                             f"{OFFSET}, scale {SCALE}")
    if (fld.get("space"), list(fld.get("bins", ()))) != ("CrCb", list(FIELD_BINS)):
        raise BallModelError(f"field must be CrCb, bins {list(FIELD_BINS)}")
    try:
        levels = tuple(int(t) for t in data["levels"])
        lo, hi = (float(d) for d in data["diameter_px"])
        threshold = float(data["threshold"])
        a, b = (float(v) for v in data.get("size_line", (0.0, 0.0)))
        head = data.get("check_head")
        check_head = None if head is None else tuple(float(v) for v in head)
        centre_blend = float(data.get("centre_blend", 0.5))
    except (KeyError, TypeError, ValueError) as err:
        raise BallModelError(f"levels, diameter_px and threshold must be numbers: {err}"
                             ) from err
    fit = data.get("fit", {})
    return BallModel(
        colour_lut=_unb64(colour.get("lut_b64"), COLOUR_BINS, "colour.lut_b64"),
        field_mask=_unb64(fld.get("mask_b64"), FIELD_BINS, "field.mask_b64"),
        levels=levels, min_diameter_px=lo, max_diameter_px=hi, threshold=threshold,
        size_line=(a, b), check_head=check_head, centre_blend=centre_blend,
        fit=dict(fit) if isinstance(fit, Mapping) else {})
