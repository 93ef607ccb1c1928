"""Negatives cut from beyond the field's far edge (``train.py --edge-negatives N``).

The false hits of the held-out checks at the newest events are look-alikes above the
field's far edge (spectators' tables, bins, clothing), and the labelled set holds few
negative crops with little field (about 470 of 53,000; none at Bordeaux): the detector asks
the check about the ``MAX_CANDIDATES`` most ball-coloured blobs of an image, and above the
field they are few. So while an event's samples are built (``dataset.build_items``), each
of its images also gives up to ``count`` negatives beyond the field: first the candidates
the finder proposes there (the venue model's, then the generic model's, up to ``POOL`` of
each, most ball-coloured first, none already among the image's samples), then, for the
rest, squares at random places there, at the sizes of the image's labelled balls (the
event's when it has none; ``--edge-candidates-only``: none). Beyond the field is the
detector's own rule (:data:`estimator.detection.real.field.OFF_FIELD`, the field found with
the venue model's tables): the blob's lowest point more than its own size above the far
edge (``sides`` 1; with ``--edge-sides 0``, above it at all: the boards and tables standing
at the edge too); an image with no field found gives none. Each lies away from every
labelled ball: its centre at least half its crop's side and ``SAFE_RADII`` ball radii from
the ball's centre, so no crop shows a labelled ball. Seeded (its own generator, so the
other samples stay as they were); an event's negatives come from its own images only, so a
check held out from it sees none.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from estimator.detection.real.candidates import find_coarse
from estimator.detection.real.check import SPEC
from estimator.detection.real.colour import ColourTables
from estimator.detection.real.field import OFF_FIELD, Field, OffField, beyond, find_field
from estimator.detection.real.model import BallModel

POOL = 200
"""Candidates asked of each model per image (the samples take the first 48 and 24)."""
SAFE_RADII = 3.0
"""Margin between a negative's crop and a labelled ball's centre, in that ball's radii."""
TRIES = 40
"""Random places drawn per random negative wanted before the image gives up."""
Box = tuple[float, float, float, float]
Source = tuple[BallModel, ColourTables]
Edge = tuple[tuple[float, float, float], Box, int]
"""A negative: its square (cx, cy, side), its blob's box (x0, y0, x1, y1), its source's index."""


@dataclass(frozen=True)
class EdgeSpec:
    """What ``train.py --edge-negatives N --edge-sides S [--edge-candidates-only]`` asks."""

    count: int = 0
    """Negatives an image, at most (0: none)."""
    sides: float = OFF_FIELD.sides
    """How far beyond the edge (:func:`is_beyond`)."""
    random: bool = True
    """Random squares where the candidates there are fewer than ``count``."""

    def key(self) -> tuple[float, float, float]:
        """What a sample cache records of it."""
        return (float(self.count), self.sides, float(self.random)) if self.count else (0, 0, 0)


NO_EDGE = EdgeSpec()
"""No negatives beyond the edge (the default)."""


def away(cx: float, cy: float, side: float, balls: Sequence[Box]) -> bool:
    """Whether a square of ``side`` centred at (cx, cy) lies clear of every ball."""
    for x0, y0, x1, y1 in balls:
        r = max(x1 - x0, y1 - y0) / 2.0
        if np.hypot(cx - (x0 + x1) / 2.0, cy - (y0 + y1) / 2.0) < side / 2.0 + SAFE_RADII * r:
            return False
    return True


def is_beyond(found: Field, boxes: np.ndarray, sides: float = OFF_FIELD.sides) -> np.ndarray:
    """Per box (x0, y0, x1, y1), whether its lowest point lies more than ``sides`` times its
    size above the field's far edge (the detector's rule at its default; 0: above it at
    all)."""
    if len(boxes) == 0:
        return np.zeros(0, bool)
    bottoms = np.stack([(boxes[:, 0] + boxes[:, 2]) / 2.0, boxes[:, 3]], axis=1)
    size = np.maximum(boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1])
    return OffField(sides=sides).is_off(beyond(found, bottoms), size)


def candidates_beyond(image: np.ndarray, found: Field, balls: Sequence[Box],
                      sources: Sequence[Source], seen: set[tuple[int, int, int]],
                      count: int, sides: float = OFF_FIELD.sides) -> list[Edge]:
    """Up to ``count`` of the finder's candidates beyond the field, clear of the balls and
    not in ``seen`` (keys (cx, cy, side) rounded; the ones taken are added)."""
    out: list[Edge] = []
    for k, (model, tables) in enumerate(sources):
        found_c = find_coarse(image, tables, model, max_count=POOL)
        boxes = np.array([c.full_box() for c in found_c], np.float64).reshape(-1, 4)
        for c, off in zip(found_c, is_beyond(found, boxes, sides), strict=True):
            if len(out) >= count:
                return out
            cx, cy, side = SPEC.square(*c.centre())
            key = (round(cx), round(cy), round(side))
            if off and key not in seen and away(cx, cy, side, balls):
                seen.add(key)
                x0, y0, x1, y1 = c.full_box()
                out.append(((cx, cy, side), (float(x0), float(y0), float(x1), float(y1)), k))
    return out


def random_beyond(shape: tuple[int, ...], found: Field, balls: Sequence[Box],
                  diameters: Sequence[float], count: int, rng: np.random.Generator,
                  sides: float = OFF_FIELD.sides) -> list[Edge]:
    """Up to ``count`` squares at random places beyond the field, clear of the balls, each
    framing a blob of one of ``diameters`` as the check frames a ball."""
    height, width = shape[:2]
    out: list[Edge] = []
    for _ in range(TRIES * count):
        if len(out) >= count or not diameters:
            break
        d = float(diameters[int(rng.integers(len(diameters)))])
        cx = float(rng.uniform(d / 2.0, width - d / 2.0))
        col = min(int(cx // found.step), len(found.top) - 1)
        # the blob's lowest point more than sides * d above the edge
        cy = float(rng.uniform(d / 2.0, max(d / 2.0, min(height - d / 2.0,
                                                          found.top[col] - (0.5 + sides) * d))))
        box = (cx - d / 2.0, cy - d / 2.0, cx + d / 2.0, cy + d / 2.0)
        square = SPEC.square(cx, cy, d)
        if is_beyond(found, np.array([box]), sides)[0] and away(cx, cy, square[2], balls):
            out.append((square, box, 0))
    return out


def edge_negatives(image: np.ndarray, balls: Sequence[Box], sources: Sequence[Source],
                   seen: set[tuple[int, int, int]], diameters: Sequence[float], spec: EdgeSpec,
                   rng: np.random.Generator) -> list[Edge]:
    """Up to ``spec.count`` negatives beyond the field of one image (the module docstring):
    the candidates of ``sources`` there first (the first source's tables find the field),
    with ``spec.random`` random squares at the image's ball sizes (``diameters`` when it has
    no ball) after; beyond the field by ``spec.sides`` (:func:`is_beyond`)."""
    if spec.count <= 0 or not sources:
        return []
    found = find_field(image, sources[0][1])
    if len(found.top) == 0:
        return []
    out = candidates_beyond(image, found, balls, sources, seen, spec.count, spec.sides)
    if not spec.random:
        return out
    own = [float(max(x1 - x0, y1 - y0)) for x0, y0, x1, y1 in balls]
    return out + random_beyond(image.shape, found, balls, own or list(diameters),
                               spec.count - len(out), rng, spec.sides)
