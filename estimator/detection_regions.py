"""Where to look for the ball: coarse-to-fine regions for :mod:`estimator.detection`.

The ball covers well under 1 % of an omni image, so thresholding, opening and tracing the
whole 1080 x 1080 frame spends nearly all its time on the field. Instead the colour test
runs first on a subsample of one pixel in ``stride``^2: every ``stride``-th row, and in row
``stride * m`` every ``stride``-th column from column ``m % stride`` (a sheared grid; each
sample is an original pixel, so it passes exactly when the full-resolution test does).
Each hit seeds a small box; each box is thresholded at full resolution and grown until no
thresholded pixel lies within ``band`` pixels of a side that is not the image's border. A
grown box therefore holds whole connected components of the threshold mask with an empty
margin around them, and boxes that meet are merged, so:

- the OPEN of a box equals the OPEN of the whole mask inside it (the margin is at least the
  structuring element's radius), and its blobs, outlines and moments are the same numbers;
- every blob whose threshold mask has a pixel on the sampling grid is found. The grid has a
  pixel in every ``stride`` x ``stride`` square, so a blob whose mask holds such a square
  cannot be missed; the shear also catches the 10-13 pixel mask of an anti-aliased ball of
  radius 2 px at every sub-pixel position, which a square grid of stride 3 misses when the
  ball is centred on a pixel corner in phase with the grid (the mask is 4 x 4 less its
  corners, and holds no 3 x 3 square).

When the hits or the boxes cover much of the image the caller thresholds the whole image
instead (the same results, just no faster).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

__all__ = ["Region", "search_regions"]

Threshold = Callable[[npt.NDArray[np.uint8], tuple[int, int] | None], npt.NDArray[np.uint8]]
"""(pixels, origin) -> their threshold mask; origin (x0, y0): where a ROI of the image
starts, None for the subsample (which skips position-dependent masking)."""

MAX_HITS = 2_000
"""More samples than this pass the colour test: threshold the whole image instead."""
MAX_AREA_FRACTION = 0.25
"""Boxes covering more of the image than this: threshold the whole image instead."""


@dataclass(frozen=True)
class Region:
    """A box of the image, [x0, x1) x [y0, y1), and its full-resolution threshold mask."""

    x0: int
    y0: int
    x1: int
    y1: int
    mask: npt.NDArray[np.uint8]


Box = tuple[int, int, int, int]


def _overlap(a: Box, b: Box) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _union(a: Box, b: Box) -> Box:
    return min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3])


def _merge(boxes: list[Box]) -> list[Box]:
    """Boxes that overlap, merged (repeatedly) into their bounding box; none overlap after."""
    out: list[Box] = []
    for box in boxes:
        merged = True
        while merged:
            merged = False
            for i, other in enumerate(out):
                if _overlap(box, other):
                    box = _union(box, out.pop(i))
                    merged = True
                    break
        out.append(box)
    return out


@functools.lru_cache(maxsize=8)
def _grid(height: int, width: int, stride: int) -> npt.NDArray[np.int16]:
    """The sampling grid as a nearest-neighbour remap table (CV_16SC2): row ``m`` of the
    subsample is image row ``stride * m``, sampled at columns ``m % stride + stride * j``
    (the last column repeated where a row runs out)."""
    rows = np.arange(0, height, stride)
    cols = (rows[:, None] // stride) % stride + stride * np.arange(-(-width // stride))[None, :]
    map_x = np.minimum(cols, width - 1).astype(np.float32)
    map_y = np.broadcast_to(rows[:, None], map_x.shape).astype(np.float32)
    table, _ = cv2.convertMaps(map_x, map_y, cv2.CV_16SC2)
    table.setflags(write=False)
    return np.asarray(table, dtype=np.int16)


def _seeds(image: npt.NDArray[np.uint8], threshold: Threshold, stride: int,
           pad: int) -> list[Box] | None:
    """One box per tile of hits on the sampling grid (None: too many hits)."""
    height, width = image.shape[:2]
    small = cv2.remap(image, _grid(height, width, stride), None,  # type: ignore[call-overload]
                      cv2.INTER_NEAREST)
    coarse = threshold(small, None)
    count = cv2.countNonZero(coarse)
    if count == 0:
        return []
    if count > MAX_HITS:
        return None
    # the hit at subsample (j, i) is the pixel (stride * j + i % stride, stride * i); the
    # box of a tile spans its pixels, a grid cell more and ``pad``
    tile = 8  # hits grouped in tiles of tile x tile grid cells, one seed box per tile
    cells = {(j // tile, i // tile) for j, i in cv2.findNonZero(coarse).reshape(-1, 2).tolist()}
    span = tile * stride
    boxes: list[Box] = []
    for cj, ci in sorted(cells):
        x0, y0 = int(cj) * span - stride - pad, int(ci) * span - stride - pad
        x1, y1 = x0 + span + 2 * (stride + pad), y0 + span + 2 * (stride + pad)
        boxes.append((max(x0, 0), max(y0, 0), min(x1, width), min(y1, height)))
    return _merge(boxes)


def _grow(box: Box, mask: npt.NDArray[np.uint8], band: int, width: int,
          height: int) -> Box:
    """The box grown on each inner side whose ``band`` outermost pixels hold mask pixels."""
    x0, y0, x1, y1 = box
    step = 4 * band
    if x0 > 0 and mask[:, :band].any():
        x0 = max(x0 - step, 0)
    if y0 > 0 and mask[:band].any():
        y0 = max(y0 - step, 0)
    if x1 < width and mask[:, -band:].any():
        x1 = min(x1 + step, width)
    if y1 < height and mask[-band:].any():
        y1 = min(y1 + step, height)
    return x0, y0, x1, y1


def search_regions(image: npt.NDArray[np.uint8], threshold: Threshold, *, stride: int,
                   band: int) -> list[Region] | None:
    """Disjoint regions holding every mask component with a pixel on the sampling grid,
    each with an empty margin of ``band`` px inside its sides that are not the image's
    border; None when searching would not pay (threshold the whole image instead)."""
    height, width = image.shape[:2]
    seeds = _seeds(image, threshold, stride, band)
    if seeds is None:
        return None
    pending = list(seeds)
    done: list[Region] = []
    limit = MAX_AREA_FRACTION * width * height
    while pending:
        box = pending.pop()
        x0, y0, x1, y1 = box
        mask = threshold(image[y0:y1, x0:x1], (x0, y0))
        grown = _grow(box, mask, band, width, height)
        if grown == box:
            done.append(Region(x0, y0, x1, y1, mask))
            continue
        # grown: merge with whatever it now meets, finished or not, and look again
        met = True
        while met:
            met = False
            for i, r in enumerate(done):
                if _overlap(grown, (r.x0, r.y0, r.x1, r.y1)):
                    grown = _union(grown, (r.x0, r.y0, r.x1, r.y1))
                    del done[i]
                    met = True
                    break
            for i, other in enumerate(pending):
                if _overlap(grown, other):
                    grown = _union(grown, pending.pop(i))
                    met = True
                    break
        pending.append(grown)
        area = sum((b[2] - b[0]) * (b[3] - b[1]) for b in pending)
        if area + sum(r.mask.size for r in done) > limit:
            return None
    return done
