"""Fusing several robots' ball estimates into one, behind the :class:`Fusion` protocol.

- ``mean``: the paper's plain average (eq. 20-21).
- ``nearest``: the estimate of the robot nearest the ball (smallest ``range_m``), as NuBot
  and CAMBADA do.
- ``weighted``: inverse-covariance weighting of all estimates.
- ``robust``: ``weighted`` with iterative n-sigma outlier rejection (Falcons).
- ``track``: the ball tracker (:mod:`estimator.tracker`), a Kalman filter over position and
  velocity; as a one-shot :class:`Fusion` it gates the estimates against each other.

Noise model (one per estimate, field frame). A robot measures range d and bearing; its
range noise is CAMBADA's ``sigma_r(d) = 0.01 d^2 - 0.01 d + 0.039`` m (configurable), along
the field bearing phi from robot to ball, and its bearing noise sigma_b (0.01 rad) gives a
tangential sigma ``d sigma_b`` across it::

    Sigma_i = R(phi) diag(sigma_r^2, (d sigma_b)^2) R(phi)^T

Both sigmas are floored at ``min_sigma_m`` so Sigma_i is never singular (d = 0), then
divided by the estimate's ``visibility`` (the fraction of the ball its blob shows, floored
at ``min_visibility``): a partly hidden ball's centroid is pulled towards its visible part.
:class:`CalibratedNoise` derives Sigma_i from the robot's calibration instead (its fit
residuals, its slope for the range growth, the centroid's pixel noise for the bearing):
covariances close to the real errors, so ``robust``'s n-sigma test and the tracker's gate
reject what does not belong. Any object with ``covariance(estimate)`` (:class:`Noise`) will do.
All methods are deterministic: no randomness, ties broken by input order (``nearest``'s
by robot name first), and the ``robots`` of a result are listed in input order.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from estimator.calibration_models import PAPER_CALIBRATION, Calibration
from estimator.corrected import BallEstimate
from estimator.errors import EstimatorError, FusionError, UnknownFusionError

__all__ = [
    "FUSION_METHODS",
    "RANGE_SIGMA_COEFFICIENTS",
    "RANGE_TIE_M",
    "CalibratedNoise",
    "Covariance",
    "FusedEstimate",
    "Fusion",
    "MeanFusion",
    "NearestFusion",
    "Noise",
    "NoiseModel",
    "RobustFusion",
    "WeightedFusion",
    "get_fusion",
    "range_sigma_m",
]

Covariance = tuple[tuple[float, float], tuple[float, float]]
"""A 2 x 2 covariance [m^2] as a tuple of rows."""

RANGE_TIE_M = 1e-9
"""``nearest``: ranges within this of the smallest tie [m]. A nanometre: far below any
range noise, far above the rounding of one range computed in two frames (1e-15 m)."""

Matrix = npt.NDArray[np.float64]

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
        """Sigma_i of one estimate in the field frame [m^2]."""
        d = estimate.range_m
        sigma_r = max(abs(range_sigma_m(d, self.range_sigma_coefficients)), self.min_sigma_m)
        sigma_t = max(abs(d) * self.bearing_sigma_rad, self.min_sigma_m)
        # a partly hidden ball: its centroid moves towards the visible part, so both
        # sigmas grow as the visible fraction shrinks
        scale = 1.0 / max(estimate.visibility, self.min_visibility)
        sigma_r, sigma_t = sigma_r * scale, sigma_t * scale
        dx = estimate.x_m - estimate.robot_x_m
        dy = estimate.y_m - estimate.robot_y_m
        phi = math.atan2(dy, dx) if (dx or dy) else 0.0  # field bearing robot -> ball
        c, s = math.cos(phi), math.sin(phi)
        rotation = np.array([[c, -s], [s, c]])
        sigma = rotation @ np.diag([sigma_r**2, sigma_t**2]) @ rotation.T
        return np.asarray(sigma, dtype=np.float64)


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
    far field is compressed near the rim), and the tangential sigma grows as d. Robots
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

    def covariance(self, estimate: BallEstimate) -> Matrix:
        """Sigma_i of one estimate in the field frame [m^2]."""
        calibration = self.calibrations.get(estimate.robot, self.default)
        d = abs(estimate.range_m)
        r = estimate.r_px if estimate.r_px is not None else _radius_px(calibration, d)
        slope = _slope_m_per_px(calibration, r)
        loc2 = self.position_sigma_m**2
        sigma_r = math.sqrt(self.fit_rms_m**2 + (slope * self.centroid_sigma_px) ** 2 + loc2)
        bearing2 = (self.centroid_sigma_px / max(r, 1.0)) ** 2 + self.yaw_sigma_rad**2
        sigma_t = math.sqrt(d * d * bearing2 + loc2)
        return _oriented(estimate, sigma_r, sigma_t, self.min_sigma_m, self.min_visibility)


@dataclass(frozen=True)
class FusedEstimate:
    """The team's ball estimate: field position [m], its covariance [m^2], robots used."""

    x_m: float
    y_m: float
    covariance: Covariance
    robots: tuple[str, ...]


def _fused(position: Matrix, covariance: Matrix, robots: Sequence[str]) -> FusedEstimate:
    cov = 0.5 * (covariance + covariance.T)  # symmetric to rounding
    return FusedEstimate(
        x_m=float(position[0]),
        y_m=float(position[1]),
        covariance=(
            (float(cov[0, 0]), float(cov[0, 1])),
            (float(cov[1, 0]), float(cov[1, 1])),
        ),
        robots=tuple(robots),
    )


@runtime_checkable
class Fusion(Protocol):
    """Several robots' estimates -> one, or None for no estimates."""

    @property
    def name(self) -> str:
        """The method's name, one of FUSION_METHODS for the built-in ones."""
        ...

    def fuse(self, estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        """The fused estimate of ``estimates`` (None when there are none)."""
        ...


@dataclass(frozen=True)
class MeanFusion:
    """The paper's eq. 20-21: x = mean(x_i), y = mean(y_i).

    Covariance: the sample covariance of the estimates divided by n (the covariance of
    the mean); for a single estimate, the noise model's covariance of that estimate.
    """

    noise: Noise = field(default_factory=NoiseModel)

    @property
    def name(self) -> str:
        return "mean"

    def fuse(self, estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        if not estimates:
            return None
        points = np.array([[e.x_m, e.y_m] for e in estimates])
        n = len(estimates)
        mean = points.mean(axis=0)  # eq. 20-21
        if n == 1:
            covariance = self.noise.covariance(estimates[0])
        else:
            centred = points - mean
            covariance = centred.T @ centred / (n - 1) / n
        return _fused(mean, covariance, [e.robot for e in estimates])


@dataclass(frozen=True)
class NearestFusion:
    """The estimate with the smallest ``range_m``, its covariance from the noise model.

    Ranges within :data:`RANGE_TIE_M` of the smallest are a tie, won by the robot whose name
    sorts first (then by the first given): the same scene in any frame (rotated, shifted)
    picks the same robot, where comparing the floats alone would let rounding decide."""

    noise: Noise = field(default_factory=NoiseModel)

    @property
    def name(self) -> str:
        return "nearest"

    def fuse(self, estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        if not estimates:
            return None
        first = min(estimates, key=lambda e: e.range_m)
        tied = [e for e in estimates if e.range_m - first.range_m <= RANGE_TIE_M]
        best = min(tied or [first], key=lambda e: e.robot)  # min keeps the first on ties
        return _fused(np.array([best.x_m, best.y_m]), self.noise.covariance(best), [best.robot])


def _information_fuse(points: Matrix, covariances: Sequence[Matrix]) -> tuple[Matrix, Matrix]:
    """Inverse-covariance weighting: P = (sum Sigma_i^-1)^-1, x = P sum Sigma_i^-1 x_i."""
    information = np.zeros((2, 2))
    weighted_sum = np.zeros(2)
    for point, sigma in zip(points, covariances, strict=True):
        inverse = np.linalg.inv(sigma)
        information += inverse
        weighted_sum += inverse @ point
    covariance = np.asarray(np.linalg.inv(information), dtype=np.float64)
    return covariance @ weighted_sum, covariance


@dataclass(frozen=True)
class WeightedFusion:
    """Inverse-covariance weighted mean of all estimates (covariances from the noise
    model); its covariance is (sum Sigma_i^-1)^-1."""

    noise: Noise = field(default_factory=NoiseModel)

    @property
    def name(self) -> str:
        return "weighted"

    def fuse(self, estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        if not estimates:
            return None
        points = np.array([[e.x_m, e.y_m] for e in estimates])
        position, covariance = _information_fuse(
            points, [self.noise.covariance(e) for e in estimates]
        )
        return _fused(position, covariance, [e.robot for e in estimates])


@dataclass(frozen=True)
class RobustFusion:
    """``weighted`` with iterative n-sigma outlier rejection (as the Falcons do).

    Repeat: fuse the kept estimates; compute each kept estimate's Mahalanobis distance
    m_i = sqrt((x_i - x)^T Sigma_i^-1 (x_i - x)) to the fused x; if the largest m_i
    exceeds ``n_sigma``, drop that one estimate (the first on ties) and fuse again. Stops
    when none exceeds ``n_sigma`` or one estimate is left.
    """

    noise: Noise = field(default_factory=NoiseModel)
    n_sigma: float = 3.0

    def __post_init__(self) -> None:
        if not self.n_sigma > 0.0:
            raise FusionError(f"n_sigma = {self.n_sigma} must be > 0 (3 is usual)")

    @property
    def name(self) -> str:
        return "robust"

    def fuse(self, estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        if not estimates:
            return None
        kept = list(range(len(estimates)))
        points = np.array([[e.x_m, e.y_m] for e in estimates])
        sigmas = [self.noise.covariance(e) for e in estimates]
        while True:
            position, covariance = _information_fuse(points[kept], [sigmas[i] for i in kept])
            if len(kept) == 1:
                break
            distances = [
                math.sqrt(
                    float((points[i] - position) @ np.linalg.solve(sigmas[i], points[i] - position))
                )
                for i in kept
            ]
            worst = int(np.argmax(distances))  # argmax keeps the first on ties
            if distances[worst] <= self.n_sigma:
                break
            del kept[worst]
        return _fused(position, covariance, [estimates[i].robot for i in kept])


def _track(noise: Noise | None) -> Fusion:
    from estimator.tracker import TrackFusion  # the tracker builds on this module

    return TrackFusion(noise=noise or CalibratedNoise())


_METHODS: dict[str, Callable[[Noise | None], Fusion]] = {
    "mean": lambda noise: MeanFusion(noise or NoiseModel()),
    "nearest": lambda noise: NearestFusion(noise or NoiseModel()),
    "weighted": lambda noise: WeightedFusion(noise or NoiseModel()),
    "robust": lambda noise: RobustFusion(noise or NoiseModel()),
    "track": _track,
}

FUSION_METHODS = tuple(_METHODS)
"""The built-in methods' names, in the order the module docstring describes them; the
names :func:`get_fusion` accepts."""


def get_fusion(name: str, *, noise: Noise | None = None) -> Fusion:
    """The fusion method called ``name`` (one of FUSION_METHODS), with its defaults: the
    window methods use ``noise`` or :class:`NoiseModel`, ``track`` ``noise`` or
    :class:`CalibratedNoise`."""
    try:
        method = _METHODS[name]
    except KeyError:
        raise UnknownFusionError(
            f"fusion method {name!r} is unknown; use one of {', '.join(FUSION_METHODS)}"
        ) from None
    return method(noise)
