"""Training samples for the real-ball detector's learned check, from labelled folders.

Offline (not the detector's run time). Per folder: the venue's ball model is fitted on the
folder's first ``TRAIN_COUNT`` labelled images by name (as a team would, and as
``dsp-eval --suite images`` does); then on every image of the folder the detector's own
candidates (up to ``MAX_CANDIDATES``) are cut out as the check sees them at run time,
labelled 1 when the candidate's centre lies in a ball box grown by 2 px (the scoring's
rule), with the box's centre and size as the regression target. Each ball box also gives
``LABEL_COPIES`` crops centred near it (jittered in place, size and light), so every ball,
even one the colour map cut badly, is a positive. Which images a model may learn from is
chosen in ``train.py`` from each sample's folder and image index. Seeded: the same
folders give the same samples.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from edge import NO_EDGE, EdgeSpec, edge_negatives

from dsp.labelled import Labelled, find_labelled
from estimator.detection.real.candidates import find_coarse
from estimator.detection.real.check import SPEC, crop_input, field_share
from estimator.detection.real.colour import ColourTables
from estimator.detection.real.fit import fit_ball_model
from estimator.detection.real.head import context
from estimator.detection.real.model import BallModel

TRAIN_COUNT = 10
MAX_CANDIDATES = 48
GENERIC_CANDIDATES = 24
LABEL_COPIES = 6
MARGIN_PX = 2.0
Box = tuple[float, float, float, float]


@dataclass
class Samples:
    x: np.ndarray  # N x 5 x 24 x 24 float32
    y: np.ndarray  # N float32 (1: a ball)
    offset: np.ndarray  # N x 3 float32: (ball centre - crop centre) / side, log size
    image: np.ndarray  # N int: image index within its folder (by name)
    label_crop: np.ndarray  # N bool: made from a label box, not a candidate
    ctx: np.ndarray  # N x 3 float32: the context features of the sample


def _inside(cx: float, cy: float, balls: Sequence[Box]) -> Box | None:
    best: tuple[float, Box] | None = None
    for box in balls:
        x0, y0, x1, y1 = box
        if x0 - MARGIN_PX <= cx <= x1 + MARGIN_PX and y0 - MARGIN_PX <= cy <= y1 + MARGIN_PX:
            d = (cx - (x0 + x1) / 2) ** 2 + (cy - (y0 + y1) / 2) ** 2
            if best is None or d < best[0]:
                best = (d, box)
    return None if best is None else best[1]


def _target(box: Box, cx: float, cy: float, side: float) -> tuple[float, float, float]:
    """The box's centre from the crop's in crop sides, and the log of the box's larger side
    over side / context (0 when the crop is framed as the check frames a ball)."""
    x0, y0, x1, y1 = box
    return (((x0 + x1) / 2 - cx) / side, ((y0 + y1) / 2 - cy) / side,
            float(np.log(max(x1 - x0, y1 - y0, 1.0) * SPEC.context / side)))


def _label_squares(balls: Sequence[Box], rng: np.random.Generator) -> list[tuple]:
    out = []
    for x0, y0, x1, y1 in balls:
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
        side0 = max(SPEC.min_side_px, SPEC.context * max(x1 - x0, y1 - y0))
        for _ in range(LABEL_COPIES):
            side = side0 * float(np.exp(rng.uniform(-0.25, 0.25)))
            jx, jy = rng.uniform(-0.12, 0.12, 2) * side
            out.append((cx + jx, cy + jy, side, (x0, y0, x1, y1)))
    return out


def _image_samples(image: np.ndarray, balls: list[Box], model, tables: ColourTables,
                   rng: np.random.Generator, generic=None,
                   seen: set[tuple[int, int, int]] | None = None) -> list[tuple]:
    """The image's candidate and label-box rows; ``seen`` gets the candidates' keys."""
    rows = []
    sources = [(model, tables, MAX_CANDIDATES)]
    if generic is not None:
        sources.append((generic[0], generic[1], GENERIC_CANDIDATES))
    seen = set() if seen is None else seen
    taken = set()
    for k, (m, t, count) in enumerate(sources):
        for c in find_coarse(image, t, m, max_count=count):
            cx, cy, side = SPEC.square(*c.centre())
            key = (round(cx), round(cy), round(side))
            taken.add(key)
            if k == 0:
                seen.add(key)
            elif key in seen:
                continue
            box = _inside(cx, cy, balls)
            target = (0.0, 0.0, 0.0) if box is None else _target(box, cx, cy, side)
            rows.append(((cx, cy, side), float(box is not None), target, False, image,
                         c.full_box(), m))
    for cx, cy, side, box in _label_squares(balls, rng):
        gain = float(rng.uniform(0.75, 1.3))
        bias = float(rng.uniform(-15, 15))
        lit = np.clip(image.astype(np.float32) * gain + bias, 0, 255).astype(np.uint8) \
            if abs(gain - 1) > 0.02 else image
        rows.append(((cx, cy, side), 1.0, _target(box, cx, cy, side), True, lit, box, model))
    seen |= taken
    return rows


def _edge_rows(image: np.ndarray, balls: list[Box], sources: list, seen: set,
               sizes: list[float], edge: EdgeSpec, rng: np.random.Generator
               ) -> list[tuple]:
    """The negatives beyond the field's far edge ``edge`` asks for (``edge.py``), as rows."""
    return [(square, 0.0, (0.0, 0.0, 0.0), False, image, box, sources[k][0])
            for square, box, k in edge_negatives(image, balls, sources, seen, sizes, edge,
                                                 rng)]


def build_folder(folder: Path, seed: int = 0, ball_class: int = 0,
                 edge: EdgeSpec = NO_EDGE) -> Samples:
    """Every sample of one folder of labelled images."""
    return build_items(find_labelled(folder), seed, ball_class, edge=edge)


def build_items(labelled: Sequence[Labelled], seed: int = 0, ball_class: int = 0,
                generic: BallModel | None = None, edge: EdgeSpec = NO_EDGE) -> Samples:
    """Every sample of one venue's labelled images (a folder's, or an event's of several
    folders, in the order given): the venue model fitted on the first ``TRAIN_COUNT``; with
    ``generic`` (a model that never saw the venue), its candidates too (up to
    ``GENERIC_CANDIDATES`` an image, those the venue model found already left out), so the
    check also learns the look-alikes a venue with no labelled frame meets. With
    ``edge.count``, each image also gives up to that many negatives beyond the field's far
    edge (``edge.py``: the venue's and the generic model's candidates there, then random
    squares; drawn from a generator of their own, so the other samples stay the same)."""
    cv2.setNumThreads(1)
    items = [it.read(ball_class) for it in labelled]
    model = fit_ball_model(items[:TRAIN_COUNT], info={"images": TRAIN_COUNT})
    tables = ColourTables.of(model)
    gen = None if generic is None else (generic, ColourTables.of(generic))
    rng = np.random.default_rng(seed)
    edge_rng = np.random.default_rng([seed, 2])
    sources = [(model, tables)] + ([] if gen is None else [gen])
    sizes = [float(max(b[2] - b[0], b[3] - b[1])) for _, balls in items for b in balls]
    xs, ys, offs, idx, lab, ctx = [], [], [], [], [], []
    for index, (image, balls) in enumerate(items):
        seen: set[tuple[int, int, int]] = set()
        rows = _image_samples(image, balls, model, tables, rng, gen, seen)
        if edge.count > 0:
            rows += _edge_rows(image, balls, sources, seen, sizes or [SPEC.min_side_px],
                               edge, edge_rng)
        for square, y, off, from_label, img, box, m in rows:
            t = tables if m is model else gen[1]
            x = crop_input(img, [square], t).crops
            xs.append(x[0])
            ctx.append(context(np.asarray([box], np.float64), field_share(x), m)[0])
            ys.append(y)
            offs.append(off)
            idx.append(index)
            lab.append(from_label)
    return Samples(np.asarray(xs, np.float32), np.asarray(ys, np.float32),
                   np.asarray(offs, np.float32), np.asarray(idx, np.int32),
                   np.asarray(lab, bool), np.asarray(ctx, np.float32))
