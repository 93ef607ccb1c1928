"""Ranking between plausible blobs: the most ball-like shape wins, not the biggest one."""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt
import pytest

from estimator.detection import detect_ball, detect_blobs

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
