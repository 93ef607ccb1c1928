"""The real detector's candidates: a far ball, a speck of the half-resolution map too small
for the size range, is found again in full resolution (``fine``), once, beside the blobs;
large frames keep the blobs alone."""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt

from estimator.detection.real import BallModel, Search, fit_ball_model, search_for
from estimator.detection.real.candidates import find_coarse
from estimator.detection.real.colour import ColourTables

GREEN = (40, 140, 40)
YELLOW = (40, 220, 240)
Box = tuple[float, float, float, float]


def _image(balls: list[tuple[int, int, int]], size: tuple[int, int] = (240, 320)
           ) -> tuple[npt.NDArray[np.uint8], list[Box]]:
    """A green field with yellow discs (cx, cy, diameter) and their boxes."""
    image = np.empty((*size, 3), np.uint8)
    image[:] = GREEN
    boxes: list[Box] = []
    for cx, cy, d in balls:
        cv2.circle(image, (cx, cy), d // 2, YELLOW, -1, cv2.LINE_8)
        boxes.append((cx - d // 2, cy - d // 2, cx + d // 2 + 1, cy + d // 2 + 1))
    return image, boxes


def _model() -> BallModel:
    """Fitted on balls of 13-31 px: the size range starts at 6.5 px, 3.25 map pixels."""
    return fit_ball_model([_image([(60, 60, 31), (200, 150, 13)]),
                           _image([(100, 180, 21)])])


def test_a_far_ball_is_a_candidate_only_in_full_resolution() -> None:
    model = _model()
    tables = ColourTables.of(model)
    image, (far, _) = _image([(101, 81, 7), (230, 160, 25)])
    coarse = find_coarse(image, tables, model)
    assert [c.scale for c in coarse] == [2]  # the near ball; the far one is a speck
    fine = find_coarse(image, tables, model, fine=8)
    assert fine[:1] == coarse and [c.scale for c in fine] == [2, 1]
    x0, y0, x1, y1 = fine[1].full_box()
    assert (x0, y0, x1, y1) == far  # the disc's own pixels, not the map's 2 px cells
    cx, cy, d = fine[1].centre()
    assert (cx, cy, d) == (101.5, 81.5, 7.0)
    assert fine[1].level == model.levels[0] and fine[1].mean > 0


def test_specks_below_the_size_range_or_of_one_pixel_stay_out() -> None:
    model = _model()
    tables = ColourTables.of(model)
    image, _ = _image([(101, 81, 5)])  # 5 px: under the range's 6.5 px even at full resolution
    image[30, 30] = YELLOW  # a lone pixel
    assert find_coarse(image, tables, model, fine=8) == []


def test_the_fine_search_keeps_at_most_its_count_most_ball_coloured_first() -> None:
    model = _model()
    tables = ColourTables.of(model)
    far = [(21 + 30 * i, 41 + 40 * (i % 3), 7) for i in range(9)]
    image, _ = _image(far)
    image[41 + 40 * 2 - 3, 21 + 30 * 8] = GREEN  # one disc a pixel short
    assert find_coarse(image, tables, model) == []
    found = find_coarse(image, tables, model, fine=3)
    assert len(found) == 3 and all(c.scale == 1 for c in found)
    # equal discs: top to bottom, then left to right
    assert [c.centre()[:2] for c in found] == [(21.5, 41.5), (111.5, 41.5), (201.5, 41.5)]
    every = find_coarse(image, tables, model, fine=9)
    assert len(every) == 9
    assert every[-1].centre()[:2] == (261.5, 122.0)  # the short one last, its top row gone


def test_camera_images_search_the_specks_and_large_frames_do_not() -> None:
    assert Search().fine == 8 and search_for(608, 800).fine == 8
    assert search_for(1080, 1080).fine == 0


def test_a_ball_the_border_cuts_is_centred_on_its_visible_part() -> None:
    """The label of a ball the image's border cuts is its visible part: the centroid is
    the blob's box centre alone there; elsewhere the check's centre is blended in."""
    from importlib.resources import files

    from estimator.detection.real import BallCheck, RealBallDetector

    check = BallCheck(files("estimator.detection.real").joinpath("ball_check.onnx")
                      .read_bytes())
    detector = RealBallDetector(_model(), check)
    for (cx, cy), cut in (((150, 230), True), ((151, 150), False)):
        image, _ = _image([(cx, cy, 41)])
        found = detector.candidates(image)[0].detection
        x, y, w, h = found.bbox_px
        assert (y + h == 240) is cut
        at_box = (found.cx_px, found.cy_px) == (x + w / 2.0, y + h / 2.0)
        assert at_box is cut
