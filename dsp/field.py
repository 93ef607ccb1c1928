"""The field's geometry, from one place: the recorder's carpet and replay's field view.

Coordinates in metres on the field frame (origin at the centre, x towards the opponent goal,
y left); lines are given by their centres. Pure Python: no numpy, OpenCV or pybullet.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = [
    "DEFAULT_FIELD",
    "FIELDS",
    "FIELD_ALIASES",
    "Circle",
    "FieldSpec",
    "Marking",
    "Rect",
    "Segment",
    "markings",
    "polylines",
]


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
    penalty_mark_distance_m: float = 3.0
    """From the goal line to the penalty mark."""
    spot_radius_m: float = 0.1
    """Radius of the centre and penalty marks."""
    line_width_m: float = 0.125
    """Width of the painted lines (MSL rules: 0.125 m)."""

    @property
    def half_length_m(self) -> float:
        return self.length_m / 2.0

    @property
    def half_width_m(self) -> float:
        return self.width_m / 2.0


FIELDS: dict[str, FieldSpec] = {
    # The paper's (older MSL) field: goals at x = +-9. Area sizes as the older MSL rules.
    "18x12": FieldSpec("18x12", 18.0, 12.0, 0.75, 1.75, 2.25, 3.25),
    # simatch's current field (docs/method.md): goal area x = +-10.25 / y = +-1.95,
    # penalty area x = +-8.75 / y = +-3.45.
    "22x14": FieldSpec("22x14", 22.0, 14.0, 0.75, 1.95, 2.25, 3.45),
}
"""Every field by name (the recorder's ``--field``; the ``field`` of a log's scenario)."""

DEFAULT_FIELD = "18x12"
"""The paper's field: what a log that names no field is drawn on."""

FIELD_ALIASES: dict[str, str] = {"msl": "22x14"}
"""Other names a camera file may name a field by (``field: msl``): ``msl`` is the current
MSL rules' field, 22x14. A log's scenario metadata names a field of :data:`FIELDS` only."""


@dataclass(frozen=True)
class Rect:
    """A rectangle's outline from corner (x0, y0) to the opposite corner (x1, y1)."""

    x0: float
    y0: float
    x1: float
    y1: float


@dataclass(frozen=True)
class Segment:
    """A straight line from (x0, y0) to (x1, y1)."""

    x0: float
    y0: float
    x1: float
    y1: float


@dataclass(frozen=True)
class Circle:
    """A circle (a line) or, ``filled``, a disc (a mark) centred on (x, y)."""

    x: float
    y: float
    radius_m: float
    filled: bool = False


Marking = Rect | Segment | Circle


def markings(spec: FieldSpec) -> tuple[Marking, ...]:
    """The field's markings in drawing order: outer lines, half-way line, centre circle and
    mark, then per half (-x first) the penalty area, the goal area and the penalty mark."""
    hl, hw = spec.half_length_m, spec.half_width_m
    out: list[Marking] = [
        Rect(-hl, -hw, hl, hw),
        Segment(0, -hw, 0, hw),
        Circle(0, 0, spec.centre_circle_radius_m),
        Circle(0, 0, spec.spot_radius_m, filled=True),
    ]
    for s in (-1.0, 1.0):
        out += [
            Rect(s * hl, -spec.penalty_area_half_width_m, s * (hl - spec.penalty_area_depth_m),
                 spec.penalty_area_half_width_m),
            Rect(s * hl, -spec.goal_area_half_width_m, s * (hl - spec.goal_area_depth_m),
                 spec.goal_area_half_width_m),
            Circle(s * (hl - spec.penalty_mark_distance_m), 0, spec.spot_radius_m, filled=True),
        ]
    return tuple(out)


def polylines(spec: FieldSpec, circle_segments: int = 48) -> list[list[tuple[float, float]]]:
    """The markings as closed or open polylines (circles and marks as ``circle_segments``-gons),
    for viewers that draw line strips."""
    strips: list[list[tuple[float, float]]] = []
    for m in markings(spec):
        if isinstance(m, Rect):
            strips.append([(m.x0, m.y0), (m.x1, m.y0), (m.x1, m.y1), (m.x0, m.y1), (m.x0, m.y0)])
        elif isinstance(m, Segment):
            strips.append([(m.x0, m.y0), (m.x1, m.y1)])
        else:
            n = circle_segments
            strips.append([
                (m.x + m.radius_m * math.cos(2 * math.pi * i / n),
                 m.y + m.radius_m * math.sin(2 * math.pi * i / n))
                for i in range(n + 1)
            ])
    return strips
