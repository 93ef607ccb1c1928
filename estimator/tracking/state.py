"""The tracker's input (:class:`Measurement`) and output (:class:`TrackState`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from estimator.estimates import Covariance, covariance_rows
from estimator.tracking.model import Gaussian

__all__ = ["Measurement", "TrackState", "track_state"]


@dataclass(frozen=True)
class Measurement:
    """One robot's estimate of the ball's position at its stamp, with its covariance."""

    stamp_ns: int
    robot: str
    x_m: float
    y_m: float
    covariance: Covariance
    """R [m^2], 2 x 2, symmetric positive definite."""
    shared_covariance: Covariance | None = None
    """The part of R that this robot's estimates share (its pose's: a bias drifts over
    seconds), None when unknown: two of its estimates moved apart by more than the rest of
    R says, as the bias is in both."""
    ground_xy: tuple[float, float] | None = None
    """Where the blob's ray meets the ground [m] when the estimate is placed elsewhere (a
    ball its width shows in the air): where a still object's estimates keep falling."""

    @property
    def still_xy(self) -> tuple[float, float]:
        """Where the tracker's clutter map counts the estimate."""
        return self.ground_xy if self.ground_xy is not None else (self.x_m, self.y_m)


@dataclass(frozen=True)
class TrackState:
    """The track at one stamp: position [m], velocity [m/s] and their covariances."""

    stamp_ns: int
    x_m: float
    y_m: float
    vx_m_s: float
    vy_m_s: float
    position_covariance: Covariance
    velocity_covariance: Covariance
    confirmed: bool
    """False while the track rests on one estimate (or on one robot's alone)."""

    @property
    def speed_m_s(self) -> float:
        return math.hypot(self.vx_m_s, self.vy_m_s)


def track_state(stamp_ns: int, g: Gaussian, confirmed: bool) -> TrackState:
    x, p = g
    return TrackState(stamp_ns, float(x[0]), float(x[1]), float(x[2]), float(x[3]),
                      covariance_rows(p[:2, :2]), covariance_rows(p[2:, 2:]), confirmed)
