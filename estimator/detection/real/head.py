"""A venue's own correction of the learned check, fitted on the venue's labelled frames.

The shared check (:mod:`check`) was trained on other venues; a new venue's ball, light and
look-alikes differ. From the same few labelled frames the colour model is fitted on, the
detector's candidates there (labelled ball / not by the boxes) and crops around each box
give the check's logit z0 and its 32 features f, and three context features c the shared
check cannot see (its crops are scaled to the blob): r = ln(diameter / expected diameter
at the blob's lowest row) from the venue's size line (:mod:`fit`; a shirt is far
larger than a ball at the same distance), r^2, and the field share of the crop's ring
(a ball lies on or near the field), and four of the blob itself g (:func:`blob_features`:
how ball-coloured, how large, how full and how round its box). The venue's logit is

    z = z0 + (f, c, g) . w + b

with (w, b) a ridge-penalised logistic regression (weights as the shared training:
positives up-weighted to balance, at most 8x), solved by Newton's method: small, exact,
deterministic. The penalty lam (how far the venue may move from the shared check) is
chosen by two-fold cross-validation over the venue's frames (even / odd by name) from
``LAMBDAS``: the value with the least held-out log-loss; the largest (close to no change)
wins ties, so a venue the shared check already suits keeps it. A blob far smaller than a
ball at its row (r < ``SMALLEST_R``) gets ``NO_BALL_LOGIT`` whatever the head says, and the
head reads r no larger than ``LARGEST_R``: above it the shared check alone weighs the size.

A venue with a head reports its best candidate from z >= 1 (``HEAD_THRESHOLD``, P 0.731),
not 0: the positives' up-weighting lifts every logit by up to ln 8, and at 0 a look-alike
was reported in 23 of the 44 held-out MSL test frames without a ball. The value was chosen
on those labelled images leaving each venue out: the threshold of the best F1 on the
other two venues was 1.0 for each of the three (docs/detection.md).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from estimator.detection.real.candidates import Coarse, find_coarse
from estimator.detection.real.check import BallCheck, crop_input, field_share
from estimator.detection.real.colour import ColourTables
from estimator.detection.real.model import HEAD_SIZE, BallModel

Box = tuple[float, float, float, float]
MARGIN_PX = 2.0

__all__ = ["HEAD_THRESHOLD", "LAMBDAS", "LARGEST_R", "NO_BALL_LOGIT", "SMALLEST_R",
           "HeadSamples", "blob_features", "context", "fit_head", "head_inputs", "head_samples",
           "inside", "venue_logits"]

LAMBDAS = (1.0, 4.0, 16.0, 64.0, 256.0)
NEWTON_STEPS = 25
MIN_POSITIVES = 10
MIN_NEGATIVES = 60
"""Fewer candidates than these in the labelled frames (e.g. 10 frames of a clean simulated
field: 7 balls, 16 other blobs): no head, the shared check as it is (a head fitted on
so few overfits, and the two-fold choice cannot tell)."""
MAX_POS_WEIGHT = 8.0
HEAD_THRESHOLD = 0.731059
"""P(ball) = 1 / (1 + e^-1), rounded as a ball file stores it: the logit 1."""
SMALLEST_R = -1.5
"""A blob whose larger side is under e^-1.5 (0.22) of the size line's diameter at its
lowest row (r < -1.5; r is 0 without a size line) is no ball, whatever the head says:
a head is linear in r and, fitted on ten frames, can carry a slope that lifts the
slivers at the image's foot (a ball there is 100 px) to P 1.0 (Bangkok fitted on its
frames 31-40: 11 such false hits of 20). Chosen on the four MSL folders fitted on four
choices of ten frames each (docs/detection.md): floors from -1.25 to -2.0 did the same;
a floor on blobs too large (r > 1.5) lost more balls than look-alikes."""
NO_BALL_LOGIT = -20.0
LARGEST_R = 1.0
"""The largest size ratio r a venue head reads (larger ones read as this). On a venue's
ten frames nearly every ball is within a factor e of the size line (|r| <= 1), and the
candidates above it are lamps, shirts and robot covers, so a head fitted there learns that
a large blob is no ball, and rejects a ball in the air, well above the line (Bordeaux: four
lobs in front of the ceiling at r = 3, P(ball) over 0.99 by the shared check, 0.006-0.06 with
the head). Chosen on the four MSL folders fitted on four choices of ten frames each
(docs/detection.md), among 0.5, 0.75, 1.0, 1.5 and none."""
JITTER_SCALE = 0.15
JITTER_SHIFT = 0.08

FloatArray = npt.NDArray[np.float64]


def context(boxes: FloatArray, field: FloatArray, model: BallModel) -> FloatArray:
    """N x 3 context features of blobs with full-resolution boxes (x0, y0, x1, y1) and
    field shares: r, r^2 (0 without a size line) and the field share."""
    a, b = model.size_line
    side = np.maximum(boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1])
    if a > 0:
        expected = np.maximum(a * boxes[:, 3] + b, 2.0)
        r = np.clip(np.log(np.maximum(side, 1.0) / expected), -3.0, 3.0)
    else:
        r = np.zeros(len(side))
    return np.stack([r, r * r, field], axis=1)


def head_inputs(feat: FloatArray, ctx: FloatArray, blobs: FloatArray) -> FloatArray:
    """What a venue head reads of its candidates: the check's features, the context with r
    (and r^2) capped at :data:`LARGEST_R`, and the blob's features."""
    r = np.minimum(ctx[:, 0], LARGEST_R)
    return np.hstack([feat, r[:, None], (r * r)[:, None], ctx[:, 2:], blobs])


def venue_logits(z0: FloatArray, feat: FloatArray, ctx: FloatArray, blobs: FloatArray,
                 head: tuple[float, ...] | None) -> FloatArray:
    """The venue's logits (the shared ones when it has no head), :data:`NO_BALL_LOGIT` for
    a blob far smaller than a ball at its row (:data:`SMALLEST_R`)."""
    z = z0
    if head is not None:
        w = np.asarray(head, np.float64)
        z = z0 + head_inputs(feat, ctx, blobs) @ w[:-1] + w[-1]
    return np.asarray(np.where(ctx[:, 0] < SMALLEST_R, NO_BALL_LOGIT, z), np.float64)


class HeadSamples:
    """Logits z0 (N), features (N x k), labels (N, 0/1), frame index (N) and weight (N)
    per sample (a positive and its jittered copies share a weight of 1)."""

    def __init__(self, z0: FloatArray, feat: FloatArray, y: FloatArray,
                 frame: npt.NDArray[np.int64], w: FloatArray | None = None) -> None:
        self.z0, self.feat, self.y, self.frame = z0, feat, y, frame
        self.w = np.ones(len(y)) if w is None else w

    def subset(self, keep: npt.NDArray[np.bool_]) -> HeadSamples:
        return HeadSamples(self.z0[keep], self.feat[keep], self.y[keep], self.frame[keep],
                           self.w[keep])


def _weights(s: HeadSamples) -> FloatArray:
    pos = float((s.w * s.y).sum())
    neg = float((s.w * (1.0 - s.y)).sum())
    ratio = min(MAX_POS_WEIGHT, neg / pos) if pos > 0 else 1.0
    return np.asarray(s.w * np.where(s.y > 0.5, max(ratio, 1.0), 1.0), np.float64)


def _objective(s: HeadSamples, x: FloatArray, sw: FloatArray, theta: FloatArray,
               lam: float) -> float:
    z = s.z0 + x @ theta
    return float((sw * np.logaddexp(0.0, np.where(s.y > 0.5, -z, z))).sum()
                 + lam * theta @ theta)


def _solve(s: HeadSamples, lam: float) -> FloatArray:
    """(w, b) minimising the weighted log-loss of z0 + f . w + b plus lam |(w, b)|^2:
    Newton's steps, each halved until the objective falls (so it never diverges)."""
    x = np.hstack([s.feat, np.ones((len(s.y), 1))])
    sw = _weights(s)
    theta = np.zeros(x.shape[1])
    current = _objective(s, x, sw, theta, lam)
    for _ in range(NEWTON_STEPS):
        p = 0.5 * (1.0 + np.tanh(0.5 * (s.z0 + x @ theta)))  # the logistic, overflow-free
        grad = x.T @ (sw * (p - s.y)) + 2.0 * lam * theta
        hess = (x.T * (sw * p * (1.0 - p))) @ x + 2.0 * lam * np.eye(x.shape[1])
        step = np.linalg.solve(hess, grad)
        for _ in range(30):
            trial = theta - step
            value = _objective(s, x, sw, trial, lam)
            if value < current:
                theta, current = trial, value
                break
            step = step / 2.0
        else:
            break
    return theta


def _loss(s: HeadSamples, theta: FloatArray) -> float:
    z = s.z0 + s.feat @ theta[:-1] + theta[-1]
    sw = _weights(s)
    # log(1 + e^-z) for y = 1, log(1 + e^z) for y = 0, stably
    per = np.logaddexp(0.0, np.where(s.y > 0.5, -z, z))
    return float((sw * per).sum() / sw.sum())


def fit_head(samples: HeadSamples, lambdas: Sequence[float] = LAMBDAS
             ) -> tuple[FloatArray | None, float]:
    """The venue's (w, b) (HEAD_SIZE numbers) and the lam chosen; (None, inf) with too few
    samples or without positives in both halves (nothing to cross-validate)."""
    halves = [samples.frame % 2 == k for k in (0, 1)]
    positives = float((samples.y * samples.w).sum())
    if positives < MIN_POSITIVES or len(samples.y) - positives < MIN_NEGATIVES or any(
            samples.y[h].sum() == 0 or samples.y[~h].sum() == 0 for h in halves):
        return None, float("inf")
    zero = np.zeros(samples.feat.shape[1] + 1)
    best_lam, best = float("inf"), sum(_loss(samples.subset(h), zero) for h in halves)
    for lam in sorted(lambdas, reverse=True):
        held = sum(_loss(samples.subset(h), _solve(samples.subset(~h), lam)) for h in halves)
        if held < best - 1e-9:
            best_lam, best = lam, held
    if best_lam == float("inf"):
        return None, best_lam
    return _solve(samples, best_lam), best_lam


def inside(cx: float, cy: float, balls: Sequence[Box]) -> bool:
    return any(x0 - MARGIN_PX <= cx <= x1 + MARGIN_PX and y0 - MARGIN_PX <= cy <= y1 + MARGIN_PX
               for x0, y0, x1, y1 in balls)


def blob_features(coarse: Sequence[Coarse]) -> FloatArray:
    """N x 4 features of the half-resolution blobs themselves: mean colour log-likelihood
    ratio, log of the larger side, fill (pixels / box area) and aspect (short / long)."""
    if not coarse:
        return np.zeros((0, 4))
    box = np.array([c.box for c in coarse], np.float64)
    w, h = box[:, 2] - box[:, 0], box[:, 3] - box[:, 1]
    half = np.array([c.scale / 2.0 for c in coarse], np.float64)  # in half-resolution px
    mean = np.array([c.mean for c in coarse], np.float64)
    pixels = np.array([c.score for c in coarse], np.float64) / np.where(mean > 0, mean, 1.0)
    return np.stack([mean / 16.0, np.log(np.maximum(w, h) * half), pixels / (w * h),
                     np.minimum(w, h) / np.maximum(w, h)], axis=1)


def _jittered(squares: list[tuple[float, float, float]], positive: list[bool], copies: int,
              rng: np.random.Generator) -> tuple[list[tuple[float, float, float]], list[int]]:
    """Each positive's square, ``copies`` times, shifted and scaled a little (the framing
    a candidate of another frame would give): the squares and their candidates' index."""
    out, owner = [], []
    for i, ((cx, cy, side), pos) in enumerate(zip(squares, positive, strict=True)):
        for _ in range(copies if pos else 0):
            k = float(np.exp(rng.uniform(-JITTER_SCALE, JITTER_SCALE)))
            dx, dy = rng.uniform(-JITTER_SHIFT, JITTER_SHIFT, 2) * side
            out.append((cx + float(dx), cy + float(dy), side * k))
            owner.append(i)
    return out, owner


def head_samples(samples: Sequence[tuple[npt.NDArray[np.uint8], Sequence[Box]]],
                 model: BallModel, check: BallCheck, *, max_count: int = 24,
                 step: int = 2, fine: int = 0, copies: int = 0) -> HeadSamples:
    """The check's logits and features (its 32, the 3 context ones, the blob's 4) on the
    detector's candidates in each labelled frame, labelled by the boxes as the scoring
    does: exactly what the head sees at run time; each positive also framed ``copies``
    more times a little off (seeded), sharing its weight."""
    tables = ColourTables.of(model)
    rng = np.random.default_rng(0)
    z0, feat, y, frame, w = [], [], [], [], []
    for index, (image, balls) in enumerate(samples):
        coarse = find_coarse(image, tables, model, max_count=max_count, step=step, fine=fine)
        if not coarse:
            continue
        squares = [check.spec.square(*c.centre()) for c in coarse]
        labels = [inside(cx, cy, balls) for cx, cy, _ in squares]
        extra, owner = _jittered(squares, labels, copies, rng)
        batch = crop_input(image, squares + extra, tables, check.spec)
        boxes = np.array([c.full_box() for c in coarse], np.float64)[list(range(len(coarse)))
                                                                       + owner]
        ctx = context(boxes, field_share(batch.crops), model)
        raw, f = check.raw(batch, ctx)
        z0.append(raw[:, 0])
        blobs = blob_features(coarse)[list(range(len(coarse))) + owner]
        feat.append(head_inputs(f, ctx, blobs))
        y += [float(v) for v in labels] + [1.0] * len(extra)
        frame += [index] * (len(coarse) + len(extra))
        w += [1.0 / (1 + copies) if v else 1.0 for v in labels] + [1.0 / (1 + copies)] * len(extra)
    if not z0:
        return HeadSamples(np.zeros(0), np.zeros((0, HEAD_SIZE - 1)), np.zeros(0),
                           np.zeros(0, np.int64))
    return HeadSamples(np.concatenate(z0), np.concatenate(feat), np.asarray(y, np.float64),
                       np.asarray(frame, np.int64), np.asarray(w, np.float64))
