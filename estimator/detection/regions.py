"""Where to look for the ball: coarse-to-fine regions for :mod:`estimator.detection`.

The ball covers well under 1 % of an omni image, so thresholding, opening and tracing the
whole 1080 x 1080 frame spends nearly all its time on the field. Instead the colour test
runs first on every ``stride``-th row (rows 0, ``stride``, ``2 stride``, ... in full: a
third of the frame's bytes at the default 3, and no more memory traffic than any pixel
subsample of those rows, as a row is read in whole cache lines). Each hit seeds a small
box; each box is thresholded at full resolution and grown until no thresholded pixel lies
within ``band`` pixels of a side that is not the image's border. A grown box therefore
holds whole connected components of the threshold mask with an empty margin around them,
and boxes that meet are merged, so:

- the OPEN of a box equals the OPEN of the whole mask inside it (the margin is at least the
  structuring element's radius), and its blobs, outlines and moments are the same numbers;
- every blob whose threshold mask has a pixel on a sampled row is found: any blob at least
  ``stride`` rows tall, so any anti-aliased ball of radius 2 px or more at the default 3
  (its 10-13 pixel mask spans 3 or 4 rows) wherever it is, the image's border included.

The rows are tested cheaply first when the caller can say which difference of two colour
channels every pixel in its colour range exceeds (:class:`ChannelGap`, e.g. red - blue >=
37 for the orange ball): one saturating subtraction of two byte-shifted views of the rows
(no copy of the pixels), a per-row sum to find the rows that hold candidates, and the exact
colour test on the candidates alone, or, when they all lie within one tile's span (the
usual frame: one ball), on their box, which is thresholded anyway (a box with no pixel
in the colour range is dropped). The blobs found are exactly those of the exact test on
the rows; the shortcut only skips the colour conversion of pixels that cannot pass it.

When the hits or the boxes cover much of the image the caller thresholds the whole image
instead (the same results, just no faster).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

__all__ = ["ChannelGap", "Region", "search_regions"]

Threshold = Callable[[npt.NDArray[np.uint8], tuple[int, int] | None], npt.NDArray[np.uint8]]
"""(pixels, origin) -> their threshold mask; origin (x0, y0): where a ROI of the image
starts, None for sampled pixels (which skip position-dependent masking)."""

MAX_HITS = 6_000
"""More sampled pixels than this pass the colour test: threshold the whole image instead."""
MAX_CANDIDATES = 20_000
"""More candidates than this pass the channel gap: test the sampled rows exactly instead."""
MAX_AREA_FRACTION = 0.25
"""Boxes covering more of the image than this: threshold the whole image instead."""
TILE_ROWS = 8
"""Hits are grouped in square tiles of ``TILE_ROWS * stride`` px, one seed box per tile
(one box for them all when they fit in a tile's span)."""


@dataclass(frozen=True)
class ChannelGap:
    """``pixel[plus] - pixel[minus] >= min_gap`` (BGR channel indices 0-2): a test that
    every pixel in the colour range passes, and most of the field fails."""

    plus: int
    minus: int
    min_gap: int


@dataclass(frozen=True)
class Region:
    """A box of the image, [x0, x1) x [y0, y1), and its full-resolution threshold mask."""

    x0: int
    y0: int
    x1: int
    y1: int
    mask: npt.NDArray[np.uint8]


Box = tuple[int, int, int, int]
Pixels = tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]
"""(rows, columns) of sampled pixels, in image coordinates."""


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


def _nonzero_rows(rows: npt.NDArray[np.uint8], stride: int, width: int) -> Pixels:
    """The non-zero entries of an n x (width * k) byte array whose row i is image row
    ``stride * i`` and whose entry j lies in image column ``j // k``."""
    # row sums in float32 (faster than int32): bytes >= 0 sum to 0 only when all are 0
    hot = cv2.reduce(rows, 1, cv2.REDUCE_SUM, dtype=cv2.CV_32F).ravel().nonzero()[0]
    if len(hot) == 0:
        return hot, hot
    ji = cv2.findNonZero(rows[hot]).reshape(-1, 2).T  # (j, i): entry j of hot row i
    return (stride * hot)[ji[1]], ji[0] // (rows.shape[1] // width)


def _gap_views(image: npt.NDArray[np.uint8], stride: int, gap: ChannelGap
               ) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.uint8], int]:
    """Views of the sampled rows whose channel 0 is ``gap.plus`` and ``gap.minus`` of each
    pixel (no copy), and how many pixels of each row they cover: all of them when every
    sampled row is followed by another row of the same buffer (the last pixel's channels
    1 and 2 then read up to 2 bytes of it), else all but the last."""
    height, width = image.shape[:2]
    n = (height - 1) // stride + 1
    pitch = 3 * width
    if image.flags.c_contiguous and stride * (n - 1) + 1 < height:
        shape, steps = (n, width, 3), (stride * pitch, 3, 1)
        return (np.ndarray(shape, np.uint8, image, gap.plus, steps),
                np.ndarray(shape, np.uint8, image, gap.minus, steps), width)
    flat = image[::stride].reshape(n, pitch)  # a view: each row's bytes are contiguous
    span = 3 * (width - 1)  # shifted views of pixels 0 .. width - 2
    return (flat[:, gap.plus:gap.plus + span].reshape(n, width - 1, 3),
            flat[:, gap.minus:gap.minus + span].reshape(n, width - 1, 3), width - 1)


def _gap_candidates(image: npt.NDArray[np.uint8], stride: int, gap: ChannelGap) -> Pixels:
    """The pixels of the sampled rows that pass ``gap``, row by row, left to right."""
    width = image.shape[1]
    plus, minus, covered = _gap_views(image, stride, gap)
    n = plus.shape[0]
    diff = np.asarray(cv2.subtract(plus, minus), np.uint8)  # channel 0: plus - minus, >= 0
    # channel 0 > 0 where plus - minus >= min_gap; channels 1 and 2 (other bytes) 0
    cv2.subtract(diff, (gap.min_gap - 1, 255, 255, 0), dst=diff)  # type: ignore[call-overload]
    ys, xs = _nonzero_rows(diff.reshape(n, 3 * covered), stride, covered)
    if covered == width:
        return ys, xs
    # the last column, which the shifted views do not reach
    last = image[::stride, width - 1].astype(np.int16)
    tail = np.flatnonzero(last[:, gap.plus] - last[:, gap.minus] >= gap.min_gap)
    if len(tail) == 0:
        return ys, xs
    all_ys = np.concatenate((ys, stride * tail))
    order = np.argsort(all_ys, kind="stable")  # in row order
    return all_ys[order], np.concatenate((xs, np.full(len(tail), width - 1, np.intp)))[order]


def _hits(image: npt.NDArray[np.uint8], threshold: Threshold, stride: int,
          gap: ChannelGap | None) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp], bool]:
    """The pixels of the sampled rows that may pass the colour test, row by row, and
    whether they were tested (False: they passed ``gap`` and are not tested yet)."""
    width = image.shape[1]
    if gap is not None and width > 1:
        ys, xs = _gap_candidates(image, stride, gap)
        if len(ys) <= MAX_CANDIDATES:
            return ys, xs, False
    mask = threshold(image[::stride], None)
    return (*_nonzero_rows(mask, stride, width), True)


def _tested(image: npt.NDArray[np.uint8], threshold: Threshold, ys: npt.NDArray[np.intp],
            xs: npt.NDArray[np.intp]) -> Pixels:
    """The pixels (ys, xs) that pass the colour test."""
    keep = np.flatnonzero(threshold(image[ys, xs][:, None], None)[:, 0])
    return ys[keep], xs[keep]


def _span(ys: npt.NDArray[np.intp], xs: npt.NDArray[np.intp], tile: int) -> Box | None:
    """(x0, y0, x1, y1), inclusive, of pixels whose rows ascend, when they fit within one
    tile's span (None: they do not)."""
    x0, x1 = int(xs.min()), int(xs.max())
    y0, y1 = int(ys[0]), int(ys[-1])
    return (x0, y0, x1, y1) if x1 - x0 < tile and y1 - y0 < tile else None


def _seeds(image: npt.NDArray[np.uint8], threshold: Threshold, stride: int, pad: int,
           gap: ChannelGap | None) -> list[Box] | None:
    """Boxes around the hits, one per tile of them (None: too many hits). Candidates that
    all lie within one tile's span make one box untested: its threshold tests them."""
    height, width = image.shape[:2]
    ys, xs, tested = _hits(image, threshold, stride, gap)
    tile = TILE_ROWS * stride
    one = _span(ys, xs, tile) if len(ys) else None
    if one is None and len(ys) and not tested:  # spread out: test them one by one
        ys, xs = _tested(image, threshold, ys, xs)
        one = _span(ys, xs, tile) if len(ys) else None
    if len(ys) == 0:
        return []
    if one is not None:  # the usual frame: one ball
        spans = [one]
    elif len(ys) > MAX_HITS:
        return None
    else:  # per tile
        key = (ys // tile) * (width // tile + 1) + xs // tile
        order = np.argsort(key, kind="stable")
        key, ys, xs = key[order], ys[order], xs[order]
        starts = np.flatnonzero(np.concatenate(([True], key[1:] != key[:-1])))
        spans = list(zip(np.minimum.reduceat(xs, starts).tolist(),
                         np.minimum.reduceat(ys, starts).tolist(),
                         np.maximum.reduceat(xs, starts).tolist(),
                         np.maximum.reduceat(ys, starts).tolist(), strict=True))
    # the blob may reach into the rows between samples (and bulge sideways there): the
    # hits' bounding box grown by a sample spacing less one, then by pad
    grow = stride - 1 + pad
    return _merge([(max(x0 - grow, 0), max(y0 - grow, 0), min(x1 + 1 + grow, width),
                    min(y1 + 1 + grow, height)) for x0, y0, x1, y1 in spans])


def _grow(box: Box, mask: npt.NDArray[np.uint8], band: int, width: int,
          height: int) -> Box | None:
    """The box grown on each inner side whose ``band`` outermost pixels hold mask pixels
    (None: the mask is empty)."""
    x0, y0, x1, y1 = box
    bx, by, bw, bh = cv2.boundingRect(mask)  # of the mask's pixels; 0 x 0: none
    if bw == 0:
        return None
    step = 4 * band
    if x0 > 0 and bx < band:
        x0 = max(x0 - step, 0)
    if y0 > 0 and by < band:
        y0 = max(y0 - step, 0)
    if x1 < width and bx + bw > mask.shape[1] - band:
        x1 = min(x1 + step, width)
    if y1 < height and by + bh > mask.shape[0] - band:
        y1 = min(y1 + step, height)
    return x0, y0, x1, y1


def search_regions(image: npt.NDArray[np.uint8], threshold: Threshold, *, stride: int,
                   band: int, gap: ChannelGap | None = None) -> list[Region] | None:
    """Disjoint regions holding every mask component with a pixel on a sampled row, each
    with an empty margin of ``band`` px inside its sides that are not the image's border;
    None when searching would not pay (threshold the whole image instead). ``gap``: a
    channel difference every pixel passing ``threshold`` exceeds (a cheap first test)."""
    height, width = image.shape[:2]
    seeds = _seeds(image, threshold, stride, band, gap)
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
        if grown is None:  # candidates that failed the colour test
            continue
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
