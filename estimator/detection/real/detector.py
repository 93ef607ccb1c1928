"""The real-ball detector: a venue's colour model proposes, a learned check decides.

    image --colour map (half resolution, or every step-th pixel of a large frame)-->
          blobs at the model's levels (candidates.find_coarse)
          --crops (5 channels)--> the check's P(ball), centre and size (check.BallCheck)
          --the venue's head (head.venue_logits)
          --less the off-field penalty (field.OffField)--> best P >= threshold: the ball

A candidate above the field's far edge (:mod:`field`: the convex hull of the image's
field green, found at an eighth of the resolution) by more than its own size needs more
evidence: its logit loses ``ln(b / d)`` (``b`` px above the edge, ``d`` its size), so one
k sizes up needs k times the odds, to be reported and to win over one on the field. A ball
in the air is above the edge too: it loses the same, and one the check is sure of is still
reported. The candidate's ``beyond_px`` says how far above the edge it lies.

The ball is the candidate with the highest (penalised) venue logit (ties: the most ball-coloured,
then top to bottom, left to right); it is reported when its P(ball) reaches the model's
threshold. Its centroid is the check's regressed centre (the centre of the ball as
labelled, which a colour blob shaded on one side or cut by a robot is not), refined once
(the winner cut out again around that centre at the regressed size, as the check was
trained to see a ball, and checked again), blended with the centre of the winner's colour
blob's box at full resolution by the model's ``centre_blend`` (0.5: the mean; the two
err partly independently, and the labelled box is the visible part of the ball, which
is what the blob's box measures where the colour is clean). A blob the image's border cuts
gives its box's centre alone: the label of a ball cut by the border is its visible part,
which the blob's box measures, while the check regresses where the whole ball would be.
Area, box, outline and circularity are the blob's (:func:`candidates.measure`).

A camera image also has its far balls' specks looked at in full resolution (``fine``, 8
of them, :func:`candidates.find_coarse`). A large frame (the project's 1080 x 1080 omni
images) is searched with ``step`` 4: the colour map of every 4th pixel of every 4th row, a
sixteenth of the pixels, only the ``max_candidates`` most ball-coloured blobs are checked
and no specks (see :func:`search_for`).

Without a check (``check=None``) the detector is the colour model alone: the most
ball-coloured candidate is the ball, at its blob's moments (the baseline).

Pure and deterministic: the same image gives the same bits whatever OpenCV's thread count.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from estimator.detection.chain import Detection
from estimator.detection.real.candidates import Coarse, find_coarse, measure
from estimator.detection.real.check import SPEC, BallCheck, Square, crop_input, field_share
from estimator.detection.real.colour import ColourTables
from estimator.detection.real.field import OFF_FIELD, OffField, beyond, find_field
from estimator.detection.real.head import blob_features, context, venue_logits
from estimator.detection.real.model import BallModel
from estimator.errors import DetectionError

__all__ = ["LARGE_FRAME_PX", "Candidate", "RealBallDetector", "Search", "search_for"]

LARGE_FRAME_PX = 1_000_000
"""Frames of more pixels than this are searched with the strided map by default."""


@dataclass(frozen=True)
class Candidate:
    """A ball-coloured region and what the learned check made of it."""

    detection: Detection
    colour_score: float
    """Mean log-likelihood ratio (ball vs. not, the venue's colour model) over the blob."""
    check_score: float
    """The learned check's probability that the region is a ball (0-1)."""
    field_score: float
    """Share of field-green pixels in the ring of the candidate's crop (0-1)."""
    beyond_px: float = 0.0
    """How far the candidate's lowest point (its box's bottom centre) lies beyond the
    field's hull [px] (:mod:`field`; 0 on the field, or when no field was found)."""


@dataclass(frozen=True)
class Search:
    """How a frame is searched: the colour map's step (2: half resolution by area
    averaging; more: every step-th pixel of every step-th row) and how many candidates
    the check sees."""

    step: int = 2
    max_candidates: int = 24
    refine: bool = True
    fine: int = 8
    """Far balls' specks (too small for the size range in the map) looked at again in
    full resolution, checked beside the blobs (:func:`candidates.find_coarse`)."""
    field: bool = True
    """Find the field's far edge (:mod:`field`) and hold a candidate above it to the
    detector's :class:`field.OffField` rule (a forward-looking camera; an omnidirectional
    frame's field surrounds the robot)."""


def search_for(height: int, width: int) -> Search:
    """The default search of a frame size: a 608 x 800 camera image at half resolution with
    24 candidates and 8 specks; a frame over LARGE_FRAME_PX (an omnidirectional one)
    strided by 4 with 6 and none, and no field edge."""
    if height * width > LARGE_FRAME_PX:
        return Search(step=4, max_candidates=6, fine=0, field=False)
    return Search()


def _check_image(image: npt.NDArray[np.uint8]) -> None:
    if not (isinstance(image, np.ndarray) and image.ndim == 3 and image.shape[2] == 3
            and image.dtype == np.uint8 and image.shape[0] >= 2 and image.shape[1] >= 2):
        shape = getattr(image, "shape", None)
        raise DetectionError(f"image has shape {shape}; pass an H x W x 3 uint8 BGR array")


def _rough(coarse: Coarse, centre: tuple[float, float]) -> Detection:
    """A candidate's detection from its map box and a centre."""
    x0, y0, x1, y1 = coarse.full_box()
    outline = np.array([[x0, y0], [x1 - 1, y0], [x1 - 1, y1 - 1], [x0, y1 - 1]], np.int32)
    return Detection(centre[0], centre[1], float((x1 - x0) * (y1 - y0)),
                     (x0, y0, x1 - x0, y1 - y0), math.pi / 4.0, outline)


class RealBallDetector:
    """The detector for one venue's model and (optionally) the shared learned check."""

    def __init__(self, model: BallModel, check: BallCheck | None,
                 search: Search | None = None, off_field: OffField = OFF_FIELD) -> None:
        self.model = model
        self.check = check
        self.tables = ColourTables.of(model)
        self.search = search
        self.off_field = off_field

    def _scores(self, image: npt.NDArray[np.uint8], coarse: list[Coarse],
                squares: list[Square]
                ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """(venue logit, dx, dy, diameter) per candidate and its context features."""
        spec = SPEC if self.check is None else self.check.spec
        batch = crop_input(image, squares, self.tables, spec)
        boxes = np.array([c.full_box() for c in coarse], np.float64).reshape(-1, 4)
        ctx = context(boxes, field_share(batch.crops), self.model)
        if self.check is None:
            return np.zeros((len(squares), 4)), ctx
        out, feat = self.check(batch, ctx)
        out[:, 0] = venue_logits(out[:, 0], feat, ctx, blob_features(coarse),
                                 self.model.check_head)
        return out, ctx

    def _beyond(self, image: npt.NDArray[np.uint8], coarse: list[Coarse], search: Search
                ) -> npt.NDArray[np.float64]:
        """How far each candidate's lowest point lies above the field's far edge."""
        if not search.field:
            return np.zeros(len(coarse))
        boxes = np.array([c.full_box() for c in coarse], np.float64)
        return beyond(find_field(image, self.tables),
                      np.stack([(boxes[:, 0] + boxes[:, 2]) / 2.0, boxes[:, 3]], axis=1))

    def check_centre(self, image: npt.NDArray[np.uint8], square: Square,
                     out: npt.NDArray[np.float64], ctx: npt.NDArray[np.float64],
                     refine: bool) -> tuple[float, float]:
        """The check's centre of a candidate (out: its row of :meth:`_scores`), refined
        once in a crop framed on the first estimate at the regressed size."""
        cx, cy = square[0] + out[1] * square[2], square[1] + out[2] * square[2]
        if not refine or self.check is None:
            return cx, cy
        framed = self.check.spec.square(cx, cy, out[3] * square[2])
        again = self.check(crop_input(image, [framed], self.tables, self.check.spec), ctx)[0][0]
        return cx + again[1] * framed[2], cy + again[2] * framed[2]

    def _winner(self, image: npt.NDArray[np.uint8], coarse: Coarse, square: Square,
                out: npt.NDArray[np.float64], ctx: npt.NDArray[np.float64],
                refine: bool) -> Detection:
        """The winning candidate measured at full resolution."""
        blob = measure(image, coarse, self.tables)
        if self.check is None:
            centre = (blob.cx_px, blob.cy_px) if blob else coarse_centre(coarse)
            return _rough(coarse, centre) if blob is None else Detection(
                blob.cx_px, blob.cy_px, blob.area_px, blob.bbox_px, blob.circularity,
                blob.outline_px)
        cx, cy = self.check_centre(image, square, out, ctx, refine)
        if blob is None:
            return _rough(coarse, (cx, cy))
        bx, by, bw, bh = blob.bbox_px
        height, width = image.shape[:2]
        k = (0.0 if min(bx, by) <= 0 or bx + bw >= width or by + bh >= height
             else self.model.centre_blend)
        cx, cy = k * cx + (1.0 - k) * (bx + bw / 2.0), k * cy + (1.0 - k) * (by + bh / 2.0)
        return Detection(cx, cy, blob.area_px, blob.bbox_px, blob.circularity,
                         blob.outline_px)

    def candidates(self, image_bgr: npt.NDArray[np.uint8]) -> list[Candidate]:
        """Every checked candidate, the most likely ball first; the first one is measured
        at full resolution, the others carry the check's rough centre."""
        _check_image(image_bgr)
        search = self.search or search_for(*image_bgr.shape[:2])
        coarse = find_coarse(image_bgr, self.tables, self.model,
                             max_count=search.max_candidates, step=search.step,
                             fine=search.fine)
        if not coarse:
            return []
        spec = SPEC if self.check is None else self.check.spec
        squares = [spec.square(*c.centre()) for c in coarse]
        out, ctx = self._scores(image_bgr, coarse, squares)
        off = self._beyond(image_bgr, coarse, search)
        if self.check is not None:
            sides = np.array([c.centre()[2] for c in coarse], np.float64)
            out[:, 0] -= self.off_field.penalty(off, sides)
        # colour alone: find_coarse's order; else by the logit (P saturates at 1.0)
        order = (list(range(len(coarse))) if self.check is None
                 else sorted(range(len(coarse)), key=lambda i: (-out[i, 0], i)))
        ranked = []
        for rank, i in enumerate(order):
            if rank == 0:
                det = self._winner(image_bgr, coarse[i], squares[i], out[i], ctx[i:i + 1],
                                   search.refine)
            else:
                det = _rough(coarse[i], (squares[i][0] + out[i, 1] * squares[i][2],
                                         squares[i][1] + out[i, 2] * squares[i][2]))
            p = 1.0 if self.check is None else float(0.5 * (1.0 + np.tanh(0.5 * out[i, 0])))
            ranked.append(Candidate(det, coarse[i].mean / 16.0, p, float(ctx[i, 2]),
                                    float(off[i])))
        return ranked

    def detect(self, image_bgr: npt.NDArray[np.uint8]) -> Detection | None:
        """The ball, or None when no candidate's P(ball) reaches the model's threshold."""
        ranked = self.candidates(image_bgr)
        if ranked and ranked[0].check_score >= self.model.threshold:
            return ranked[0].detection
        return None


def coarse_centre(coarse: Coarse) -> tuple[float, float]:
    """The centre of a candidate's map box in full-resolution pixels."""
    cx, cy, _ = coarse.centre()
    return cx, cy
