"""Pixel radius -> ground range calibrations, their fitting and their JSON form.

A calibration maps the pixel radius r [px] of the ball's centroid (its distance from the
image centre) to the horizontal range d [m] from the robot's centre to the ball's centre.
This module gathers its parts under one name:

- :mod:`estimator.calibration.models`: the :class:`Calibration` protocol and its models
  (linear as the paper's eq. 4, lookup table, NuBot's mirror, from a camera model);
- :mod:`estimator.calibration.fit`: least-squares fits and :func:`fit_all`, which ranks them
  on held-out samples;
- :mod:`estimator.calibration.centre`: the image centre and the mounting rotation, fitted
  to where the ball was seen;
- :mod:`estimator.calibration.json_form`: the ``dsp-calibration`` JSON form, written and read.
"""

from __future__ import annotations

from estimator.calibration.centre import (
    CentreFit,
    fit_centre_and_mount,
    fit_centre_to_ranges,
    fit_mount,
)
from estimator.calibration.fit import (
    FITTERS,
    MIN_HOLDOUT_RANGES,
    FitResult,
    fit_all,
    fit_linear,
    fit_lookup,
    fit_mirror,
    holdout_rms_m,
)
from estimator.calibration.json_form import (
    CALIBRATION_FORMAT,
    CALIBRATION_FORMAT_VERSION,
    calibration_from_dict,
    calibration_from_json,
    calibration_to_json,
)
from estimator.calibration.models import (
    CALIBRATION_MODELS,
    PAPER_CALIBRATION,
    Calibration,
    CameraCalibration,
    CameraLike,
    LinearCalibration,
    LookupCalibration,
    MirrorCalibration,
    ranges_m,
)

__all__ = [
    "CALIBRATION_FORMAT",
    "CALIBRATION_FORMAT_VERSION",
    "CALIBRATION_MODELS",
    "FITTERS",
    "MIN_HOLDOUT_RANGES",
    "PAPER_CALIBRATION",
    "Calibration",
    "CameraCalibration",
    "CameraLike",
    "CentreFit",
    "FitResult",
    "LinearCalibration",
    "LookupCalibration",
    "MirrorCalibration",
    "calibration_from_dict",
    "calibration_from_json",
    "calibration_to_json",
    "fit_all",
    "fit_centre_and_mount",
    "fit_centre_to_ranges",
    "fit_linear",
    "fit_lookup",
    "fit_mirror",
    "fit_mount",
    "holdout_rms_m",
    "ranges_m",
]
