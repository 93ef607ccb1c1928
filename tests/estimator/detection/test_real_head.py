"""The venue head's samples with downscaled copies of the labelled frames: the copies add
the frame's own ball smaller (its blob smaller by the scale) while its context, measured
in the frame's geometry, says what the original's did, and they count as the frame's in
the cross-validation, but not as evidence of their own that the frames are enough for a
head. The images are the committed subset in tests/data/msl-images.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest

from dsp.labelled import find_labelled
from estimator.detection.real import BallCheck, fit_ball_model
from estimator.detection.real.head import (
    MIN_POSITIVES,
    SCALE_COPIES,
    HeadSamples,
    fit_head,
    head_samples,
)

SUBSET = Path(__file__).resolve().parents[2] / "data" / "msl-images" / "20220715" / "r7"
R, LOG_SIDE = 32, 36  # columns of the context's r and of the blob's log side


@pytest.fixture(scope="module")
def frames() -> list[tuple[np.ndarray, list[tuple[float, float, float, float]]]]:
    return [it.read(0) for it in find_labelled(SUBSET)][:10]


def test_a_copy_shows_the_frames_ball_smaller_at_the_size_lines_ratio(frames: list) -> None:
    check = BallCheck(files("estimator.detection.real").joinpath("ball_check.onnx").read_bytes())
    model = fit_ball_model(frames)
    assert model.size_line[0] > 0  # r means something on this venue
    balls = [k for k, (_, boxes) in enumerate(frames) if boxes]
    some = [frames[k] for k in balls[:3]]
    alone = head_samples(some, model, check, fine=8)
    both = head_samples(some, model, check, fine=8, scales=(0.7,))
    assert len(both.y) > len(alone.y) and both.y.sum() > alone.y.sum()
    assert set(both.frame.tolist()) == set(alone.frame.tolist())  # no frame of its own
    compared = 0
    for index in sorted(set(alone.frame.tolist())):
        n = int((alone.frame == index).sum())
        rows = np.flatnonzero(both.frame == index)  # the frame's own samples, then its copy's
        np.testing.assert_array_equal(both.feat[rows[:n]], alone.feat[alone.frame == index])
        original, copy = rows[:n][both.y[rows[:n]] > 0.5], rows[n:][both.y[rows[n:]] > 0.5]
        if not (len(original) and len(copy)):
            continue
        # the ball's blob at 0.7 of its side (ln 0.7 = -0.36), its r as in the frame
        side = np.median(both.feat[copy, LOG_SIDE]) - np.median(both.feat[original, LOG_SIDE])
        assert -0.6 < side < -0.15
        r = np.median(both.feat[copy, R]) - np.median(both.feat[original, R])
        assert abs(r) < 0.25
        compared += 1
    assert compared >= 2


def test_copies_are_no_evidence_of_their_own_for_fitting_a_head(frames: list) -> None:
    """Four frames hold too few balls for a head; their copies do not make up for it."""
    check = BallCheck(files("estimator.detection.real").joinpath("ball_check.onnx").read_bytes())
    model = fit_ball_model(frames[:4])
    both = head_samples(frames[:4], model, check, fine=8, scales=SCALE_COPIES)
    assert both.copy.any() and not both.copy.all()
    assert float(both.y[~both.copy].sum()) < MIN_POSITIVES <= float(both.y.sum())
    assert fit_head(both) == (None, float("inf"))
    counted = HeadSamples(both.z0, both.feat, both.y, both.frame, both.w)  # as if originals
    assert fit_head(counted)[0] is not None
