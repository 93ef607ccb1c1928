"""Fitting a venue's use of the shared check on its labelled frames (pure: arrays in).

:func:`adapt` gives a colour model (:func:`fit.fit_ball_model`) its venue head
(:mod:`head`), fitted on the same few labelled frames, on the candidates of the
search the detector will use there: the check's logit corrected for the venue, with the
penalty chosen by two-fold cross-validation over the frames.

The centroid's blend (``BallModel.centre_blend``, the weight of the check's centre against
the colour blob box's centre) is not fitted here: chosen on a venue's ten frames it picked
the check alone where the mean of the two erred less on the venue's other frames (the
check's centre is at its best on frames it was trained on), so it stays at its default.

With a head, the model's threshold becomes :data:`head.HEAD_THRESHOLD` (P 0.731, logit 1):
the head is fitted with the positives up-weighted (up to 8x, a logit shift of up to ln 8),
so at 0.5 a venue's look-alikes passed where no ball was in sight.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from estimator.detection.real.check import BallCheck
from estimator.detection.real.detector import Search, search_for
from estimator.detection.real.head import HEAD_THRESHOLD, fit_head, head_samples
from estimator.detection.real.model import BallModel

__all__ = ["adapt"]

Box = tuple[float, float, float, float]
Sample = tuple[npt.NDArray[np.uint8], Sequence[Box]]


def adapt(model: BallModel, samples: Sequence[Sample], check: BallCheck, *,
          search: Search | None = None) -> BallModel:
    """The model with its venue head fitted on the labelled frames, and the head's
    threshold (unchanged when the cross-validation keeps the shared check, or the frames
    hold too few candidates)."""
    if search is None:  # the specks where the detector looks at them (camera images)
        fine = search_for(*samples[0][0].shape[:2]).fine if samples else 0
        search = dataclasses.replace(Search(), fine=fine)
    head, lam = fit_head(head_samples(samples, model, check, max_count=search.max_candidates,
                                      step=search.step, fine=search.fine))
    if head is None:
        return dataclasses.replace(model, fit={**model.fit, "head_lambda": None})
    return dataclasses.replace(model, fit={**model.fit, "head_lambda": lam},
                               threshold=HEAD_THRESHOLD,
                               check_head=tuple(round(float(v), 6) for v in head))
