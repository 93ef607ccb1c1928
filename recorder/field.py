"""The carpet texture, drawn from the field geometry of :mod:`dsp.field` (no pybullet here:
scenarios may use it)."""

from __future__ import annotations

import cv2
import numpy as np

from dsp.errors import UsageError
from dsp.field import FIELDS, Circle, FieldSpec, Rect, markings

__all__ = ["FIELDS", "LINE_WIDTH_M", "FieldSpec", "field_spec", "field_texture"]

CARPET_RGB = (30, 125, 45)
LINE_RGB = (245, 245, 245)
LINE_WIDTH_M = FIELDS["18x12"].line_width_m
"""The lines' width on every field (:attr:`dsp.field.FieldSpec.line_width_m`)."""
TEXTURE_PX_PER_M = 100


def field_spec(name: str) -> FieldSpec:
    try:
        return FIELDS[name]
    except KeyError:
        raise UsageError(f"unknown field {name!r}; choose one of {', '.join(FIELDS)}") from None


def field_texture(spec: FieldSpec, px_per_m: int = TEXTURE_PX_PER_M) -> np.ndarray:
    """Top view of the carpet with its lines, BGR; row 0 = +y edge, column 0 = -x edge."""
    full_l = spec.length_m + 2 * spec.border_m
    full_w = spec.width_m + 2 * spec.border_m
    w_px, h_px = round(full_l * px_per_m), round(full_w * px_per_m)
    img = np.empty((h_px, w_px, 3), np.uint8)
    img[:] = CARPET_RGB[::-1]
    shift = 4  # sub-pixel precision for cv2 drawing
    scale = px_per_m * (1 << shift)

    def pt(x: float, y: float) -> tuple[int, int]:
        return (
            round((x + full_l / 2) * scale - 0.5 * (1 << shift)),
            round((full_w / 2 - y) * scale - 0.5 * (1 << shift)),
        )

    thick = max(1, round(spec.line_width_m * px_per_m))
    col = LINE_RGB[::-1]
    for m in markings(spec):
        if isinstance(m, Rect):
            cv2.rectangle(img, pt(m.x0, m.y0), pt(m.x1, m.y1), col, thick, cv2.LINE_AA, shift)
        elif isinstance(m, Circle):
            cv2.circle(img, pt(m.x, m.y), round(m.radius_m * scale), col,
                       -1 if m.filled else thick, cv2.LINE_AA, shift)
        else:
            cv2.line(img, pt(m.x0, m.y0), pt(m.x1, m.y1), col, thick, cv2.LINE_AA, shift)
    return img
