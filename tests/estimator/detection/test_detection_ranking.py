"""Ranking between plausible blobs: the most ball-like shape wins, not the biggest one; ties
go to the larger blob, then top-to-bottom, left-to-right."""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt
import pytest

from estimator.detection import DetectionParams, detect_ball, detect_blobs

ORANGE_BGR = (0, 110, 255)
GREEN_BGR = (40, 140, 40)
RADIUS_PX = 9
AXES_PX = (32, 12)


def field_image(size: int = 300) -> npt.NDArray[np.uint8]:
    image = np.empty((size, size, 3), np.uint8)
    image[:] = GREEN_BGR
    return image


def draw_disc(image: npt.NDArray[np.uint8], centre: tuple[int, int]) -> None:
    cv2.circle(image, centre, RADIUS_PX, ORANGE_BGR, -1)


def draw_ellipse(image: npt.NDArray[np.uint8], centre: tuple[int, int]) -> None:
    # an elongated orange blob (a ball half hidden behind a leg, a shirt): plausible
    # (circularity ~0.75, fill pi/4) and four times the disc's area, but less ball-like
    cv2.ellipse(image, centre, AXES_PX, 0, 0, 360, ORANGE_BGR, -1)


def test_each_shape_alone_is_a_plausible_ball() -> None:
    for draw in (draw_disc, draw_ellipse):
        image = field_image()
        draw(image, (150, 150))
        assert detect_ball(image) is not None, draw.__name__


@pytest.mark.parametrize("disc_first", [True, False], ids=["disc-above", "disc-below"])
def test_a_round_ball_beats_a_bigger_plausible_ellipse(disc_first: bool) -> None:
    image = field_image()
    disc, ellipse = ((80, 60), (150, 220)) if disc_first else ((150, 240), (150, 70))
    draw_disc(image, disc)
    draw_ellipse(image, ellipse)
    blobs = detect_blobs(image)
    assert len(blobs) == 2
    round_one, long_one = sorted(blobs, key=lambda b: -b.circularity)
    assert long_one.area_px > 3 * round_one.area_px
    assert blobs == [round_one, long_one]
    ball = detect_ball(image)
    assert ball is not None
    assert (ball.cx_px, ball.cy_px) == pytest.approx(disc, abs=0.05)


def draw_square(image: npt.NDArray[np.uint8], corner: tuple[int, int], side: int) -> None:
    cv2.rectangle(image, corner, (corner[0] + side - 1, corner[1] + side - 1), ORANGE_BGR, -1)


def test_equally_ball_like_blobs_rank_the_larger_first() -> None:
    """Guards the tie-break on area: two blobs with the very same shape score (without the
    OPEN, squares of side 2^k + 1 have circularity exactly pi/4 and fill 1) rank the larger
    first, even when the smaller one is above it and to its left."""
    params = DetectionParams(open_kernel_px=1, max_fill_ratio=1.0)
    image = field_image()
    draw_square(image, (40, 40), 9)
    draw_square(image, (150, 150), 17)
    small, large = sorted(detect_blobs(image, params), key=lambda b: b.area_px)
    assert (small.area_px, large.area_px) == (81.0, 289.0)
    assert small.circularity == large.circularity  # the same shape score: a tie
    assert detect_blobs(image, params) == [large, small]
    assert detect_ball(image, params) == large


@pytest.mark.parametrize(("first", "second"), [
    ((200, 60), (80, 220)),  # the upper one is to the right: rows decide before columns
    ((80, 150), (220, 150)),  # the same row: the left one first
], ids=["upper-first", "left-first"])
def test_identical_balls_rank_top_to_bottom_then_left_to_right(
        first: tuple[int, int], second: tuple[int, int]) -> None:
    """Guards the tie-break on position: two identical discs (the same score and area, a
    full tie) rank top-to-bottom, then left-to-right, as the module docstring says, so the
    ball chosen between them never depends on the order the blobs were found in."""
    image = field_image()
    draw_disc(image, second)
    draw_disc(image, first)
    blobs = detect_blobs(image)
    assert len(blobs) == 2
    assert blobs[0].area_px == blobs[1].area_px
    assert blobs[0].circularity == blobs[1].circularity
    assert [(b.cx_px, b.cy_px) for b in blobs] == [pytest.approx(first, abs=0.05),
                                                   pytest.approx(second, abs=0.05)]
    ball = detect_ball(image)
    assert ball is not None and (ball.cx_px, ball.cy_px) == pytest.approx(first, abs=0.05)
