"""Balls in the air for the learned check's training (``train.py --flying SHARE``).

A ball in flight is small, dark and smeared by its motion, and seen against the hall's roof,
its banners or the field's far side rather than on the green. The labelled images hold few
such balls (1.2 % of the positive crops have under 30 % field in their ring), so a share of
the real positive crops (``dataset.py``, five channels) gives one more each: its ball (the
disc the regression target gives) shrunk about the crop's centre, darkened, pasted onto a
negative crop with little field green in its ring (a background beside or beyond the
field: what the check was shown there), and smeared by a linear motion blur of random
length and direction (the ball alone moves: the blurred ball's coverage mixes it with the
background). Look-alikes (negative crops) are made over alike and stay negatives, as many
a ball as the samples have negatives per positive. The targets and the context features
follow: the offset and log size scale with the shrink, ``r`` moves by its log, the field
share is the new crop's.

Works on the samples as the check sees them (no image is read), so it runs from the sample
cache. Seeded: the same samples and generator give the same crops. Held out by event it
was not better (docs/notes/detection.md, "Balls in the air"): off by default.
"""

from __future__ import annotations

import cv2
import numpy as np

PX = 24
SHRINK = (0.45, 1.0)
"""Ball diameter scale (a far ball framed by the smallest crop side is about half size)."""
DARK = (0.35, 1.0)
"""Gain on the ball's pixels."""
BLUR_PX = (1.0, 9.0)
"""Motion blur length in crop pixels (the framed ball is about 12 across)."""
RIM = 0.9
"""The disc cut from a positive, over its label box's half side (a box holds a rim of what
lies behind the ball)."""
FRAMED = (0.2, 0.5)
"""A positive is pasted only when its ball is framed: its centre within this share of the
crop's side from the middle, the log of its size within this of the framing's."""
NO_FIELD = 0.3
"""Largest field share of a background crop's ring (few crops have none: 157 of 52,813
negatives under 0.1, 472 under 0.3)."""
MAX_PER_BALL = 8.0
"""At most this many look-alikes in the air per ball in the air (``train.py``'s cap on the
positives' weight)."""
MIN_BACKGROUNDS = 20
"""Backgrounds at the least: the negatives with the least field when fewer have none."""


def motion_kernel(length: float, angle: float) -> np.ndarray:
    """Normalised line kernel of ``length`` pixels at ``angle`` (radians), its points
    spread over their four nearest taps (so a fractional length blurs partly)."""
    half = int(np.ceil(length / 2)) + 1
    k = np.zeros((2 * half + 1, 2 * half + 1), np.float64)
    t = np.linspace(-length / 2, length / 2, max(2, int(np.ceil(length * 4))))
    px, py = half + t * np.cos(angle), half + t * np.sin(angle)
    x0, y0 = np.floor(px).astype(int), np.floor(py).astype(int)
    fx, fy = px - x0, py - y0
    for dy, dx, w in ((0, 0, (1 - fx) * (1 - fy)), (0, 1, fx * (1 - fy)),
                      (1, 0, (1 - fx) * fy), (1, 1, fx * fy)):
        np.add.at(k, (y0 + dy, x0 + dx), w)
    return (k / k.sum()).astype(np.float32)


def _ring_field(crop: np.ndarray) -> float:
    edge = PX // 4
    ring = np.ones((PX, PX), bool)
    ring[edge:-edge, edge:-edge] = False
    return float(crop[4][ring].mean())


def fly_one(ball: np.ndarray, off: np.ndarray, ctx: np.ndarray, background: np.ndarray,
            rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One flying ball: the positive crop ``ball`` (5 x 24 x 24) with target ``off`` and
    context ``ctx`` over ``background``; returns the crop, target and context."""
    s = float(rng.uniform(*SHRINK))
    gain = float(rng.uniform(*DARK))
    colour = rng.uniform(0.85, 1.15, 3).astype(np.float32)
    length, angle = float(rng.uniform(*BLUR_PX)), float(rng.uniform(0.0, np.pi))
    c = PX / 2
    warp = np.float32([[s, 0, c * (1 - s)], [0, s, c * (1 - s)]])
    fg = cv2.warpAffine(np.ascontiguousarray(ball.transpose(1, 2, 0)), warp, (PX, PX),
                        flags=cv2.INTER_AREA, borderMode=cv2.BORDER_REPLICATE)
    bx, by = c + s * off[0] * PX, c + s * off[1] * PX
    radius = RIM * s * PX / 2 * float(np.exp(off[2])) / 2
    yy, xx = np.mgrid[0:PX, 0:PX].astype(np.float32) + 0.5
    mask = np.clip(radius + 0.5 - np.hypot(xx - bx, yy - by), 0.0, 1.0).astype(np.float32)
    fg[..., :3] *= gain * colour
    fg[..., 3] *= float(rng.uniform(0.5, 1.0))
    fg[..., 4] = 0.0
    kernel = motion_kernel(length, angle)
    cover = cv2.filter2D(mask, -1, kernel, borderType=cv2.BORDER_REPLICATE)
    smear = cv2.filter2D(fg * mask[..., None], -1, kernel, borderType=cv2.BORDER_REPLICATE)
    bg = background.transpose(1, 2, 0)
    out = np.clip(smear + (1.0 - cover)[..., None] * bg, 0.0, 1.0).transpose(2, 0, 1)
    out = np.ascontiguousarray(out, np.float32)
    new_off = np.array([s * off[0], s * off[1], off[2] + np.log(s)], np.float32)
    r = float(np.clip(ctx[0] + np.log(s), -3.0, 3.0)) if ctx[0] != 0 or ctx[1] != 0 else 0.0
    return out, new_off, np.array([r, r * r, _ring_field(out)], np.float32)


def flying(x: np.ndarray, y: np.ndarray, off: np.ndarray, ctx: np.ndarray, share: float,
           rng: np.random.Generator, per_ball: float | None = None
           ) -> tuple[np.ndarray, ...]:
    """Balls in the air for ``share`` of the framed positives of (x, y, offset, context) (drawn
    with replacement above 1), and ``per_ball`` look-alikes in the air for each: negatives'
    middles (the blob, framed as a ball is) made over in the same way and labelled 0, so
    that a crop with no field and a smeared blob does not mean a ball by itself. By
    default ``per_ball`` is the samples' negatives per positive, at most ``MAX_PER_BALL``:
    ``train.py`` weighs a positive by that ratio, so the look-alikes in the air then weigh
    as much as the balls (one each let the check call 83-100 % of the held-out events'
    crops with little field a ball). The extra samples as
    the same four arrays, positives first. Backgrounds: the negatives with at most
    ``NO_FIELD`` field in their ring (the ``MIN_BACKGROUNDS`` with the least when fewer)."""
    framed = (np.abs(off[:, :2]).max(axis=1) <= FRAMED[0]) & (np.abs(off[:, 2]) <= FRAMED[1])
    pos, neg = np.flatnonzero((y > 0) & framed), np.flatnonzero(y == 0)
    bgs = neg[np.argsort(ctx[neg, 2], kind="stable")[:max(MIN_BACKGROUNDS, int(np.sum(
        ctx[neg, 2] <= NO_FIELD)))]]
    if per_ball is None:
        per_ball = min(MAX_PER_BALL, len(neg) / max(1, int(np.sum(y > 0))))
    count = round(share * len(pos))
    alike = round(per_ball * count)
    chosen = np.concatenate([rng.choice(pos, count, replace=count > len(pos)),
                             rng.choice(neg, alike, replace=alike > len(neg))])
    n = len(chosen)
    xs = np.empty((n, *x.shape[1:]), np.float32)
    offs = np.empty((n, 3), np.float32)
    ctxs = np.empty((n, ctx.shape[1]), np.float32)
    for k, i in enumerate(chosen):
        xs[k], offs[k], ctxs[k] = fly_one(x[i], off[i], ctx[i], x[rng.choice(bgs)], rng)
    return xs, (np.arange(n) < count).astype(np.float32), offs, ctxs
