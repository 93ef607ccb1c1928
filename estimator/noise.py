"""Per-estimate noise: the covariance Sigma_i [m^2] of one robot's estimate, field frame.

A robot measures range d and bearing; its range noise is CAMBADA's
``sigma_r(d) = 0.01 d^2 - 0.01 d + 0.039`` m (configurable), along the field bearing phi
from robot to ball, and its bearing noise sigma_b (0.01 rad) gives a tangential sigma
``d sigma_b`` across it::

    Sigma_i = R(phi) diag(sigma_r^2, (d sigma_b)^2) R(phi)^T

Both sigmas are floored at ``min_sigma_m`` so Sigma_i is never singular (d = 0), then
divided by the estimate's ``visibility`` (the fraction of the ball its blob shows, floored
at ``min_visibility``): a partly hidden ball's centroid is pulled towards its visible part.
:class:`CalibratedNoise` derives Sigma_i from the robot's calibration instead (its fit
residuals, its slope for the range growth, the centroid's pixel noise for the bearing):
covariances close to the real errors, so ``robust``'s n-sigma test and the tracker's gate
reject what does not belong. Any object with ``covariance(estimate)`` (:class:`Noise`) will
do; both models orient their two sigmas the same way (:func:`_oriented`).

A robot is also wrong about its own pose. When an estimate carries the covariance P of the
pose it was located from (:attr:`~estimator.estimates.BallEstimate.pose_covariance`: from
the log, the field-line fit, or a stated default), both models add the ball's share of it,
with J the ball's derivative by the pose (x, y, yaw) and (dx, dy) from robot to ball::

    Sigma_loc = J P J^T,   J = [[1, 0, -dy], [0, 1, dx]]

(:func:`localisation_covariance`): the position error as it is, and the yaw error across
the bearing, ``sigma_perp = range sigma_yaw``, so a far robot with a doubtful heading weighs
less than a near one. It is not divided by the visibility (the pose's error is the same
whatever the blob shows), and :class:`CalibratedNoise` then drops its fixed
``yaw_sigma_rad`` and ``position_sigma_m``, which stand for the same error when it is not
known.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from estimator.calibration.models import PAPER_CALIBRATION, Calibration
from estimator.errors import EstimatorError, FusionError
from estimator.estimates import BallEstimate, Matrix

__all__ = [
    "RANGE_SIGMA_COEFFICIENTS",
    "CalibratedNoise",
    "Noise",
    "NoiseModel",
    "localisation_covariance",
    "range_sigma_m",
]

RANGE_SIGMA_COEFFICIENTS = (0.01, -0.01, 0.039)
"""CAMBADA's (c2, c1, c0) of the range noise sigma_r(d) = c2 d^2 + c1 d + c0 [m]."""


def range_sigma_m(
    d_m: float, coefficients: tuple[float, float, float] = RANGE_SIGMA_COEFFICIENTS
) -> float:
    """CAMBADA's range noise sigma(d) = c2 d^2 + c1 d + c0 [m] (default 0.01, -0.01, 0.039)."""
    c2, c1, c0 = coefficients
    return c2 * d_m * d_m + c1 * d_m + c0


@dataclass(frozen=True)
class NoiseModel:
    """The per-estimate covariance model (see the module docstring)."""

    range_sigma_coefficients: tuple[float, float, float] = RANGE_SIGMA_COEFFICIENTS
    """(c2, c1, c0) of sigma_r(d) = c2 d^2 + c1 d + c0 [m]."""
    bearing_sigma_rad: float = 0.01
    min_sigma_m: float = 1e-3
    min_visibility: float = 0.05
    """Sigmas grow as 1 / visibility, at most 1 / min_visibility times."""

    def __post_init__(self) -> None:
        if not (self.bearing_sigma_rad >= 0.0 and self.min_sigma_m > 0.0):
            raise FusionError(
                f"bearing_sigma_rad = {self.bearing_sigma_rad} and min_sigma_m = "
                f"{self.min_sigma_m}; pass bearing_sigma_rad >= 0 and min_sigma_m > 0"
            )

    def covariance(self, estimate: BallEstimate) -> Matrix:
        """Sigma_i of one estimate in the field frame [m^2], with the pose's share when the
        estimate carries its pose's covariance (:func:`localisation_covariance`)."""
        d = estimate.range_m
        sigma_r = abs(range_sigma_m(d, self.range_sigma_coefficients))
        sigma = _oriented(estimate, sigma_r, abs(d) * self.bearing_sigma_rad, self.min_sigma_m,
                          self.min_visibility)
        return sigma if estimate.pose_covariance is None else \
            sigma + localisation_covariance(estimate)


def localisation_covariance(estimate: BallEstimate) -> Matrix:
    """The ball's covariance [m^2] that its robot's pose covariance P (x, y, yaw) gives:
    J P J^T with J = [[1, 0, -dy], [0, 1, dx]], (dx, dy) from robot to ball (module
    docstring); zero when the estimate carries no pose covariance."""
    if estimate.pose_covariance is None:
        return np.zeros((2, 2))
    p = np.asarray(estimate.pose_covariance, dtype=np.float64)
    if p.shape != (3, 3) or not np.all(np.isfinite(p)):
        raise FusionError(f"{estimate.robot}: pose covariance must be 3 x 3 and finite, "
                          f"not {p.tolist()}")
    dx = estimate.x_m - estimate.robot_x_m
    dy = estimate.y_m - estimate.robot_y_m
    j = np.array([[1.0, 0.0, -dy], [0.0, 1.0, dx]])
    out = j @ (0.5 * (p + p.T)) @ j.T
    return np.asarray(0.5 * (out + out.T), dtype=np.float64)


def _oriented(estimate: BallEstimate, sigma_r: float, sigma_t: float, min_sigma: float,
              min_visibility: float) -> Matrix:
    """R(phi) diag(sigma_r^2, sigma_t^2) R(phi)^T, both sigmas floored at ``min_sigma`` and
    divided by the estimate's visibility (floored at ``min_visibility``)."""
    # a partly hidden ball: its centroid moves towards the visible part, so both
    # sigmas grow as the visible fraction shrinks
    scale = 1.0 / max(estimate.visibility, min_visibility)
    sigma_r = max(sigma_r, min_sigma) * scale
    sigma_t = max(sigma_t, min_sigma) * scale
    dx = estimate.x_m - estimate.robot_x_m
    dy = estimate.y_m - estimate.robot_y_m
    phi = math.atan2(dy, dx) if (dx or dy) else 0.0  # field bearing robot -> ball
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c * c * sigma_r**2 + s * s * sigma_t**2, c * s * (sigma_r**2 - sigma_t**2)],
                     [c * s * (sigma_r**2 - sigma_t**2), s * s * sigma_r**2 + c * c * sigma_t**2]])


@runtime_checkable
class Noise(Protocol):
    """A per-estimate covariance model: Sigma_i [m^2] in the field frame."""

    def covariance(self, estimate: BallEstimate) -> Matrix:
        """Sigma_i of one estimate, 2 x 2, symmetric positive definite."""
        ...


def _slope_m_per_px(calibration: Calibration, r_px: float, h_px: float = 0.5) -> float:
    """d'(r) by a central difference (one-sided at r = 0 and at a mirror's horizon)."""
    lo, hi = max(r_px - h_px, 0.0), r_px + h_px
    try:
        d_hi = calibration.range_m(hi)
    except EstimatorError:  # beyond the horizon: a backward difference
        hi, d_hi = r_px, calibration.range_m(r_px)
    return abs(d_hi - calibration.range_m(lo)) / (hi - lo)


def _radius_px(calibration: Calibration, d_m: float) -> float:
    """The pixel radius whose calibrated range is ``d_m`` (bisection; ranges grow with r)."""
    lo, hi = 0.0, 64.0
    for _ in range(16):  # bracket: double hi until d(hi) >= d or hi is past the horizon
        try:
            if calibration.range_m(hi) >= d_m:
                break
        except EstimatorError:
            break
        lo, hi = hi, 2.0 * hi
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        try:
            below = calibration.range_m(mid) < d_m
        except EstimatorError:
            below = False
        lo, hi = (mid, hi) if below else (lo, mid)
    return 0.5 * (lo + hi)


@dataclass(frozen=True)
class CalibratedNoise:
    """Sigma_i from the robot's own calibration rather than a fixed law.

    With r the centroid's pixel radius, d = d(r) the calibrated range and d'(r) its slope
    [m/px], sigma_px the centroid's noise [px], rms the calibration fit's residual RMS [m],
    sigma_yaw the robot's heading noise [rad] and sigma_loc its position noise [m]::

        sigma_r^2 = rms^2 + (d'(r) sigma_px)^2 + sigma_loc^2            along the bearing
        sigma_t^2 = d^2 ((sigma_px / r)^2 + sigma_yaw^2) + sigma_loc^2   across it
        Sigma_i   = R(phi) diag(sigma_r^2, sigma_t^2) R(phi)^T / max(visibility, v_min)^2

    The range growth comes from the calibration: on an omni camera d'(r) grows with r (the
    far field is compressed near the rim), and the tangential sigma grows as d. An estimate
    whose range a second measure gave (``range_sigma_m``: a ball in the air placed by its
    blob's width, :mod:`estimator.width`) has that sigma in place of the first two terms
    of sigma_r. Robots
    missing from ``calibrations`` use ``default``; an estimate without ``r_px`` gets r by
    inverting its calibration.
    """

    calibrations: Mapping[str, Calibration] = field(default_factory=dict)
    default: Calibration = PAPER_CALIBRATION
    fit_rms_m: float = 0.0
    """The calibration fit's residual RMS [m] (0 for a camera model: no fit)."""
    centroid_sigma_px: float = 0.5
    yaw_sigma_rad: float = 0.003
    position_sigma_m: float = 0.01
    min_sigma_m: float = 1e-3
    min_visibility: float = 0.05

    def __post_init__(self) -> None:
        values = (self.fit_rms_m, self.centroid_sigma_px, self.yaw_sigma_rad,
                  self.position_sigma_m)
        if not (all(v >= 0.0 for v in values) and self.min_sigma_m > 0.0):
            raise FusionError(
                f"fit_rms_m, centroid_sigma_px, yaw_sigma_rad, position_sigma_m = {values} "
                f"and min_sigma_m = {self.min_sigma_m}; pass sigmas >= 0 and min_sigma_m > 0"
            )

    def calibrated_range_sigma_m(self, robot: str, r_px: float) -> float:
        """The calibrated range's own sigma at pixel radius ``r_px`` [m]: the fit's residual
        and the centroid's noise through the calibration's slope (no pose's share)."""
        return math.sqrt(self._range_variance(self.calibrations.get(robot, self.default), r_px))

    def _range_variance(self, calibration: Calibration, r_px: float) -> float:
        """rms^2 + (d'(r) sigma_px)^2: the first two terms of sigma_r^2."""
        slope = _slope_m_per_px(calibration, r_px)
        return self.fit_rms_m**2 + (slope * self.centroid_sigma_px) ** 2

    def covariance(self, estimate: BallEstimate) -> Matrix:
        """Sigma_i of one estimate in the field frame [m^2]; an estimate that carries its
        pose's covariance has the pose's share from it instead of the fixed sigmas."""
        calibration = self.calibrations.get(estimate.robot, self.default)
        d = abs(estimate.range_m)
        r = estimate.r_px if estimate.r_px is not None else _radius_px(calibration, d)
        known = estimate.pose_covariance is not None
        loc2 = 0.0 if known else self.position_sigma_m**2
        yaw2 = 0.0 if known else self.yaw_sigma_rad**2
        own2 = (self._range_variance(calibration, r) if estimate.range_sigma_m is None
                else estimate.range_sigma_m**2)
        sigma_r = math.sqrt(own2 + loc2)
        bearing2 = (self.centroid_sigma_px / max(r, 1.0)) ** 2 + yaw2
        sigma_t = math.sqrt(d * d * bearing2 + loc2)
        sigma = _oriented(estimate, sigma_r, sigma_t, self.min_sigma_m, self.min_visibility)
        return sigma + localisation_covariance(estimate) if known else sigma
