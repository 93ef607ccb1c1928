"""Ball detection: HSV threshold, OPEN, blobs, sub-pixel centroid, plausibility."""

from __future__ import annotations

import math

import cv2
import numpy as np
import numpy.typing as npt
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from estimator.detection import DetectionParams, detect_ball, detect_blobs
from estimator.errors import DetectionError

ORANGE_BGR = (0, 110, 255)  # the simulator's ball, RGB (255, 110, 0)
GREEN_BGR = (40, 140, 40)


def field_image(size: int = 200) -> npt.NDArray[np.uint8]:
    image = np.empty((size, size, 3), np.uint8)
    image[:] = GREEN_BGR
    return image


def draw_disc(
    image: npt.NDArray[np.uint8],
    cx: float,
    cy: float,
    radius: float,
    colour: tuple[int, int, int] = ORANGE_BGR,
    samples: int = 16,
) -> None:
    """Anti-aliased disc: each pixel blends colour by its exact area coverage, estimated
    on a samples x samples grid (pixel index i covers [i - 0.5, i + 0.5])."""
    x0, x1 = math.floor(cx - radius) - 1, math.ceil(cx + radius) + 2
    y0, y1 = math.floor(cy - radius) - 1, math.ceil(cy + radius) + 2
    offsets = (np.arange(samples) + 0.5) / samples - 0.5
    us = (np.arange(x0, x1)[:, None] + offsets[None, :]).ravel()
    vs = (np.arange(y0, y1)[:, None] + offsets[None, :]).ravel()
    inside = (us[None, :] - cx) ** 2 + (vs[:, None] - cy) ** 2 <= radius**2
    coverage = inside.reshape(y1 - y0, samples, x1 - x0, samples).mean(axis=(1, 3))[..., None]
    roi = image[y0:y1, x0:x1].astype(np.float64)
    blended = roi * (1.0 - coverage) + np.array(colour, np.float64) * coverage
    image[y0:y1, x0:x1] = np.clip(np.rint(blended), 0, 255).astype(np.uint8)


@settings(max_examples=40, deadline=None)
@given(
    st.floats(min_value=60.0, max_value=140.0),
    st.floats(min_value=60.0, max_value=140.0),
    st.floats(min_value=4.0, max_value=30.0),
)
def test_antialiased_disc_centre_within_0_05_px(cx: float, cy: float, radius: float) -> None:
    image = field_image()
    draw_disc(image, cx, cy, radius)
    detection = detect_ball(image)
    assert detection is not None
    assert math.hypot(detection.cx_px - cx, detection.cy_px - cy) < 0.05
    assert detection.area_px == pytest.approx(math.pi * radius**2, rel=0.02)


def test_opencv_antialiased_circle_with_shift_within_0_05_px() -> None:
    rng = np.random.default_rng(7)
    for _ in range(20):
        cx, cy, radius = *rng.uniform(60.0, 140.0, 2), rng.uniform(5.0, 30.0)
        image = field_image()
        centre = (round(cx * 256), round(cy * 256))
        cv2.circle(image, centre, round(radius * 256), ORANGE_BGR, -1, cv2.LINE_AA, shift=8)
        detection = detect_ball(image)
        assert detection is not None
        assert (
            math.hypot(detection.cx_px - centre[0] / 256, detection.cy_px - centre[1] / 256) < 0.05
        )


def test_binary_moments_are_only_statistically_sub_pixel() -> None:
    # Without edge weighting the centroid of the thresholded disc (eq. 1-2 on the binary
    # mask) is right on average but off by up to ~0.15 px on one disc.
    rng = np.random.default_rng(3)
    errors = []
    for _ in range(30):
        cx, cy, radius = *rng.uniform(60.0, 140.0, 2), rng.uniform(4.0, 30.0)
        image = field_image()
        draw_disc(image, cx, cy, radius)
        detection = detect_ball(image, DetectionParams(subpixel=False))
        assert detection is not None
        errors.append(math.hypot(detection.cx_px - cx, detection.cy_px - cy))
    assert 0.01 < max(errors) < 0.5


def test_binary_disc_on_the_pixel_grid_is_exact() -> None:
    image = field_image()
    cv2.circle(image, (100, 80), 12, ORANGE_BGR, -1)  # symmetric about (100, 80)
    for subpixel in (True, False):
        detection = detect_ball(image, DetectionParams(subpixel=subpixel))
        assert detection is not None
        assert (detection.cx_px, detection.cy_px) == pytest.approx((100.0, 80.0), abs=1e-9)
        assert detection.bbox_px == (88, 68, 25, 25)
        assert detection.circularity > 0.85
        assert detection.outline_px.shape[1] == 2


def test_shaded_ball_is_still_orange() -> None:
    image = field_image()
    cv2.circle(image, (100, 100), 15, (0, 50, 115), -1)  # the shadowed limb: V = 115
    cv2.circle(image, (100, 100), 11, ORANGE_BGR, -1)
    detection = detect_ball(image)
    assert detection is not None
    assert detection.area_px == pytest.approx(math.pi * 15.5**2, rel=0.1)
    assert (detection.cx_px, detection.cy_px) == pytest.approx((100.0, 100.0), abs=0.05)


def test_nothing_orange_gives_none() -> None:
    image = field_image()
    cv2.line(image, (0, 100), (199, 100), (255, 255, 255), 3)  # a white line
    cv2.circle(image, (60, 60), 20, (20, 20, 20), -1)  # a dark robot
    assert detect_ball(image) is None
    assert detect_blobs(image) == []


def test_speckle_is_removed_by_the_open() -> None:
    image = field_image()
    image[10, 10] = ORANGE_BGR
    image[50, 150] = ORANGE_BGR
    assert detect_blobs(image) == []


def test_the_most_ball_like_blob_wins() -> None:
    image = field_image(300)
    cv2.rectangle(image, (20, 20), (120, 60), ORANGE_BGR, -1)  # an orange advert: not round
    cv2.circle(image, (200, 200), 8, ORANGE_BGR, -1)  # the ball, smaller
    blobs = detect_blobs(image)
    assert len(blobs) == 2
    ball = detect_ball(image)
    assert ball is not None
    assert (ball.cx_px, ball.cy_px) == pytest.approx((200.0, 200.0))
    assert blobs[0] == ball


def test_two_balls_are_both_listed_and_detect_ball_returns_the_first() -> None:
    image = field_image(300)
    cv2.circle(image, (60, 60), 6, ORANGE_BGR, -1)
    cv2.circle(image, (200, 200), 15, ORANGE_BGR, -1)
    blobs = detect_blobs(image)
    assert {(round(b.cx_px), round(b.cy_px)) for b in blobs} == {(60, 60), (200, 200)}
    assert detect_ball(image) == blobs[0]
    assert detect_blobs(image) == blobs  # deterministic order


def test_implausible_only_gives_none_but_is_listed() -> None:
    image = field_image(300)
    cv2.rectangle(image, (20, 20), (220, 40), ORANGE_BGR, -1)
    assert detect_ball(image) is None
    assert len(detect_blobs(image)) == 1


def test_ignore_radius_masks_the_robot_body() -> None:
    image = field_image(201)
    cv2.circle(image, (100, 100), 10, ORANGE_BGR, -1)  # orange on the robot itself
    cv2.circle(image, (170, 40), 7, ORANGE_BGR, -1)
    params = DetectionParams(ignore_radius_px=25.0)
    ball = detect_ball(image, params)
    assert ball is not None
    assert (ball.cx_px, ball.cy_px) == pytest.approx((170.0, 40.0))
    assert len(detect_blobs(image, params)) == 1


def test_hue_range_may_wrap_for_a_red_ball() -> None:
    image = field_image()
    cv2.circle(image, (100, 100), 10, (30, 0, 230), -1)  # red, hue ~ 176
    assert detect_ball(image) is None
    red = DetectionParams(hsv_lower=(170, 120, 80), hsv_upper=(8, 255, 255))
    ball = detect_ball(image, red)
    assert ball is not None
    assert (ball.cx_px, ball.cy_px) == pytest.approx((100.0, 100.0))


def test_detection_is_frozen() -> None:
    image = field_image()
    cv2.circle(image, (100, 100), 10, ORANGE_BGR, -1)
    ball = detect_ball(image)
    assert ball is not None
    with pytest.raises(AttributeError):
        ball.cx_px = 1.0  # type: ignore[misc]


@pytest.mark.parametrize(
    ("image", "match"),
    [
        (np.zeros((10, 10), np.uint8), "H x W x 3 uint8"),
        (np.zeros((10, 10, 3), np.float32), "H x W x 3 uint8"),
        ([[0]], "numpy array"),
    ],
)
def test_bad_image(image: object, match: str) -> None:
    with pytest.raises(DetectionError, match=match):
        detect_ball(image)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"hsv_lower": (200, 0, 0)}, "outside OpenCV's 0-179"),
        ({"hsv_lower": (5, 200, 80), "hsv_upper": (25, 100, 255)}, "swap them"),
        ({"min_area_px": 50.0, "max_area_px": 10.0}, "min_area_px"),
        ({"ignore_radius_px": -1.0}, "ignore nothing"),
    ],
)
def test_bad_params(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(DetectionError, match=match):
        DetectionParams(**kwargs)  # type: ignore[arg-type]
