"""The field's white lines as geometry the pose fit measures against.

A :class:`FieldLines` holds the markings' centre lines in the field frame (metres; origin at
the centre, x towards the opponent goal, y left): straight segments, circles drawn as lines
and filled marks (the centre and penalty spots). It knows nothing of where the numbers come
from; the caller builds it from its field description (a rectangle is four segments).

Distance. For a field point p the model gives the distance to the nearest centre line and
the unit vector n pointing from that line towards p (the gradient of the distance)::

    segment a-b:  t = clip((p - a).(b - a) / |b - a|^2, 0, 1),  d = |p - (a + t (b - a))|
    circle c, r:  d = | |p - c| - r |
    mark c, r:    d = max(|p - c| - r, 0)      (a filled disc: its inside is white)

:meth:`FieldLines.distance` evaluates this exactly; :class:`DistanceGrid` samples it once on
a grid and reads it back by bilinear interpolation (``cv2.remap``), the usual fast way of a
distance-transform (chamfer) fit: the same numbers to a fraction of the grid step, at a
cost that does not grow with the number of markings.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from estimator.errors import LocalisationError

__all__ = ["DistanceGrid", "FieldLines"]

FloatArray = NDArray[np.float64]
_MAP_COLS = 256
_BLOCK_ROWS = 64


def _rows(values: Iterable[tuple[float, ...]], width: int) -> FloatArray:
    out = np.asarray(list(values), dtype=np.float64).reshape(-1, width)
    if not np.all(np.isfinite(out)):
        raise LocalisationError("field line coordinates must be finite")
    return out


@dataclass(frozen=True, eq=False)
class FieldLines:
    """Centre lines of the field's markings and the field's outer lines' extent [m]."""

    segments: FloatArray
    """(n, 4): x0, y0, x1, y1 of each straight line."""
    circles: FloatArray
    """(m, 3): x, y, radius of each circle drawn as a line."""
    marks: FloatArray
    """(k, 3): x, y, radius of each filled mark."""
    half_length_m: float
    """Half the distance between the goal lines' centres."""
    half_width_m: float
    """Half the distance between the touch lines' centres."""
    line_width_m: float = 0.125

    @classmethod
    def from_shapes(cls, *, half_length_m: float, half_width_m: float,
                    rects: Iterable[tuple[float, float, float, float]] = (),
                    segments: Iterable[tuple[float, float, float, float]] = (),
                    circles: Iterable[tuple[float, float, float]] = (),
                    marks: Iterable[tuple[float, float, float]] = (),
                    line_width_m: float = 0.125) -> FieldLines:
        """The model of rectangles' outlines (corners x0, y0, x1, y1), segments, circles
        and filled marks (x, y, radius)."""
        segs = [tuple(s) for s in segments]
        for x0, y0, x1, y1 in rects:
            segs += [(x0, y0, x1, y0), (x1, y0, x1, y1), (x1, y1, x0, y1), (x0, y1, x0, y0)]
        if not (half_length_m > 0 and half_width_m > 0 and line_width_m > 0):
            raise LocalisationError(
                "the field's half length, half width and line width must be > 0")
        return cls(_rows(segs, 4), _rows(circles, 3), _rows(marks, 3),
                   float(half_length_m), float(half_width_m), float(line_width_m))

    def inside(self, xy: FloatArray, margin_m: float) -> NDArray[np.bool_]:
        """Whether each field point (N, 2) lies within the outer lines grown by ``margin_m``."""
        return ((np.abs(xy[:, 0]) <= self.half_length_m + margin_m)
                & (np.abs(xy[:, 1]) <= self.half_width_m + margin_m))

    def offset(self, xy: FloatArray) -> FloatArray:
        """The vector (N, 2) [m] from the nearest point of the nearest centre line to each
        field point (N, 2); (0, 0) on a line or inside a mark. Ties: the first marking."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        px, py = p[:, 0], p[:, 1]
        best = np.full(len(p), np.inf)  # squared distance so far
        out = np.zeros_like(p)
        for x0, y0, x1, y1 in self.segments:
            ax, ay = x1 - x0, y1 - y0
            t = np.clip(((px - x0) * ax + (py - y0) * ay) / max(ax * ax + ay * ay, 1e-12),
                        0.0, 1.0)
            _keep_nearer(best, out, px - (x0 + t * ax), py - (y0 + t * ay))
        for shapes, filled in ((self.circles, False), (self.marks, True)):
            for cx, cy, r in shapes:
                vx, vy = px - cx, py - cy
                rho = np.maximum(np.hypot(vx, vy), 1e-12)
                scale = 1.0 - r / rho  # from the circle's nearest point
                if filled:
                    scale = np.maximum(scale, 0.0)  # inside the mark: on it
                _keep_nearer(best, out, vx * scale, vy * scale)
        return out

    def distance(self, xy: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Distance [m] of each field point (N, 2) to the nearest centre line, and the unit
        vector (N, 2) from that line towards the point (the distance's gradient; (0, 0) on
        a line or inside a mark)."""
        v = self.offset(xy)
        d = np.hypot(v[:, 0], v[:, 1])
        return d, v / np.maximum(d, 1e-12)[:, None]


def _keep_nearer(best: FloatArray, out: FloatArray, vx: FloatArray, vy: FloatArray) -> None:
    """Where (vx, vy) is shorter than ``best`` (squared lengths), take it into ``out``."""
    d2 = vx * vx + vy * vy
    nearer = d2 < best
    best[nearer] = d2[nearer]
    out[nearer, 0] = vx[nearer]
    out[nearer, 1] = vy[nearer]


@dataclass(frozen=True, eq=False)
class DistanceGrid:
    """:meth:`FieldLines.distance` sampled on a grid over the field and its surround, read
    back by bilinear interpolation (``cv2.remap``).

    The grid holds the vector from the nearest line to each cell centre, not the distance:
    near a straight line that vector is linear in the position, so bilinear interpolation
    gives it exactly (a distance, V-shaped across the line, would be rounded off at its
    bottom, where the fit looks). Points off the grid read ``outside_m`` and no direction.
    """

    offset_m: NDArray[np.float32]
    """(rows, cols, 2): row i at y = y0_m + i step_m, column j at x = x0_m + j step_m."""
    x0_m: float
    y0_m: float
    step_m: float
    outside_m: float = 1.0

    @classmethod
    def build(cls, lines: FieldLines, *, step_m: float = 0.02, margin_m: float = 2.0,
              outside_m: float = 1.0) -> DistanceGrid:
        """Sample ``lines`` every ``step_m`` over the field grown by ``margin_m``."""
        if not step_m > 0:
            raise LocalisationError(f"grid step must be > 0, got {step_m}")
        x0, y0 = -lines.half_length_m - margin_m, -lines.half_width_m - margin_m
        cols = math.ceil(2 * (lines.half_length_m + margin_m) / step_m) + 1
        rows = math.ceil(2 * (lines.half_width_m + margin_m) / step_m) + 1
        xs = x0 + step_m * np.arange(cols)
        offset = np.empty((rows, cols, 2), np.float32)
        for i in range(0, rows, _BLOCK_ROWS):  # a block of rows at a time: bounded memory
            ys = y0 + step_m * np.arange(i, min(i + _BLOCK_ROWS, rows))
            xy = np.stack(np.broadcast_arrays(xs[None, :], ys[:, None]), axis=-1)
            offset[i:i + len(ys)] = lines.offset(xy.reshape(-1, 2)).reshape(len(ys), cols, 2)
        return cls(offset, x0, y0, step_m, outside_m)

    def distance(self, xy: FloatArray) -> tuple[FloatArray, FloatArray]:
        """As :meth:`FieldLines.distance`, interpolated from the grid."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        n_points = len(p)
        # rows of _MAP_COLS points: remap's maps stay well under OpenCV's 32767 columns
        size = -(-n_points // _MAP_COLS) * _MAP_COLS
        mx, my = np.full(size, -1e4, np.float32), np.full(size, -1e4, np.float32)
        mx[:n_points] = (p[:, 0] - self.x0_m) / self.step_m
        my[:n_points] = (p[:, 1] - self.y0_m) / self.step_m
        read = cv2.remap(self.offset_m, mx.reshape(-1, _MAP_COLS), my.reshape(-1, _MAP_COLS),
                         cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                         borderValue=(np.nan, np.nan))
        v = np.asarray(read, dtype=np.float64).reshape(-1, 2)[:n_points]
        off = np.isnan(v[:, 0])
        v[off] = 0.0
        d = np.sqrt(np.einsum("ij,ij->i", v, v))
        n = v / np.maximum(d, 1e-9)[:, None]
        d[off] = self.outside_m
        return d, n
