"""train/edge.py (``train.py --edge-negatives N``): the negatives cut while the samples are
built lie beyond the field's far edge by the detector's own rule, clear of every labelled
ball (a ball in the air too), the finder's candidates there first, and are the same for
the same generator. A synthetic camera image (a grey hall over a green field), the
shipped generic model; NumPy and OpenCV only (no torch)."""

from __future__ import annotations

import importlib.util
import json
import sys
from importlib.resources import files
from pathlib import Path
from types import ModuleType
from typing import Any

import cv2
import numpy as np
import pytest

from estimator.detection.real import BallModel, model_from_dict
from estimator.detection.real.colour import ColourTables

ROOT = Path(__file__).resolve().parents[2]
FIELD_TOP = 400
Source = tuple[BallModel, ColourTables]
GREEN_BGR = (60, 140, 40)
BALL_BGR = (20, 150, 185)
LOOK_ALIKE = (120, 150)  # a ball-coloured disc above the field, far from the ball
NEAR_BALL = (420, 150)  # another, beside the ball in the air
NOT_BEYOND = [(120, 600), (520, FIELD_TOP - 28)]  # on the field; on its edge (less than its
# size above it: the detector's rule has it on the field)
BALLS = [(440.0, 130.0, 480.0, 170.0), (280.0, 580.0, 320.0, 620.0)]  # in the air; on the field


def _module() -> ModuleType:
    spec = importlib.util.spec_from_file_location("train_edge", ROOT / "train" / "edge.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # its dataclass looks its module up there
    spec.loader.exec_module(mod)
    return mod


edge = _module()


@pytest.fixture(scope="module")
def source() -> Source:
    text = files("estimator.detection.real").joinpath("ball_generic.json").read_text()
    model = model_from_dict(json.loads(text))
    return model, ColourTables.of(model)


def _hall() -> np.ndarray:
    image = np.full((800, 608, 3), 128, np.uint8)
    image[FIELD_TOP:] = GREEN_BGR
    image[760:] = 10
    for x0, y0, x1, y1 in BALLS:
        cv2.circle(image, (round((x0 + x1) / 2), round((y0 + y1) / 2)), 20, BALL_BGR, -1)
    for centre in (LOOK_ALIKE, NEAR_BALL, *NOT_BEYOND):
        cv2.circle(image, centre, 12, BALL_BGR, -1)
    return image


def _cut(source: Source, seed: int, count: int = 12,
         seen: set[tuple[int, int, int]] | None = None) -> list[Any]:
    return list(edge.edge_negatives(_hall(), BALLS, [source], set() if seen is None else seen,
                                    [30.0], edge.EdgeSpec(count),
                                    np.random.default_rng(seed)))


def test_they_lie_beyond_the_field_and_clear_of_the_balls(source: Source) -> None:
    cut = _cut(source, 0)
    assert len(cut) == 12
    for (cx, cy, side), (x0, y0, x1, y1), k in cut:
        d = max(x1 - x0, y1 - y0)
        assert k == 0 and (x0 + x1) / 2 == pytest.approx(cx) and (y0 + y1) / 2 == pytest.approx(cy)
        assert y1 < FIELD_TOP - d + 8  # its lowest point more than its size above the edge
        assert side >= 2 * d - 1e-9  # framed as the check frames a ball
        for bx0, by0, bx1, by1 in BALLS:
            gap = np.hypot(cx - (bx0 + bx1) / 2, cy - (by0 + by1) / 2)
            assert gap >= side / 2 + 3 * (bx1 - bx0) / 2
    # the look-alike far from the ball is a candidate there, taken first; the one beside
    # the ball in the air is not cut at all
    first = cut[0][0]
    assert np.hypot(first[0] - LOOK_ALIKE[0], first[1] - LOOK_ALIKE[1]) < 4
    for x, y in (NEAR_BALL, *NOT_BEYOND):
        assert all(np.hypot(cx - x, cy - y) > 20 for (cx, cy, _), _, _ in cut)


def test_the_same_seed_gives_the_same_negatives(source: Source) -> None:
    a, b, c = _cut(source, 3), _cut(source, 3), _cut(source, 4)
    assert a == b
    assert a[0] == c[0]  # the candidate is no draw
    assert a[1:] != c[1:]  # the random squares are


def test_a_candidate_already_sampled_is_not_cut_again(source: Source) -> None:
    seen: set[tuple[int, int, int]] = set()
    first = _cut(source, 0, 1, seen)
    (cx, cy, side), _, _ = first[0]
    assert (round(cx), round(cy), round(side)) in seen
    again = _cut(source, 0, 1, seen)
    assert np.hypot(again[0][0][0] - cx, again[0][0][1] - cy) > 4


def test_no_field_no_negatives(source: Source) -> None:
    grey = np.full((800, 608, 3), 128, np.uint8)
    cv2.circle(grey, LOOK_ALIKE, 12, BALL_BGR, -1)
    assert edge.edge_negatives(grey, [], [source], set(), [30.0], edge.EdgeSpec(8),
                               np.random.default_rng(0)) == []


def test_with_sides_0_a_look_alike_at_the_edge_is_cut_too(source: Source) -> None:
    at_edge = NOT_BEYOND[1]
    cut = edge.edge_negatives(_hall(), BALLS, [source], set(), [30.0],
                              edge.EdgeSpec(2, sides=0.0), np.random.default_rng(0))
    assert [np.hypot(cx - at_edge[0], cy - at_edge[1]) < 4 for (cx, cy, _), _, _ in cut
            ].count(True) == 1
    for _, (_, _, _, y1), _ in cut:
        assert y1 < FIELD_TOP + 8  # its lowest point above the edge


def test_candidates_only_gives_no_random_square(source: Source) -> None:
    cut = edge.edge_negatives(_hall(), BALLS, [source], set(), [30.0],
                              edge.EdgeSpec(12, random=False), np.random.default_rng(0))
    assert len(cut) == 1 and np.hypot(cut[0][0][0] - LOOK_ALIKE[0],
                                      cut[0][0][1] - LOOK_ALIKE[1]) < 4
