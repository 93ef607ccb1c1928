"""The coarse-to-fine search (estimator.detection.regions) gives the whole image's results.

Every comparison is against ``search_stride_px=1`` (the whole image thresholded, opened and
traced, the reference path): the same blobs in the same order, every field equal, outlines
included.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt
import pytest
from test_estimator_detection import GREEN_BGR, ORANGE_BGR, draw_disc, field_image

from estimator.detection.chain import (
    Detection,
    DetectionParams,
    _channel_gap,
    _threshold,
    detect_ball,
    detect_blobs,
)
from estimator.detection.regions import search_regions
from estimator.errors import DetectionError

GOLDEN = Path(__file__).resolve().parents[3] / "logs" / "golden"


def _as_tuples(blobs: list[Detection]) -> list[tuple[Any, ...]]:
    return [(b.cx_px, b.cy_px, b.area_px, b.bbox_px, b.circularity, b.outline_px.tolist())
            for b in blobs]


def _same_as_whole_image(image: npt.NDArray[np.uint8], params: DetectionParams) -> list[Detection]:
    blobs = detect_blobs(image, params)
    whole = detect_blobs(image, dataclasses.replace(params, search_stride_px=1))
    assert _as_tuples(blobs) == _as_tuples(whole)
    return blobs


def _golden_frames() -> list[npt.NDArray[np.uint8]]:
    from replay.log import ImageMessage, LogReader, decode_image

    frames = []
    for log in sorted(GOLDEN.glob("*.mcap")):
        with LogReader(log) as reader:
            for msg in reader.messages():
                if isinstance(msg, ImageMessage):
                    image = decode_image(msg)
                    assert image is not None
                    frames.append(image)
    return frames


def test_every_golden_frame_gives_the_whole_images_blobs() -> None:
    frames = _golden_frames()
    assert len(frames) == 72  # 3 x 3 x 4 paper scenes, 3 x 4 each rolling, match, lobs
    params = [DetectionParams(), DetectionParams(ignore_radius_px=100.0),
              DetectionParams(open_kernel_px=7, search_stride_px=4)]
    balls = 0
    for frame, p in itertools.product(frames, params):
        balls += len(_same_as_whole_image(frame, p))
    assert balls >= 3 * 36  # the ball in most frames
    lines = DetectionParams(hsv_lower=(0, 0, 200), hsv_upper=(179, 60, 255))  # white lines
    assert sum(len(_same_as_whole_image(frame, lines)) for frame in frames[::4]) > 50


@pytest.mark.parametrize("seed", range(12))
def test_random_scenes_give_the_whole_images_blobs(seed: int) -> None:
    rng = np.random.default_rng(seed)
    image = field_image(301)
    for _ in range(int(rng.integers(5, 40))):  # discs, some cut by the border, some touching
        x, y, r = rng.uniform(-6, 307), rng.uniform(-6, 307), rng.uniform(0.5, 14)
        colour = (int(rng.integers(0, 60)), int(rng.integers(60, 160)), int(rng.integers(200, 256)))
        cv2.circle(image, (round(x * 16), round(y * 16)), round(r * 16), colour, -1,
                   cv2.LINE_AA, shift=4)
    image[rng.random(image.shape[:2]) < 0.01] = ORANGE_BGR  # speckle
    for p in (DetectionParams(), DetectionParams(ignore_radius_px=60.5,
                                                 ignore_centre_px=(100.3, 150.7)),
              DetectionParams(open_kernel_px=5, search_stride_px=2), DetectionParams(
                  open_kernel_px=1, subpixel=False, search_stride_px=5)):
        _same_as_whole_image(image, p)


@pytest.mark.parametrize("size", [121, 122])
@pytest.mark.parametrize("radius", [2.0, 2.5, 3.0])
def test_a_tiny_ball_at_the_image_edge_is_found(radius: float, size: int) -> None:
    # every phase of the sampling grid (and sub-pixel offsets), along each border and in
    # the corners, as close to the border as draw_disc can draw; 121 rows: the last row is
    # sampled, 122: it is not (the channel test then reads whole rows, see below)
    edge = math.ceil(radius) + 1.0
    phases = (0.0, 1.0, 2.0, 0.5, 1.3, 2.7)
    found = listed = 0
    for du, dv in itertools.product(phases, phases):
        for cx, cy in ((edge + du, 60 + dv), (size - 1 - edge - du, 60 + dv),
                       (60 + du, edge + dv), (60 + du, size - 1 - edge - dv),
                       (edge + du, edge + dv), (size - 1 - edge - du, size - 1 - edge - dv)):
            image = field_image(size)
            draw_disc(image, cx, cy, radius)
            blobs = _same_as_whole_image(image, DetectionParams())
            assert len(blobs) == 1, (cx, cy)
            assert math.hypot(blobs[0].cx_px - cx, blobs[0].cy_px - cy) < 0.3
            listed += 1
            found += detect_ball(image) is not None
    # the plausibility rules (e.g. the fill ratio of a 3 x 4 box) reject half the radius-2
    # positions and a few radius-2.5 ones on the whole image as well; the search rejects
    # exactly those (compared above)
    assert found >= {2.0: 0.45, 2.5: 0.95, 3.0: 1.0}[radius] * listed


def test_a_ball_cut_by_the_image_border_is_found() -> None:
    for radius, inside in itertools.product((2.0, 2.5, 3.0, 6.0), (0.6, 1.0, 1.5)):
        for cx, cy in ((inside, 50.3), (99 - inside, 50.3), (50.3, inside), (50.3, 99 - inside)):
            image = field_image(100)
            cv2.circle(image, (round(cx * 16), round(cy * 16)), round(radius * 16), ORANGE_BGR,
                       -1, cv2.LINE_AA, shift=4)
            _same_as_whole_image(image, DetectionParams())
            assert detect_blobs(image), (radius, cx, cy)


def test_a_tiny_ball_on_the_rim_of_a_recorded_frame_is_found() -> None:
    # a frame with no ball in it (rolling's goalkeeper); the image circle's rim at r ~ 540
    frame = next(f for f in _golden_frames() if detect_ball(f) is None).copy()
    cx, cy = 539.5 + 520 * math.cos(0.7), 539.5 + 520 * math.sin(0.7)
    draw_disc(frame, cx, cy, 2.5)
    ball = detect_ball(frame)
    assert ball is not None
    assert math.hypot(ball.cx_px - cx, ball.cy_px - cy) < 0.3
    _same_as_whole_image(frame, DetectionParams())


def test_a_big_ball_and_a_mostly_orange_image_fall_back_to_the_whole_image() -> None:
    image = field_image(400)
    cv2.circle(image, (200, 210), 150, ORANGE_BGR, -1, cv2.LINE_AA)  # most of the image
    blobs = _same_as_whole_image(image, DetectionParams())
    assert len(blobs) == 1
    image[:] = ORANGE_BGR
    assert len(_same_as_whole_image(image, DetectionParams())) == 1


def test_search_stride_must_be_positive() -> None:
    with pytest.raises(DetectionError, match="search_stride_px = 0"):
        DetectionParams(search_stride_px=0)


@pytest.mark.parametrize("width", [61, 62])
def test_every_blob_with_a_pixel_on_a_sampled_row_is_found(width: int) -> None:
    # the colour is tested on every third row in full: a blob of one pixel is found where
    # it lies on such a row, in any column, and only there. The fast channel test reads
    # each row through views shifted by up to 2 bytes: with 62 rows every sampled row has
    # a row after it and the views reach its last pixel (and 2 bytes of the next row);
    # with 61 the last row is sampled, and the last column is tested separately
    params = DetectionParams(open_kernel_px=1, min_area_px=0.0)
    for x, y in itertools.product((0, 1, 2, 3, 4, 5, 30, width - 2, width - 1), range(12)):
        image = field_image(width)
        image[y, x] = ORANGE_BGR
        whole = detect_blobs(image, dataclasses.replace(params, search_stride_px=1))
        assert len(whole) == 1
        blobs = detect_blobs(image, params)
        assert _as_tuples(blobs) == (_as_tuples(whole) if y % 3 == 0 else []), (x, y)


def test_candidates_in_the_last_column_keep_the_rows_in_order() -> None:
    # 61 rows: the last column is tested apart from the rest and its candidates merged in
    # row order; two pixels within one tile's span, the later row found first
    params = DetectionParams(open_kernel_px=1, min_area_px=0.0)
    image = field_image(61)
    image[3, 60] = ORANGE_BGR
    image[21, 50] = ORANGE_BGR
    assert len(_same_as_whole_image(image, params)) == 2


def test_candidates_that_fail_the_colour_test_leave_no_region() -> None:
    # a small red patch passes the cheap channel test (red - blue) but not the hue range:
    # its box is thresholded, found empty and dropped, so nothing is opened or traced there
    params = DetectionParams()
    image = field_image(240)
    cv2.circle(image, (100, 100), 5, (20, 20, 200), -1)
    gap = _channel_gap(params.hsv_lower, params.hsv_upper)

    def threshold(pixels: npt.NDArray[np.uint8], origin: tuple[int, int] | None
                  ) -> npt.NDArray[np.uint8]:
        return _threshold(pixels, params, origin, image.shape)

    assert search_regions(image, threshold, stride=3, band=7, gap=gap) == []
    draw_disc(image, 150.0, 60.0, 4.0)
    regions = search_regions(image, threshold, stride=3, band=7, gap=gap)
    assert regions is not None
    assert len(regions) == 1
    assert regions[0].mask.any()
    assert len(_same_as_whole_image(image, params)) == 1


def test_a_ball_among_many_channel_gap_candidates_is_found() -> None:
    # a red field: every sampled pixel passes the cheap channel test (red - blue) but not
    # the hue range, too many candidates to convert one by one; the rows are tested
    # exactly instead, with the same results
    image = field_image(400)
    image[:] = (20, 20, 200)  # red, hue 0: outside the ball's 5-25
    draw_disc(image, 200.3, 150.6, 6.0)
    draw_disc(image, 392.0, 6.0, 2.5)
    blobs = _same_as_whole_image(image, DetectionParams())
    assert len(blobs) == 2


HSV_RANGES = [
    ((5, 120, 80), (25, 255, 255)),  # the default orange
    ((170, 100, 100), (15, 255, 255)),  # red, wrapping around 180
    ((0, 1, 1), (29, 255, 255)),  # the whole red-to-yellow sector, barely saturated
    ((28, 60, 60), (32, 255, 255)),  # across the sector boundary at 30 (yellow)
    ((45, 200, 30), (75, 255, 255)),  # green
    ((100, 90, 90), (130, 255, 255)),  # blue
    ((140, 150, 200), (160, 255, 255)),  # magenta
]


@pytest.fixture(scope="module")
def every_colour() -> npt.NDArray[np.uint8]:
    codes = np.arange(1 << 24, dtype=np.uint32)
    bgr = np.stack([(codes >> s) & 255 for s in (16, 8, 0)], axis=1).astype(np.uint8)
    return bgr.reshape(4096, 4096, 3)


@pytest.mark.parametrize(("lower", "upper"), HSV_RANGES)
def test_the_channel_gap_holds_for_every_colour_in_the_range(
        lower: tuple[int, int, int], upper: tuple[int, int, int],
        every_colour: npt.NDArray[np.uint8]) -> None:
    # the cheap first test must pass every pixel the HSV range passes (all 2^24 colours,
    # through the detector's own threshold), or the search would miss blobs
    gap = _channel_gap(lower, upper)
    assert gap is not None
    params = DetectionParams(hsv_lower=lower, hsv_upper=upper)
    inside = _threshold(every_colour, params, None, every_colour.shape) > 0
    pixels = every_colour[inside].astype(np.int16)
    assert len(pixels) > 1000
    assert int((pixels[:, gap.plus] - pixels[:, gap.minus]).min()) >= gap.min_gap


def test_the_default_channel_gap_rejects_the_field_lines_and_robots() -> None:
    params = DetectionParams()
    gap = _channel_gap(params.hsv_lower, params.hsv_upper)
    assert gap is not None
    for colour in (GREEN_BGR, (235, 235, 235), (96, 88, 88), (25, 25, 25)):
        assert colour[gap.plus] - colour[gap.minus] < gap.min_gap, colour
    assert ORANGE_BGR[gap.plus] - ORANGE_BGR[gap.minus] >= gap.min_gap


def test_ranges_holding_greys_have_no_channel_gap() -> None:
    assert _channel_gap((0, 0, 200), (179, 60, 255)) is None  # white lines
    assert _channel_gap((5, 0, 80), (25, 255, 255)) is None  # S from 0: greys pass
    assert _channel_gap((0, 100, 100), (179, 255, 255)) is None  # every hue


def test_views_of_an_image_give_the_blobs_of_their_copies() -> None:
    # the search reads byte-shifted views of the rows; a ROI, a mirrored image and the
    # BGR channels of a BGRA image are not laid out like a fresh array
    image = field_image(240)
    for cx, cy, r in ((40.3, 61.7, 5.0), (200.0, 30.2, 2.5), (232.5, 120.0, 4.0)):
        draw_disc(image, cx, cy, r)
    bgra = np.dstack((image, np.full(image.shape[:2], 255, np.uint8)))
    for view in (image[7:233, 3:239], image[:, ::-1], image[::-1], bgra[..., :3]):
        assert not view.flags.c_contiguous
        blobs = _same_as_whole_image(view, DetectionParams())
        assert _as_tuples(blobs) == _as_tuples(detect_blobs(view.copy()))
        assert len(blobs) >= 2
