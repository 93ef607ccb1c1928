"""A blob's width across the bearing gives the ball's horizontal range whatever its height
(:mod:`estimator.width`): rasterised discs as an omni camera images a ball, on the ground
and lifted; too narrow a blob says nothing; the width decides only a ball in the air."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from estimator.constants import BALL_RADIUS_M
from estimator.width import MIN_WIDTH_PX, WidthRange, combine_ranges, width_range

CENTRE = (540.0, 540.0)


def _width(r_px: float, a_px: float, azimuth_rad: float = 0.7) -> WidthRange | None:
    """The width's range of the outline cv2 finds of a disc of radius ``a_px`` whose centre
    is ``r_px`` from the image centre (the pixels whose centres it covers)."""
    cu = CENTRE[0] + r_px * math.sin(azimuth_rad)
    cv = CENTRE[1] + r_px * math.cos(azimuth_rad)
    ys, xs = np.mgrid[0:1080, 0:1080]
    img = np.where((xs - cu) ** 2 + (ys - cv) ** 2 <= a_px**2, 255, 0).astype(np.uint8)
    contours, _ = cv2.findContours(img, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    return width_range(max(contours, key=cv2.contourArea).reshape(-1, 2), CENTRE, (cu, cv))


@pytest.mark.parametrize("rho", [2.0, 4.0, 6.0])
def test_a_disc_s_width_gives_the_ball_s_range(rho: float) -> None:
    """A ball rho from the axis spans 2 asin(R / rho) of azimuth: a disc of that angular
    width gives rho within its sigma, and the sigma is a few percent."""
    r = 420.0
    w = _width(r, r * BALL_RADIUS_M / rho)
    assert w is not None
    assert w.range_m == pytest.approx(rho, abs=2.5 * w.sigma_m)
    assert 0.0 < w.sigma_m < 0.04 * rho


def test_the_same_angular_width_farther_out_is_the_same_range() -> None:
    """A ball in the air: its ray meets the ground farther out (a larger pixel radius), and
    its blob spans the same azimuth; the width's range stays the ball's."""
    rho = 5.0
    near = _width(360.0, 360.0 * BALL_RADIUS_M / rho)
    far = _width(480.0, 480.0 * BALL_RADIUS_M / rho)
    assert near is not None and far is not None
    assert far.range_m == pytest.approx(near.range_m, rel=0.03)
    assert far.range_m == pytest.approx(rho, rel=0.03)


def test_a_blob_too_narrow_or_at_the_centre_says_nothing() -> None:
    r = 450.0
    a = 0.45 * MIN_WIDTH_PX  # a disc a little narrower than the narrowest used
    assert _width(r, a) is None
    assert _width(r, a + 2.0) is not None
    assert _width(3.0, 20.0) is None  # wraps the centre


def test_only_a_width_nearer_than_the_ground_beyond_both_sigmas_lifts_the_ball() -> None:
    width = WidthRange(5.0, 0.1)
    lifted = combine_ranges(5.9, 0.2, width)
    assert lifted.lifted and lifted.range_m == 5.0 and lifted.sigma_m == 0.1
    within = combine_ranges(5.5, 0.2, width)  # 0.5 m nearer: inside 3 sigma (0.67 m)
    assert not within.lifted and within.range_m == 5.5 and within.sigma_m == 0.2
    farther = combine_ranges(4.0, 0.05, width)  # a cut blob: narrower, so "farther"
    assert not farther.lifted and farther.range_m == 4.0
