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
MAP_COLS = 256
"""Points per row of the remap tables that read the grid (well under OpenCV's 32767)."""
_BLOCK_CELLS = 32
"""The side of the grid's blocks, in cells, each measured against its nearby markings."""
_CHUNK_CELLS = 1 << 18


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

    @property
    def count(self) -> int:
        """How many markings: segments, then circles, then marks (:meth:`offset`'s order)."""
        return len(self.segments) + len(self.circles) + len(self.marks)

    def _vectors(self, px: FloatArray, py: FloatArray,
                 which: Iterable[int] | None = None) -> Iterable[tuple[FloatArray, FloatArray]]:
        """The vector from each marking of ``which`` (indices in :attr:`count`'s order, in
        that order; None: all) to each point (px, py)."""
        n_seg, n_circ = len(self.segments), len(self.circles)
        for k in range(self.count) if which is None else which:
            if k < n_seg:
                x0, y0, x1, y1 = self.segments[k]
                ax, ay = x1 - x0, y1 - y0
                t = np.clip(((px - x0) * ax + (py - y0) * ay) / max(ax * ax + ay * ay, 1e-12),
                            0.0, 1.0)
                yield px - (x0 + t * ax), py - (y0 + t * ay)
                continue
            filled = k >= n_seg + n_circ
            cx, cy, r = (self.marks[k - n_seg - n_circ] if filled
                         else self.circles[k - n_seg])
            vx, vy = px - cx, py - cy
            rho = np.maximum(np.hypot(vx, vy), 1e-12)
            scale = 1.0 - r / rho  # from the circle's nearest point
            if filled:
                scale = np.maximum(scale, 0.0)  # inside the mark: on it
            yield vx * scale, vy * scale

    def offset(self, xy: FloatArray, which: Iterable[int] | None = None) -> FloatArray:
        """The vector (N, 2) [m] from the nearest point of the nearest centre line to each
        field point (N, 2); (0, 0) on a line or inside a mark. Ties: the first marking.
        ``which``: only these markings (indices, in order; None: all)."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        px, py = p[:, 0], p[:, 1]
        best = np.full(len(p), np.inf)  # squared distance so far
        out = np.zeros_like(p)
        for vx, vy in self._vectors(px, py, which):
            _keep_nearer(best, out, vx, vy)
        return out

    def distances(self, xy: FloatArray) -> FloatArray:
        """(count, N): the distance [m] of each field point (N, 2) to each marking."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        rows = [np.hypot(vx, vy) for vx, vy in self._vectors(p[:, 0], p[:, 1])]
        return np.array(rows).reshape(self.count, len(p))

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
        offset = np.empty((rows, cols, 2), np.float32)
        # Each block of _BLOCK_CELLS x _BLOCK_CELLS cells is measured against the markings
        # that can be nearest to one of its cells: a marking farther from the block's centre
        # c than the nearest one by more than twice the block's half-diagonal h is farther
        # from every cell p of it (d(p, m) >= d(c, m) - h > best(c) + h >= best(p)), so it
        # can neither be nearest nor tie. The same numbers as all markings everywhere, at a
        # fraction of the cost (a grid is built at every replay that fits the lines).
        k = _BLOCK_CELLS
        nbi, nbj = -(-rows // k), -(-cols // k)
        half = (k - 1) / 2 * step_m
        cy = y0 + step_m * (k * np.arange(nbi) + (k - 1) / 2)
        cx = x0 + step_m * (k * np.arange(nbj) + (k - 1) / 2)
        centres = np.stack(np.broadcast_arrays(cx[None, :], cy[:, None]), axis=-1)
        d = lines.distances(centres.reshape(-1, 2))  # (markings, blocks)
        near = d <= d.min(axis=0) + 2 * math.sqrt(2) * half + 1e-9
        keys, group = np.unique(near.T, axis=0, return_inverse=True)  # blocks alike
        cell_group = group.reshape(nbi, nbj).repeat(k, 0).repeat(k, 1)[:rows, :cols].ravel()
        order = np.argsort(cell_group, kind="stable")
        bounds = np.searchsorted(cell_group[order], np.arange(len(keys) + 1))
        flat = offset.reshape(-1, 2)
        for g, key in enumerate(keys):
            for a in range(bounds[g], bounds[g + 1], _CHUNK_CELLS):  # bounded memory
                cells = order[a:min(a + _CHUNK_CELLS, bounds[g + 1])]
                xy = np.column_stack([x0 + step_m * (cells % cols), y0 + step_m * (cells // cols)])
                flat[cells] = lines.offset(xy, np.flatnonzero(key).tolist())
        return cls(offset, x0, y0, step_m, outside_m)

    def distance(self, xy: FloatArray) -> tuple[FloatArray, FloatArray]:
        """As :meth:`FieldLines.distance`, interpolated from the grid."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        n_points = len(p)
        # rows of MAP_COLS points: remap's maps stay well under OpenCV's 32767 columns
        size = -(-n_points // MAP_COLS) * MAP_COLS
        mx, my = np.full(size, -1e4, np.float32), np.full(size, -1e4, np.float32)
        mx[:n_points] = (p[:, 0] - self.x0_m) / self.step_m
        my[:n_points] = (p[:, 1] - self.y0_m) / self.step_m
        read = cv2.remap(self.offset_m, mx.reshape(-1, MAP_COLS), my.reshape(-1, MAP_COLS),
                         cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                         borderValue=(np.nan, np.nan))
        v = np.asarray(read, dtype=np.float64).reshape(-1, 2)[:n_points]
        off = np.isnan(v[:, 0])
        v[off] = 0.0
        d = np.sqrt(np.einsum("ij,ij->i", v, v))
        n = v / np.maximum(d, 1e-9)[:, None]
        d[off] = self.outside_m
        return d, n
