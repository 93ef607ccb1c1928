"""Fitting a venue's ball model from a few labelled images (pure: arrays in, model out).

What a team runs at a new venue: a handful of frames with the ball's boxes drawn (YOLO
labels, read by the caller) give

- the colour table: histograms of the ball's pixels (an ellipse inside each box, at 0.8 of
  its half-sides, so the box's corners and most of the background stay out) and of every
  pixel outside the boxes (grown by 3 px), each ball weighted alike (a close ball has a
  hundred times the pixels of a far one) and each image's background alike; both smoothed
  by a Gaussian of ``SMOOTH_BINS`` bins so the colours between the samples' are filled in,
  and turned into the log-likelihood ratio (:mod:`model`). A colour seen in neither
  gets 0 (no evidence);
- the field mask: the (Cr, Cb) bins that hold ``FIELD_SHARE`` of the pixels outside the
  boxes in the image's lower ``FIELD_ROWS`` (the field fills it), grown by one bin;
- the size range: the boxes' sides, widened (a far ball may be smaller, a ball at the
  camera larger than any in the sample).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from estimator.detection.real.colour import to_ycrcb
from estimator.detection.real.model import COLOUR_BINS, FIELD_BINS, OFFSET, SCALE, BallModel
from estimator.errors import BallModelError

__all__ = ["Box", "fit_ball_model"]

Box = tuple[float, float, float, float]
"""(x0, y0, x1, y1) in pixels of the image, x1 and y1 exclusive."""

SMOOTH_BINS = 0.7
FIELD_SHARE = 0.8
FIELD_ROWS = 0.6
_N = math.prod(COLOUR_BINS)
_EPS = 1e-7


def _bins(ycrcb: npt.NDArray[np.uint8]) -> npt.NDArray[np.intp]:
    """Each pixel's colour-table bin, flat."""
    y, cr, cb = (ycrcb[..., i].astype(np.intp) for i in range(3))
    bins = ((y >> 5) * COLOUR_BINS[1] + (cr >> 3)) * COLOUR_BINS[2] + (cb >> 3)
    return np.asarray(bins, np.intp)


def _masks(shape: tuple[int, int], balls: Sequence[Box]
           ) -> tuple[list[npt.NDArray[np.bool_]], npt.NDArray[np.bool_]]:
    """One ellipse mask per ball, and the background (outside every box grown by 3 px)."""
    ellipses = []
    outside = np.ones(shape, np.uint8)
    for x0, y0, x1, y1 in balls:
        mask = np.zeros(shape, np.uint8)
        centre = (round((x0 + x1) / 2.0 * 16), round((y0 + y1) / 2.0 * 16))
        axes = (max(round((x1 - x0) * 0.4 * 16), 8), max(round((y1 - y0) * 0.4 * 16), 8))
        cv2.ellipse(mask, centre, axes, 0, 0, 360, 1, -1, cv2.LINE_8, 4)
        ellipses.append(mask.view(np.bool_))
        cv2.rectangle(outside, (math.floor(x0) - 3, math.floor(y0) - 3),
                      (math.ceil(x1) + 3, math.ceil(y1) + 3), 0, -1)
    return ellipses, outside.view(np.bool_)


def _blur(hist: npt.NDArray[np.float64], sigma: float) -> npt.NDArray[np.float64]:
    """A separable Gaussian blur of a 3-D histogram (zero beyond its edges)."""
    radius = max(1, math.ceil(3 * sigma))
    t = np.arange(-radius, radius + 1, dtype=np.float64)
    kernel = np.exp(-0.5 * (t / sigma) ** 2)
    kernel /= kernel.sum()
    out = hist
    for axis in range(hist.ndim):
        out = np.apply_along_axis(np.convolve, axis, out, kernel, mode="same")
    return out


def _field_mask(field_hist: npt.NDArray[np.float64]) -> npt.NDArray[np.uint8]:
    """The (Cr, Cb) bins holding FIELD_SHARE of the field rows' background, grown by 1."""
    flat = field_hist.ravel()
    order = np.argsort(-flat, kind="stable")
    cumulative = np.cumsum(flat[order])
    count = int(np.searchsorted(cumulative, FIELD_SHARE * cumulative[-1])) + 1
    mask = np.zeros(flat.shape, np.uint8)
    mask[order[:count]] = 1
    return np.asarray(cv2.dilate(mask.reshape(FIELD_BINS), np.ones((3, 3), np.uint8)),
                      np.uint8)


def _accumulate(samples: Iterable[tuple[npt.NDArray[np.uint8], Sequence[Box]]]
                ) -> tuple[npt.NDArray[np.float64], ...]:
    """Ball, background and field-row histograms, and the balls' sides."""
    ball, back = np.zeros(_N), np.zeros(_N)
    field = np.zeros(FIELD_BINS)
    sides: list[float] = []
    bottoms: list[float] = []
    for image, boxes in samples:
        ycrcb = to_ycrcb(image)
        bins = _bins(ycrcb)
        height = image.shape[0]
        ellipses, outside = _masks(image.shape[:2], boxes)
        for (x0, y0, x1, y1), mask in zip(boxes, ellipses, strict=True):
            counts = np.bincount(bins[mask], minlength=_N)
            if counts.sum() > 0:
                ball += counts / counts.sum()
                sides.append(max(x1 - x0, y1 - y0))
                bottoms.append(y1)
        counts = np.bincount(bins[outside], minlength=_N)
        back += counts / max(1, counts.sum())
        low = outside[round(height * (1 - FIELD_ROWS)):]
        crcb = ycrcb[round(height * (1 - FIELD_ROWS)):][low][:, 1:] >> 3
        np.add.at(field, (crcb[:, 0], crcb[:, 1]), 1.0)
    return ball, back, field, np.asarray(sides, np.float64), np.asarray(bottoms, np.float64)


def _size_line(sides: npt.NDArray[np.float64], bottoms: npt.NDArray[np.float64]
               ) -> tuple[float, float]:
    """Least squares ``side = a * bottom + b`` once, again without the worst quarter of
    the residuals (a ball half hidden, a box drawn loosely); (0, 0) for fewer than 4
    balls, a spread of rows under 50 px or a slope that is not positive."""
    if len(sides) < 4 or float(np.ptp(bottoms)) < 50.0:
        return 0.0, 0.0
    keep = np.ones(len(sides), bool)
    a = b = 0.0
    for _ in range(2):
        a, b = (float(v) for v in np.polyfit(bottoms[keep], sides[keep], 1))
        resid = np.abs(sides - (a * bottoms + b))
        keep = resid <= np.quantile(resid, 0.75)
    return (a, b) if a > 0 else (0.0, 0.0)


def fit_ball_model(samples: Iterable[tuple[npt.NDArray[np.uint8], Sequence[Box]]], *,
                   levels: Sequence[int] = (150, 166, 182), threshold: float = 0.5,
                   info: Mapping[str, Any] | None = None) -> BallModel:
    """The ball model of (BGR image, ball boxes) samples; images without a ball add to the
    background. :class:`BallModelError` when no box holds a pixel."""
    ball, back, field, sides, bottoms = _accumulate(samples)
    if ball.sum() <= 0:
        raise BallModelError("no labelled ball pixels to fit the colour on: label at "
                             "least one ball")
    p_ball = _blur((ball / ball.sum()).reshape(COLOUR_BINS), SMOOTH_BINS)
    p_back = _blur((back / max(back.sum(), _EPS)).reshape(COLOUR_BINS), SMOOTH_BINS)
    ratio = np.log(p_ball + _EPS) - np.log(p_back + _EPS)
    lut = np.clip(np.rint(OFFSET + SCALE * ratio), 0, 255).astype(np.uint8)
    fit = {"balls": len(sides), **(info or {})}
    return BallModel(colour_lut=lut, field_mask=_field_mask(field), levels=tuple(levels),
                     min_diameter_px=max(3.0, 0.5 * float(sides.min())),
                     max_diameter_px=max(160.0, 1.5 * float(sides.max())),
                     threshold=threshold, size_line=_size_line(sides, bottoms), fit=fit)
