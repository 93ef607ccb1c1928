"""The venue's logits: a blob far smaller than a ball at its row (r < SMALLEST_R) is no
ball whatever the head's slope in r says, on arrays and in the detector on the committed
real subset (tests/data/msl-images); the head reads r capped at LARGEST_R, as it is fitted."""

from __future__ import annotations

import dataclasses
import math
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest

from dsp.labelled import find_labelled
from estimator.detection.real import BallCheck, RealBallDetector, adapt, fit_ball_model
from estimator.detection.real.head import (
    LARGEST_R,
    NO_BALL_LOGIT,
    SMALLEST_R,
    head_inputs,
    head_samples,
    inside,
    venue_logits,
)
from estimator.detection.real.model import HEAD_SIZE

SUBSET = Path(__file__).resolve().parents[2] / "data" / "msl-images" / "20220715" / "r7"
R = 32  # the head's weight of the context's r follows the check's 32 features


def test_a_blob_far_under_the_size_line_gets_no_ball_whatever_the_head() -> None:
    z0 = np.array([3.0, 3.0, 3.0, 3.0])
    ctx = np.array([[-3.0, 9.0, 0.5], [-1.6, 2.56, 0.5], [-1.4, 1.96, 0.5], [0.0, 0.0, 0.5]])
    feat, blobs = np.zeros((4, 32)), np.zeros((4, 4))
    np.testing.assert_array_equal(venue_logits(z0, feat, ctx, blobs, None),
                                  [NO_BALL_LOGIT, NO_BALL_LOGIT, 3.0, 3.0])
    head = [0.0] * HEAD_SIZE
    head[R] = -5.0  # a slope that lifts small blobs: +8 at r = -1.6
    np.testing.assert_allclose(venue_logits(z0, feat, ctx, blobs, tuple(head)),
                               [NO_BALL_LOGIT, NO_BALL_LOGIT, 10.0, 3.0])


def test_the_head_reads_r_no_larger_than_the_cap() -> None:
    """A head that learnt "larger than a ball at its row: no ball" (a steep negative slope
    in r and r^2) lowers a blob at r = 3 (a ball in the air) no more than one at the cap;
    below the cap it reads r as it is, and the shared logit alone is not capped."""
    z0 = np.full(4, 6.0)
    rs = np.array([0.5, LARGEST_R, 2.0, 3.0])
    ctx = np.stack([rs, rs * rs, np.full(4, 0.9)], axis=1)
    feat, blobs = np.zeros((4, 32)), np.zeros((4, 4))
    head = [0.0] * HEAD_SIZE
    head[R], head[R + 1] = -1.0, -1.0
    z = venue_logits(z0, feat, ctx, blobs, tuple(head))
    capped = 6.0 - LARGEST_R - LARGEST_R**2
    np.testing.assert_allclose(z, [6.0 - 0.5 - 0.25, capped, capped, capped])
    np.testing.assert_array_equal(venue_logits(z0, feat, ctx, blobs, None), z0)
    x = head_inputs(feat, ctx, blobs)
    assert x.shape == (4, HEAD_SIZE - 1)
    np.testing.assert_array_equal(x[:, R], [0.5, LARGEST_R, LARGEST_R, LARGEST_R])
    np.testing.assert_array_equal(x[:, R + 2], ctx[:, 2])


def test_the_head_is_fitted_on_what_it_reads() -> None:
    """The head's samples carry r capped as the detector's logits read it: no sample of
    the subset's fit is over the cap, though some of its candidates are."""
    check = BallCheck(files("estimator.detection.real").joinpath("ball_check.onnx").read_bytes())
    frames = [it.read(0) for it in find_labelled(SUBSET)][:10]
    model = fit_ball_model(frames)
    samples = head_samples(frames, model, check)
    assert samples.feat.shape[1] == HEAD_SIZE - 1
    r = samples.feat[:, R]
    assert r.max() == LARGEST_R
    np.testing.assert_array_equal(samples.feat[:, R + 1], r * r)


def test_the_detector_gives_no_ball_to_blobs_far_under_the_size_line() -> None:
    """The subset's venue with its size line ten times too steep: every candidate whose
    box is under e^-1.5 of the line's diameter at its foot scores the floor's P, the
    others keep the check's; with the fitted line the ball is found."""
    check = BallCheck(files("estimator.detection.real").joinpath("ball_check.onnx").read_bytes())
    frames = [it.read(0) for it in find_labelled(SUBSET)]
    model = adapt(fit_ball_model(frames[:10]), frames[:10], check)
    a, b = model.size_line
    assert a > 0
    image, balls = next((f for f in frames[10:] if f[1]), frames[10])
    found = RealBallDetector(model, check).detect(image)
    assert found is not None and inside(found.cx_px, found.cy_px, balls)
    steep = dataclasses.replace(model, size_line=(10 * a, 10 * b))
    ranked = RealBallDetector(steep, check).candidates(image)
    floor = 1.0 / (1.0 + math.exp(-NO_BALL_LOGIT))
    small = []
    for c in ranked[1:]:  # the first is measured again at full resolution
        _, y, w, h = c.detection.bbox_px
        expected = max(10 * a * (y + h) + 10 * b, 2.0)
        if max(w, h) < math.exp(SMALLEST_R) * expected * 0.95:
            small.append(c.check_score)
        elif max(w, h) > math.exp(SMALLEST_R) * expected * 1.05:
            assert c.check_score != pytest.approx(floor, rel=1e-6, abs=0)
    assert len(small) >= 3 and small == pytest.approx([floor] * len(small), rel=1e-6, abs=0)


@pytest.mark.parametrize("lam", [0.3, 3.0, 30.0])
def test_the_head_s_fit_is_the_minimum_of_its_penalised_loss(lam: float) -> None:
    """Guards Newton's steps of the head's fit (no files needed): at the (w, b) found, the
    gradient of the weighted log-loss plus lam |(w, b)|^2, taken here by central
    differences of that objective, is zero; a ridge gradient without its factor 2 stops
    elsewhere."""
    from estimator.detection.real.head import HeadSamples, _objective, _solve, _weights

    rng = np.random.default_rng(5)
    n, k = 200, 6
    feat = rng.normal(size=(n, k))
    y = (feat @ rng.normal(size=k) + rng.normal(0.0, 1.0, n) > 0.8).astype(np.float64)
    s = HeadSamples(rng.normal(0.0, 0.5, n), feat, y, np.arange(n, dtype=np.int64))
    theta = _solve(s, lam)
    x = np.hstack([feat, np.ones((n, 1))])
    sw = _weights(s)
    h = 1e-6
    grad = np.array([(_objective(s, x, sw, theta + h * e, lam)
                      - _objective(s, x, sw, theta - h * e, lam)) / (2 * h)
                     for e in np.eye(k + 1)])
    assert np.abs(grad).max() < 1e-4 * max(1.0, lam * float(np.abs(theta).max())), grad
    assert np.abs(theta).max() > 1e-3  # a fit that moved, not the zero start
