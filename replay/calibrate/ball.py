"""``dsp-calibrate --ball-from DIR``: a venue's ball model from a folder of labelled images
(or ``--ball-from LOG.mcap``: from a simulated log, its truth drawing the boxes,
:mod:`replay.calibrate.ball_log`).

What a team does at a new venue: label the ball in a few frames (YOLO labels, any
labelling tool writes them), then fit. The colour table, field mask and size line come
from the first N labelled images by file name (:func:`estimator.detection.real.fit_ball_model`)
and, unless ``no_head``, the venue's head on the shared check is fitted on the same images
(:func:`estimator.detection.real.adapt`); :func:`fit_samples` does both, whatever labelled
the frames. Reads those files only; returns the model.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from dsp.ball_file import shipped_check
from dsp.errors import InputError, UsageError
from dsp.labelled import Labelled, find_labelled
from estimator.detection.real import BallCheck, BallModel, Box, adapt, fit_ball_model
from estimator.errors import EstimatorError
from replay.calibrate.ball_log import frames_from_log

__all__ = ["fit_ball", "fit_from_folder", "fit_from_labelled", "fit_samples", "format_fit"]

Sample = tuple[npt.NDArray[np.uint8], Sequence[Box]]


def fit_samples(source: Path | str, samples: Sequence[Sample], info: Mapping[str, Any], *,
                head: bool = True, check: bytes | None = None) -> BallModel:
    """The ball model of labelled frames (BGR image, ball boxes), however they were
    labelled; errors name ``source``."""
    try:
        model = fit_ball_model(samples, info=info)
        return adapt(model, samples, BallCheck(check or shipped_check())) if head else model
    except EstimatorError as err:
        raise InputError(f"{source}: {err}") from err


def fit_ball(source: Path, *, ball_class: int = 0, train_count: int | None = None,
             head: bool = True, check: bytes | None = None) -> BallModel:
    """The ball model of a folder of labelled images or, for a path ending in ``.mcap``, of
    a simulated log's first ``train_count`` images, labelled from its truth."""
    if source.suffix.lower() != ".mcap":
        return fit_from_folder(source, ball_class=ball_class, train_count=train_count,
                               head=head, check=check)
    if train_count is not None and train_count < 1:
        raise UsageError(f"--train-count {train_count}: use 1 or more")
    frames, info = frames_from_log(source, train_count)
    return fit_samples(source, frames, info, head=head, check=check)


def fit_from_folder(folder: Path, *, ball_class: int = 0, train_count: int | None = None,
                    head: bool = True, check: bytes | None = None,
                    train_from: int = 0) -> BallModel:
    """The ball model of ``folder``'s first ``train_count`` labelled images (None: all)
    from its ``train_from``-th (0: the first) by name."""
    if train_count is not None and train_count < 1:
        raise UsageError(f"--train-count {train_count}: use 1 or more")
    labelled = find_labelled(folder)
    if not labelled:
        raise InputError(f"{folder}: no image with a YOLO label file (NAME.txt) beside it")
    return fit_from_labelled(folder, labelled, ball_class=ball_class,
                             train_count=train_count, head=head, check=check,
                             train_from=train_from)


def fit_from_labelled(source: Path | str, labelled: Sequence[Labelled], *,
                      ball_class: int = 0, train_count: int | None = None,
                      head: bool = True, check: bytes | None = None,
                      train_from: int = 0) -> BallModel:
    """The ball model of the ``train_count`` labelled images (None: all) of ``labelled``
    from its ``train_from``-th on (a folder's, or a day's or event's of several folders);
    errors name ``source``."""
    chosen = labelled[train_from:] if train_count is None else labelled[
        train_from:train_from + train_count]
    if not chosen:
        raise InputError(f"{source}: {len(labelled)} labelled images, none from number "
                         f"{train_from + 1} on to fit on")
    samples = [item.read(ball_class) for item in chosen]
    info = {"images": len(chosen), "first": chosen[0].image.name,
            "last": chosen[-1].image.name, "ball_class": ball_class}
    return fit_samples(source, samples, info, head=head, check=check)


def format_fit(model: BallModel) -> str:
    """One line: what the model was fitted from."""
    fit = model.fit
    if fit.get("generic"):
        events = fit.get("events")
        return (f"generic ball model from {fit.get('images')} images of "
                f"{len(events) if isinstance(events, dict) else '?'} events, "
                f"{fit.get('balls')} balls, diameters {model.min_diameter_px:.0f}-"
                f"{model.max_diameter_px:.0f} px, no venue head")
    head = ("no venue head" if model.check_head is None
            else f"venue head (penalty {fit.get('head_lambda')})")
    left = (f", {fit['left_out']} left out (the ball hidden or cut by the image's edge)"
            if fit.get("left_out") else "")
    return (f"ball model from {fit.get('images')} images ({fit.get('first')} .. "
            f"{fit.get('last')}), {fit.get('balls')} balls, diameters "
            f"{model.min_diameter_px:.0f}-{model.max_diameter_px:.0f} px, {head}{left}")
