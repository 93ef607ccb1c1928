"""The learned check: a small CNN that tells a ball from a ball-coloured thing.

Each candidate is cut out as a square of ``spec.context`` times its larger side (at least
``spec.min_side_px``), centred on it, resized to ``spec.crop_px`` square (``INTER_AREA``;
outside the image the border pixels are repeated), so a near and a far ball look alike and
the crop shows what lies around the blob. With ``spec.wide_px`` > 0 a second, wider square
(``spec.wide_context`` times the side) of the same centre is cut too, at ``spec.wide_px``:
the leg above a shoe, the body around a shirt. Five channels per crop, 0-1:

    B, G, R          the pixels / 255
    ball             the venue's colour table byte / 255 (:func:`colour.ball_map`)
    field            1 where the venue's field green is (:func:`colour.field_map`)

so the network sees the venue's colour model (fitted per venue) beside the pixels, and
needs to learn only what a ball looks like against its surroundings: round, shaded, on or
near the field, not a shirt, a robot's cover or a lamp.

Beside the crops the network reads ``CONTEXT_FEATURES`` numbers per candidate that its
scaled crops cannot show (:func:`head.context`). The network (trained by
``train/train.py``, exported to ONNX; inputs "crops", optionally "wide", and "context") gives
per candidate the logit of "a ball", the ball's centre relative to the crop's (in crop
sides) and the log of the ball's diameter over the crop's side less ``ln(1 / context)``,
and its ``FEATURES`` penultimate features (output "feat", what a venue head reads).
It runs through OpenCV's ``dnn`` (``readNetFromONNX`` of the bytes the caller read), one
batch per image; OpenCV's convolutions split the work over output pixels, never a sum, so
the scores are the same bits whatever the thread count.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from estimator.detection.real.colour import ColourTables, ball_map, field_map, to_ycrcb
from estimator.errors import DetectionError

__all__ = ["CHANNELS", "FEATURES", "SPEC", "BallCheck", "CheckInput", "CheckSpec",
           "crop_input", "cut_patches", "field_share", "patch_channels"]

CHANNELS = 5
FEATURES = 32

Square = tuple[float, float, float]
"""(cx, cy, side) of a crop in full-resolution pixels."""


@dataclass(frozen=True)
class CheckSpec:
    """How the check's network sees a candidate (fixed by the network it was trained as)."""

    crop_px: int = 24
    context: float = 2.0
    """Crop side over the candidate's diameter."""
    min_side_px: float = 16.0
    wide_px: int = 0
    """Side of the wide crop in pixels (0: none)."""
    wide_context: float = 6.0
    """Wide crop side over the candidate's diameter."""
    context_features: int = 3

    def square(self, cx: float, cy: float, diameter: float) -> Square:
        return cx, cy, max(self.min_side_px, self.context * diameter)


SPEC = CheckSpec()
"""The shipped network's view."""


@dataclass(frozen=True)
class CheckInput:
    """The network's image inputs for N candidates."""

    crops: npt.NDArray[np.float32]
    """N x 5 x crop_px x crop_px."""
    wide: npt.NDArray[np.float32] | None
    """N x 5 x wide_px x wide_px, or None."""


def _cut(image: npt.NDArray[np.uint8], cx: float, cy: float, side: float, px: int
         ) -> npt.NDArray[np.uint8]:
    """The square [cx - side / 2, cx + side / 2) x ... resized to px, border repeated."""
    height, width = image.shape[:2]
    half = side / 2.0
    x0, y0 = math.floor(cx - half), math.floor(cy - half)
    x1, y1 = x0 + max(1, round(side)), y0 + max(1, round(side))
    inner = image[max(y0, 0):min(y1, height), max(x0, 0):min(x1, width)]
    if inner.size == 0:
        inner = image[min(max(y0, 0), height - 1):, min(max(x0, 0), width - 1):][:1, :1]
    pads = (max(0, -y0), max(0, y1 - height), max(0, -x0), max(0, x1 - width))
    if any(pads):
        inner = np.asarray(cv2.copyMakeBorder(inner, *pads, cv2.BORDER_REPLICATE), np.uint8)
    return np.asarray(cv2.resize(inner, (px, px), interpolation=cv2.INTER_AREA), np.uint8)


def cut_patches(image: npt.NDArray[np.uint8], squares: Sequence[Square], px: int
                ) -> npt.NDArray[np.uint8]:
    """The squares resized to px: N x px x px x 3 BGR bytes."""
    if not squares:
        return np.zeros((0, px, px, 3), np.uint8)
    return np.stack([_cut(image, cx, cy, side, px) for cx, cy, side in squares])


def patch_channels(patches: npt.NDArray[np.uint8], tables: ColourTables
                   ) -> npt.NDArray[np.float32]:
    """N x 5 x px x px float32 of N x px x px x 3 patches. The patches are stacked into one
    column image so their colour maps take one pass."""
    n, px = patches.shape[0], patches.shape[1]
    out = np.empty((n, CHANNELS, px, px), np.float32)
    if n == 0:
        return out
    column = patches.reshape(n * px, px, 3)
    ycrcb = to_ycrcb(column)
    out[:, :3] = patches.transpose(0, 3, 1, 2)
    out[:, 3] = ball_map(ycrcb, tables).reshape(n, px, px)
    out[:, 4] = field_map(ycrcb, tables).reshape(n, px, px) * 255
    out *= np.float32(1.0 / 255.0)
    return out


def crop_input(image: npt.NDArray[np.uint8], squares: Sequence[Square], tables: ColourTables,
               spec: CheckSpec = SPEC) -> CheckInput:
    """The network's image inputs for crops (cx, cy, side)."""
    crops = patch_channels(cut_patches(image, squares, spec.crop_px), tables)
    wide = None
    if spec.wide_px > 0:
        k = spec.wide_context / spec.context
        wide = patch_channels(cut_patches(image, [(cx, cy, side * k) for cx, cy, side in squares],
                                          spec.wide_px), tables)
    return CheckInput(crops, wide)


class BallCheck:
    """The trained network, loaded from its ONNX bytes."""

    def __init__(self, onnx_bytes: bytes, spec: CheckSpec = SPEC) -> None:
        self.spec = spec
        try:
            self._net = cv2.dnn.readNetFromONNX(np.frombuffer(onnx_bytes, np.uint8))
        except cv2.error as err:
            raise DetectionError(f"the ball check's ONNX model does not load: {err}") from err

    def raw(self, batch: CheckInput, context: npt.NDArray[np.float64]
            ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """The network's outputs for crops and their N x k context features
        (:func:`head.context`): N x 4 (ball logit, dx, dy, log size) and its N x 32
        features (what a venue's own head, :mod:`head`, reads)."""
        n = len(batch.crops)
        if n == 0:
            return np.zeros((0, 4)), np.zeros((0, FEATURES))
        self._net.setInput(batch.crops, "crops")
        if batch.wide is not None:
            self._net.setInput(batch.wide, "wide")
        self._net.setInput(np.ascontiguousarray(context, np.float32), "context")
        out, feat = self._net.forward(["out", "feat"])
        return (np.asarray(out, np.float64).reshape(n, 4),
                np.asarray(feat, np.float64).reshape(n, FEATURES))

    def __call__(self, batch: CheckInput, context: npt.NDArray[np.float64]
                 ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """N x 4: the logit of P(ball), dx, dy (the ball's centre from the crop's, in crop
        sides) and the ball's diameter in crop sides; and the N x 32 features."""
        raw, feat = self.raw(batch, context)
        out = raw.copy()
        out[:, 3] = np.exp(raw[:, 3]) / self.spec.context
        return out, feat


def field_share(crops: npt.NDArray[np.float32]) -> npt.NDArray[np.float64]:
    """Per crop, the share of field-green pixels in its outer ring (a quarter of the side
    on each edge: outside the blob, which fills the middle half)."""
    px = crops.shape[2]
    edge = px // 4
    ring = np.ones(crops.shape[2:], bool)
    ring[edge:-edge, edge:-edge] = False
    return np.asarray(crops[:, 4][:, ring].mean(axis=1), np.float64)
