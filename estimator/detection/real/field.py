"""Where the field is in a camera image: under the upper edge of its green's convex hull.

A ball on the ground lies on the field's green; the look-alikes that matter most at the
newest events (spectators' tables, bins, clothing, advertising boards, lamps) stand above
the field's far edge. The field is found at a reduced resolution (each map pixel the area
mean of ``step`` x ``step`` pixels, ``INTER_AREA``; 76 x 100 map pixels of a 608 x 800
image at the default 8): each pixel the venue model's field green or not
(:func:`colour.field_map`, the model's (Cr, Cb) mask less its near-grey bins,
``GREY_CR``), closed over ``CLOSE_PX`` map pixels so the field's white lines and the robots
and people on it do not split it; the largest 8-connected component's convex hull is the
field, and its upper edge (per map column, the hull's top row) is the field's far edge.
A hull of less than ``MIN_SHARE`` of the image (a camera looking at the roof, a frame with
no field colour) is no field: every point is on it.

A forward-looking camera sees the field below the horizon and, below the field, only its
own robot and its lens's dark rim: a ball there is at the robot's feet, so only the far
edge counts. :func:`beyond` gives how far a point lies above it (0 on or below; a column
beside the hull takes its nearest column's edge). The detector asks it of each candidate's
lowest point (its box's bottom centre), where a ball on the ground touches the field: a
ball in the air can be above the edge too, so a candidate there needs more evidence,
never none (:class:`OffField`, :mod:`detector`). An omnidirectional frame's field
surrounds the robot; :func:`detector.search_for` leaves the rule off for one.

Pure: an image and the venue's tables in, an edge out; about 0.8 ms on a 608 x 800 image
(half of it the reduction).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
import numpy.typing as npt

from estimator.detection.real.colour import ColourTables, field_map, to_ycrcb
from estimator.detection.real.model import FIELD_BINS

__all__ = ["CLOSE_PX", "GREY_CR", "MIN_SHARE", "OFF_FIELD", "STEP", "Field", "OffField",
           "beyond", "find_field"]

STEP = 8
"""Full-resolution pixels per map pixel of the field search."""
CLOSE_PX = 5
"""Side of the closing's square (map pixels): bridges lines and legs up to 40 px wide."""
GREY_CR = 120
"""Field-mask bins from this Cr up are left out of the field search: a fitted mask holds
every colour of the image's lower part (the lens's dark rim, robots, greys), and a grey
roof or wall of one would join the field; the field's own green is under Cr 120 at every
event of the shared images (its median 85-118), a roof's and a wall's at 124-132."""
MIN_SHARE = 0.05
"""The least share of the image a field hull covers (less: no field found)."""


@dataclass(frozen=True)
class Field:
    """The field's far edge: per map column, the full-resolution row of the hull's top
    (an empty array: no field found)."""

    top: npt.NDArray[np.float64] = field(compare=False, repr=False)
    step: int = STEP
    share: float = 0.0
    """The share of the image the hull covers (0 without one)."""


def _green(tables: ColourTables) -> ColourTables:
    """The tables with the field mask's near-grey bins (Cr >= ``GREY_CR``) left out."""
    mask = tables.field.reshape(FIELD_BINS).copy()
    mask[GREY_CR // 8:] = 0
    return ColourTables(tables.ball, np.ascontiguousarray(mask.ravel()))


def find_field(image: npt.NDArray[np.uint8], tables: ColourTables, step: int = STEP) -> Field:
    """The field of a BGR image by the venue's field green (see the module docstring)."""
    height, width = image.shape[:2]
    cols, rows = max(1, width // step), max(1, height // step)
    small = np.asarray(cv2.resize(image[:rows * step, :cols * step], (cols, rows),
                                  interpolation=cv2.INTER_AREA), np.uint8)
    green = field_map(to_ycrcb(small), _green(tables))
    kernel = np.ones((CLOSE_PX, CLOSE_PX), np.uint8)
    green = np.asarray(cv2.morphologyEx(green, cv2.MORPH_CLOSE, kernel), np.uint8)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(green, connectivity=8,
                                                           ltype=cv2.CV_32S)
    none = Field(np.zeros(0), step)
    if n <= 1:
        return none
    best = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    hull = cv2.convexHull(cv2.findNonZero((labels == best).astype(np.uint8)))
    filled = np.zeros((rows, cols), np.uint8)
    cv2.fillConvexPoly(filled, hull, 1)
    area = int(np.count_nonzero(filled))
    if area < MIN_SHARE * rows * cols:
        return none
    xs = np.flatnonzero(filled.any(axis=0))
    top = np.argmax(filled[:, xs], axis=0).astype(np.float64)
    # map row i covers full-resolution rows [step i, step (i + 1)): its top; a column
    # beside the hull (a convex hull's columns are one run) takes its nearest column's
    return Field(np.interp(np.arange(cols), xs, top) * step, step, area / float(rows * cols))


def beyond(found: Field, points: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """How far each of N points (x, y) lies above the field's far edge [px]; 0 on or
    below it, or everywhere when no field was found."""
    if len(found.top) == 0 or len(points) == 0:
        return np.zeros(len(points))
    col = np.clip((points[:, 0] // found.step).astype(np.int64), 0, len(found.top) - 1)
    return np.asarray(np.maximum(found.top[col] - points[:, 1], 0.0), np.float64)


@dataclass(frozen=True)
class OffField:
    """How much more evidence a candidate above the field needs. One whose lowest point
    lies ``b`` px above the field's far edge, more than ``sides`` times its own larger side
    ``d``, has its venue logit lowered by ``weight * ln(b / (sides * d))``: at ``weight``
    1, a candidate k times that far up needs k times the odds to be reported (and to win
    over one on the field). ``weight`` 0: the rule is off."""

    sides: float = 1.0
    weight: float = 1.0

    def is_off(self, beyond_px: npt.NDArray[np.float64], side_px: npt.NDArray[np.float64]
               ) -> npt.NDArray[np.bool_]:
        """Per candidate (or labelled ball), whether it lies beyond the field."""
        return np.asarray(beyond_px > self.sides * np.maximum(side_px, 1.0), np.bool_)

    def penalty(self, beyond_px: npt.NDArray[np.float64], side_px: npt.NDArray[np.float64]
                ) -> npt.NDArray[np.float64]:
        """Per candidate, what its logit loses for where it lies."""
        scale = self.sides * np.maximum(side_px, 1.0)
        ratio = np.maximum(beyond_px, scale) / scale
        return np.asarray(self.weight * np.log(ratio), np.float64)


OFF_FIELD = OffField()
"""The rule the detector applies: a candidate more than its own size above the field's
far edge needs the odds multiplied by how many times that far up it is. Chosen held out
by event (docs/detection-events.md): for each of the eight events of the shared images,
the rule of the best F1 summed over ten frames and none on the seven other events, among
``sides`` 0.5, 1, 2 and 4 and ``weight`` 0.25, 0.5, 0.75, 1, 1.5, 2 and 3: (1, 1) for five
events, (1, 0.75) for two, (4, 2) for one; (1, 1) on all eight."""
