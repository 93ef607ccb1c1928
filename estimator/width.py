"""A ball's horizontal range from its blob's width across the bearing (``--width-range``).

An omnidirectional camera whose axis stands vertical (the ideal top-down view, the fisheye
and the mirror alike) images every azimuth about its axis along one direction about the
image centre. A sphere of radius R whose centre is rho from that axis spans

    w = 2 asin(R / rho)

of azimuth, *whatever its height*: so the blob's azimuthal extent gives rho = R / sin(w / 2),
the range of the point under the ball, where the blob's radius (the ground-plane range)
places a ball in the air farther out along its ray, a metre for 10 cm of height at 8 m on
the mirror. The width is the coarser measure (a 12 px wide blob at 8 m: 0.4 px is 3 %), so
it only decides where it says more (:func:`combine_ranges`): a width that puts the ball
nearer than its ray meets the ground, beyond both sigmas, is a ball in the air, placed
under itself; otherwise the ground-plane range stands. (Averaging the two on the ground
was tried: on the mirror lobs log of :data:`MIN_WIDTH_PX` the ballistic fusion's RMSE went
from 0.16 to 0.53 m.) A width that says the ball is farther is a ball cut by something in
front of it or by the image's edge.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from estimator.constants import BALL_RADIUS_M

__all__ = ["MIN_WIDTH_PX", "WIDTH_EDGE_PX", "WIDTH_SIGMA_PX", "RangeChoice", "WidthRange",
           "combine_ranges", "width_range"]

WIDTH_EDGE_PX = 0.6
"""What the outline's extent misses of the ball's, both sides together [px]: the outline
runs through the boundary pixels' centres, half a pixel inside the edge, less the blur and
antialiasing that widen a blob (fitted on the simulated mirror's ground-ball frames of
``dsp-record --scenario lobs --camera mirror --seed 1``: 0.5-0.7 px at 2-10 m)."""

WIDTH_SIGMA_PX = 0.4
"""The sigma of that extent [px] (the same frames: interquartile range 0.2-0.6 px)."""

MIN_WIDTH_PX = 12.0
"""The narrowest blob whose width is used [px] (its width then to about 3 %). Narrower
blobs are far balls, whose width cannot tell a hop from the ground, and the boxes of the
ball's colour beside the field, whose width would put a ball in the air well inside it:
with every width used, one exact-pose mirror match (seed 41) went from 0.026 to 2.5 m
(chosen on seeds 40 and 41 and a lobs log, seed 1)."""

_MIN_OUTLINE = 5
_MIN_RADIUS_PX = 5.0


@dataclass(frozen=True)
class WidthRange:
    """The horizontal range a blob's width gives [m], and its sigma [m]."""

    range_m: float
    sigma_m: float


def width_range(outline_px: npt.ArrayLike, centre_px: tuple[float, float],
                centroid_px: tuple[float, float], *, ball_radius_m: float = BALL_RADIUS_M,
                edge_px: float = WIDTH_EDGE_PX, sigma_px: float = WIDTH_SIGMA_PX,
                min_width_px: float = MIN_WIDTH_PX) -> WidthRange | None:
    """The range from the azimuthal extent of ``outline_px`` (N x 2 (u, v)) about
    ``centre_px``, seen from the centroid's azimuth; None when the blob is narrower than
    ``min_width_px`` across the bearing, or too near the centre to say (its extent then
    spans the image's angles, not the ball's)."""
    points = np.asarray(outline_px, dtype=np.float64).reshape(-1, 2)
    du, dv = centroid_px[0] - centre_px[0], centroid_px[1] - centre_px[1]
    r = math.hypot(du, dv)
    if len(points) < _MIN_OUTLINE or r < _MIN_RADIUS_PX:
        return None
    azimuth = np.arctan2(points[:, 0] - centre_px[0], points[:, 1] - centre_px[1])
    relative = (azimuth - math.atan2(du, dv) + math.pi) % (2.0 * math.pi) - math.pi
    w = float(relative.max() - relative.min()) + edge_px / r
    if not 0.0 < w < math.pi / 2.0:  # the blob wraps the centre: no ball's width
        return None
    if w * r < min_width_px:  # too narrow to tell: a far ball, or a distant box's sliver
        return None
    half = 0.5 * w
    rho = ball_radius_m / math.sin(half)
    sigma = rho * (sigma_px / r) / (2.0 * math.tan(half))  # |d rho / d w| sigma_w
    return WidthRange(rho, sigma)


@dataclass(frozen=True)
class RangeChoice:
    """The range an estimate takes from its two measures, and what it made of them."""

    range_m: float
    sigma_m: float
    lifted: bool
    """The width put the ball nearer than its ray meets the ground: in the air."""


def combine_ranges(ground_m: float, ground_sigma_m: float, width: WidthRange, *,
                   k_sigma: float = 3.0) -> RangeChoice:
    """The width's range when it is nearer than the ground-plane range by more than
    ``k_sigma`` of both sigmas (a ball in the air), else the ground-plane range."""
    if ground_m - width.range_m > k_sigma * math.hypot(ground_sigma_m, width.sigma_m):
        return RangeChoice(width.range_m, width.sigma_m, True)
    return RangeChoice(ground_m, ground_sigma_m, False)
