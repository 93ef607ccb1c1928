"""Where the field is: a synthetic camera image (a grey hall above, a green field below, the
lens's dark rim at the foot) has its far edge found where the green starts, a point above
it is beyond the field by its height, one on it or at the robot's feet is not; a candidate
above the field needs more evidence (its odds divided by how many of its sizes up it is),
one on the field none; an omnidirectional frame is left alone."""

from __future__ import annotations

import json
import math
from importlib.resources import files

import cv2
import numpy as np
import pytest

from estimator.detection.real import (
    BallCheck,
    BallModel,
    RealBallDetector,
    Search,
    model_from_dict,
)
from estimator.detection.real.colour import ColourTables
from estimator.detection.real.detector import search_for
from estimator.detection.real.field import OFF_FIELD, OffField, beyond, find_field

FIELD_TOP = 300
GREEN_BGR = (60, 140, 40)  # Cr 84, Cb 105: the field's green of the shared images
BALL_BGR = (20, 150, 185)  # the generic model's most ball-like colour


@pytest.fixture(scope="module")
def model() -> BallModel:
    text = files("estimator.detection.real").joinpath("ball_generic.json").read_text()
    return model_from_dict(json.loads(text))


@pytest.fixture(scope="module")
def check() -> BallCheck:
    return BallCheck(files("estimator.detection.real").joinpath("ball_check.onnx").read_bytes())


def _hall(height: int = 800, width: int = 608) -> np.ndarray:
    """A grey hall over a green field from row FIELD_TOP, the lens's dark rim at the foot."""
    image = np.full((height, width, 3), 128, np.uint8)
    image[FIELD_TOP:] = GREEN_BGR
    image[height - 40:] = 10
    return image


def test_the_far_edge_is_where_the_green_starts(model: BallModel) -> None:
    found = find_field(_hall(), ColourTables.of(model))
    assert 0.5 < found.share < 0.7
    assert np.all(np.abs(found.top - FIELD_TOP) <= found.step)
    off = beyond(found, np.array([[300.0, 100.0], [300.0, 500.0], [300.0, 790.0],
                                  [5.0, 250.0]]))
    assert off[0] == pytest.approx(FIELD_TOP - 100, abs=found.step)
    assert off[1] == 0.0 and off[2] == 0.0  # on the field; below it, at the robot's feet
    assert off[3] == pytest.approx(FIELD_TOP - 250, abs=found.step)


def test_a_grey_frame_has_no_field_and_nothing_is_beyond_it(model: BallModel) -> None:
    grey = np.full((800, 608, 3), 128, np.uint8)
    found = find_field(grey, ColourTables.of(model))
    assert found.share == 0.0 and len(found.top) == 0
    assert beyond(found, np.array([[10.0, 10.0]])).tolist() == [0.0]
    # a green patch too small to be a field is none either
    grey[600:630, 300:330] = GREEN_BGR
    assert len(find_field(grey, ColourTables.of(model)).top) == 0


def test_the_rule_divides_the_odds_by_how_far_up_a_candidate_is() -> None:
    rule = OffField(sides=1.0, weight=1.0)
    off = np.array([0.0, 10.0, 40.0, 40.0])
    side = np.array([10.0, 10.0, 10.0, 5.0])
    assert rule.penalty(off, side).tolist() == pytest.approx([0.0, 0.0, math.log(4),
                                                              math.log(8)])
    assert rule.is_off(off, side).tolist() == [False, False, True, True]
    assert OffField(weight=0.0).penalty(off, side).tolist() == [0.0] * 4
    assert OFF_FIELD == rule  # the detector applies it by default


def _logit(p: float) -> float:
    return math.log(p) - math.log1p(-p)


def test_a_candidate_above_the_field_needs_more_evidence_one_on_it_none(
        model: BallModel, check: BallCheck) -> None:
    plain = RealBallDetector(model, check, off_field=OffField(weight=0.0))
    ruled = RealBallDetector(model, check, off_field=OffField(sides=1.0, weight=1.0))
    above = _hall()
    cv2.circle(above, (400, 100), 12, BALL_BGR, -1)  # 200 px above the field
    before, after = plain.candidates(above)[0], ruled.candidates(above)[0]
    assert after.beyond_px == before.beyond_px == pytest.approx(FIELD_TOP - 112, abs=8)
    assert abs(after.detection.cy_px - 100) < 3
    side = max(after.detection.bbox_px[2:])  # the blob's; the rule reads its map box
    assert _logit(before.check_score) - _logit(after.check_score) == pytest.approx(
        math.log(after.beyond_px / side), abs=0.2)
    # the generic model reports from P 0.731: reported without the rule, not with it
    assert before.check_score > model.threshold > after.check_score
    assert plain.detect(above) is not None and ruled.detect(above) is None
    on = _hall()
    cv2.circle(on, (200, 500), 12, BALL_BGR, -1)
    before, after = plain.candidates(on)[0], ruled.candidates(on)[0]
    assert after.beyond_px == 0.0 and after.check_score == before.check_score > 0.99
    assert ruled.detect(on) is not None


def test_an_omnidirectional_frame_is_left_alone(model: BallModel, check: BallCheck) -> None:
    assert not search_for(1080, 1080).field and search_for(800, 608).field
    image = cv2.resize(_hall(), (1080, 1080), interpolation=cv2.INTER_NEAREST)
    cv2.circle(image, (700, 150), 40, BALL_BGR, -1)  # above the field's green
    ranked = RealBallDetector(model, check).candidates(image)
    assert ranked and all(c.beyond_px == 0.0 for c in ranked)
    forward = Search(step=4, max_candidates=6, fine=0, field=True)  # as a camera's frame
    assert RealBallDetector(model, check, forward).candidates(image)[0].beyond_px > 100
