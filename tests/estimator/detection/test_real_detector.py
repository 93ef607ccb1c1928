"""The real-ball detector on real images: a venue's model fitted on 10 labelled frames finds
the ball in the next ones, the shipped check loads from the package, the model's JSON form
round-trips and refuses bad fields, and the results do not depend on OpenCV's threads.

The images are the committed subset in tests/data/msl-images (Apache-2.0, see its README).
"""

from __future__ import annotations

import dataclasses
import json
import math
from importlib.resources import files
from pathlib import Path

import cv2
import numpy as np
import pytest

from dsp.labelled import find_labelled
from estimator.detection.real import (
    BallCheck,
    BallModel,
    RealBallDetector,
    Search,
    adapt,
    fit_ball_model,
    model_from_dict,
    model_to_dict,
)
from estimator.detection.real.head import HEAD_THRESHOLD
from estimator.errors import BallModelError, DetectionError

SUBSET = Path(__file__).resolve().parents[2] / "data" / "msl-images" / "20220715" / "r7"


@pytest.fixture(scope="module")
def samples() -> list[tuple[np.ndarray, list[tuple[float, float, float, float]]]]:
    return [it.read(0) for it in find_labelled(SUBSET)]


@pytest.fixture(scope="module")
def check() -> BallCheck:
    return BallCheck(files("estimator.detection.real").joinpath("ball_check.onnx").read_bytes())


@pytest.fixture(scope="module")
def model(samples: list, check: BallCheck) -> BallModel:
    return adapt(fit_ball_model(samples[:10]), samples[:10], check)


def test_the_subset_is_there(samples: list) -> None:
    assert len(samples) == 14 and sum(len(b) for _, b in samples[10:]) == 9


def test_a_venue_fitted_on_ten_frames_finds_the_ball_in_the_next_four(
        samples: list, model: BallModel, check: BallCheck) -> None:
    assert model.check_head is not None  # the venue's head was fitted (enough candidates)
    detector = RealBallDetector(model, check)
    for image, balls in samples[10:]:
        found = detector.detect(image)
        assert found is not None
        errors = [np.hypot(found.cx_px - (x0 + x1) / 2, found.cy_px - (y0 + y1) / 2)
                  for x0, y0, x1, y1 in balls
                  if x0 - 2 <= found.cx_px <= x1 + 2 and y0 - 2 <= found.cy_px <= y1 + 2]
        assert errors and min(errors) < 3.0


def test_a_venue_head_reports_from_the_logit_one(samples: list, model: BallModel,
                                                 check: BallCheck) -> None:
    """With a head the best candidate is the ball from P 0.731 (logit 1), not 0.5: a
    candidate at P 0.62 is not reported; the colour model alone keeps 0.5."""
    assert model.threshold == HEAD_THRESHOLD
    assert math.log(HEAD_THRESHOLD / (1 - HEAD_THRESHOLD)) == pytest.approx(1.0, abs=1e-5)
    assert fit_ball_model(samples[:10]).threshold == 0.5
    image = samples[0][0]
    best = RealBallDetector(model, check).candidates(image)[0].check_score
    assert 0.8 < best < 0.99  # the frame's ball, scored below saturation
    assert model.check_head is not None
    # move the venue's bias so the ball's logit is 0.5 (P 0.62)
    shift = 0.5 - math.log(best / (1 - best))
    head = (*model.check_head[:-1], model.check_head[-1] + shift)
    lowered = dataclasses.replace(model, check_head=head)
    ranked = RealBallDetector(lowered, check).candidates(image)
    assert ranked[0].check_score == pytest.approx(0.6225, abs=1e-3)
    assert RealBallDetector(lowered, check).detect(image) is None
    at_half = dataclasses.replace(lowered, threshold=0.5)
    assert RealBallDetector(at_half, check).detect(image) is not None


def test_the_colour_model_alone_is_worse_than_with_the_check(
        samples: list, model: BallModel) -> None:
    """Without the learned check the most ball-coloured blob wins: here a shirt or a
    shoe at least once in the four frames (what the check is for)."""
    alone = RealBallDetector(model, None)
    hits = 0
    for image, balls in samples[10:]:
        found = alone.detect(image)
        assert found is not None
        hits += any(x0 - 2 <= found.cx_px <= x1 + 2 and y0 - 2 <= found.cy_px <= y1 + 2
                    for x0, y0, x1, y1 in balls)
    assert hits < 4


def test_candidates_are_ranked_and_scored(samples: list, model: BallModel,
                                          check: BallCheck) -> None:
    ranked = RealBallDetector(model, check).candidates(samples[10][0])
    assert 2 <= len(ranked) <= Search().max_candidates + Search().fine
    logits = [c.check_score for c in ranked]
    assert logits[0] >= 0.5 and logits[0] == max(logits)
    assert all(0.0 <= c.field_score <= 1.0 for c in ranked)


def test_the_results_do_not_depend_on_the_thread_count(samples: list, model: BallModel,
                                                       check: BallCheck) -> None:
    detector = RealBallDetector(model, check)
    before = cv2.getNumThreads()
    runs = []
    try:
        for threads in (1, 2):
            cv2.setNumThreads(threads)
            runs.append([[(c.detection.cx_px, c.detection.cy_px, c.check_score)
                          for c in detector.candidates(image)] for image, _ in samples[10:]])
    finally:
        cv2.setNumThreads(before)
    assert runs[0] == runs[1]


def test_the_json_form_round_trips(model: BallModel) -> None:
    data = json.loads(json.dumps(model_to_dict(model)))
    again = model_from_dict(data)
    assert np.array_equal(again.colour_lut, model.colour_lut)
    assert np.array_equal(again.field_mask, model.field_mask)
    assert (again.levels, again.threshold, again.check_head) == (
        model.levels, model.threshold, model.check_head)  # the head is stored rounded
    assert again.min_diameter_px == pytest.approx(model.min_diameter_px, abs=1e-3)
    assert again.size_line == pytest.approx(model.size_line, abs=1e-6)
    assert model_to_dict(again) == data  # and the JSON form is a fixed point


@pytest.mark.parametrize(("change", "words"), [
    ({"format": "something else"}, "not a ball model"),
    ({"version": 7}, "version 7"),
    ({"threshold": 1.5}, "threshold 1.5"),
    ({"levels": [182, 150]}, "ascending"),
    ({"diameter_px": [10, 5]}, "diameter range"),
    ({"check_head": [0.0] * 3}, "check_head"),
    ({"levels": "abc"}, "must be numbers"),
])
def test_bad_fields_are_refused_by_name(model: BallModel, change: dict, words: str) -> None:
    data = {**model_to_dict(model), **change}
    with pytest.raises(BallModelError, match=words):
        model_from_dict(data)


def test_a_bad_colour_table_is_refused(model: BallModel) -> None:
    data = model_to_dict(model)
    data["colour"] = {**data["colour"], "lut_b64": "AAAA"}
    with pytest.raises(BallModelError, match=r"colour.lut_b64 holds 3 bytes; expected 8192"):
        model_from_dict(data)
    data["colour"] = {**data["colour"], "lut_b64": "not base64!"}
    with pytest.raises(BallModelError, match="not valid base64"):
        model_from_dict(data)


def test_no_labelled_ball_cannot_be_fitted(samples: list) -> None:
    with pytest.raises(BallModelError, match="no labelled ball pixels"):
        fit_ball_model([(samples[0][0], [])])


def test_bad_onnx_bytes_and_bad_images_are_detection_errors(model: BallModel,
                                                            check: BallCheck) -> None:
    with pytest.raises(DetectionError, match="ONNX model does not load"):
        BallCheck(b"not an onnx model")
    with pytest.raises(DetectionError, match="H x W x 3 uint8"):
        RealBallDetector(model, check).detect(np.zeros((10, 10), np.uint8))
