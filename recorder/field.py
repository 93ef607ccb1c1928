"""Field dimensions and the carpet texture (no pybullet: scenarios and replay may use them)."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from dsp.errors import UsageError

__all__ = ["FIELDS", "LINE_WIDTH_M", "FieldSpec", "field_spec", "field_texture"]

CARPET_RGB = (30, 125, 45)
LINE_RGB = (245, 245, 245)
LINE_WIDTH_M = 0.125
TEXTURE_PX_PER_M = 100


@dataclass(frozen=True)
class FieldSpec:
    """Field dimensions in metres (lines' centres; origin at the centre, x to the opponent)."""

    name: str
    length_m: float
    width_m: float
    goal_area_depth_m: float
    goal_area_half_width_m: float
    penalty_area_depth_m: float
    penalty_area_half_width_m: float
    centre_circle_radius_m: float = 2.0
    border_m: float = 1.5
    goal_half_width_m: float = 1.0
    goal_height_m: float = 1.0
    goal_depth_m: float = 0.6

    @property
    def half_length_m(self) -> float:
        return self.length_m / 2.0

    @property
    def half_width_m(self) -> float:
        return self.width_m / 2.0


FIELDS: dict[str, FieldSpec] = {
    # The paper's (older MSL) field: goals at x = +-9. Area sizes as the older MSL rules.
    "18x12": FieldSpec("18x12", 18.0, 12.0, 0.75, 1.75, 2.25, 3.25),
    # simatch's current field (NOTES.md): goal area x = +-10.25 / y = +-1.95,
    # penalty area x = +-8.75 / y = +-3.45.
    "22x14": FieldSpec("22x14", 22.0, 14.0, 0.75, 1.95, 2.25, 3.45),
}


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

    thick = max(1, round(LINE_WIDTH_M * px_per_m))
    col = LINE_RGB[::-1]

    def rect(x0: float, y0: float, x1: float, y1: float) -> None:
        cv2.rectangle(img, pt(x0, y0), pt(x1, y1), col, thick, cv2.LINE_AA, shift)

    hl, hw = spec.half_length_m, spec.half_width_m
    rect(-hl, -hw, hl, hw)
    cv2.line(img, pt(0, -hw), pt(0, hw), col, thick, cv2.LINE_AA, shift)
    cv2.circle(img, pt(0, 0), round(spec.centre_circle_radius_m * scale), col, thick,
               cv2.LINE_AA, shift)
    cv2.circle(img, pt(0, 0), round(0.1 * scale), col, -1, cv2.LINE_AA, shift)
    for s in (-1.0, 1.0):
        rect(s * hl, -spec.penalty_area_half_width_m, s * (hl - spec.penalty_area_depth_m),
             spec.penalty_area_half_width_m)
        rect(s * hl, -spec.goal_area_half_width_m, s * (hl - spec.goal_area_depth_m),
             spec.goal_area_half_width_m)
        cv2.circle(img, pt(s * (hl - 3.0), 0), round(0.1 * scale), col, -1, cv2.LINE_AA, shift)
    return img


