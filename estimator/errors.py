"""Errors raised by the estimator: one base class, one subclass per kind of mistake.

Every message names the offending value and says how to fix it. All errors derive from
``ValueError`` too, because each one is a bad input value.
"""

from __future__ import annotations

__all__ = [
    "BallModelError",
    "CalibrationError",
    "CalibrationFormatError",
    "DetectionError",
    "EstimatorError",
    "FitError",
    "FusionError",
    "GeometryError",
    "LocalisationError",
    "OutOfRangeError",
    "UnknownFusionError",
]


class EstimatorError(ValueError):
    """Base class of every error the estimator raises."""


class DetectionError(EstimatorError):
    """A bad image or bad detection parameters (wrong dtype, shape, HSV range)."""


class BallModelError(DetectionError):
    """A ball model (its dict / JSON form) that cannot be read, or labelled samples that
    cannot be fitted."""


class GeometryError(EstimatorError):
    """A bad pose or quaternion (zero length, not finite)."""


class CalibrationError(EstimatorError):
    """A bad calibration model or parameter."""


class CalibrationFormatError(CalibrationError):
    """A calibration JSON/dict that cannot be read (bad JSON, missing key, bad version)."""


class FitError(CalibrationError):
    """Calibration samples that cannot be fitted (too few, not finite, degenerate)."""


class OutOfRangeError(CalibrationError):
    """A pixel radius outside the region where a calibration gives a ground range."""


class FusionError(EstimatorError):
    """A bad fusion input or configuration."""


class UnknownFusionError(FusionError):
    """A fusion method name that is not one of ``FUSION_METHODS``."""


class LocalisationError(EstimatorError):
    """A bad input to the field-line localisation (an image of the wrong size, a prior
    covariance that is not positive definite, a bad parameter or field line)."""
