"""The tracker's parameters, its input and its output (:mod:`estimator.tracker`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from estimator.errors import FusionError
from estimator.fusion import Covariance
from estimator.tracker_model import Gaussian, Matrix

__all__ = ["GATE_CHI2_999", "NS", "Measurement", "TrackState", "TrackerParams", "covariance",
           "track_state"]

GATE_CHI2_999 = 13.815510557964274
"""chi-square quantile, 2 degrees of freedom, 0.999: -2 ln(0.001)."""
NS = 1_000_000_000


@dataclass(frozen=True)
class TrackerParams:
    """The tracker's tuning (units in the names)."""

    accel_noise_m2_s3: float = 1.0
    """q: spectral density of the white acceleration noise [m^2/s^3]: small, since kicks
    and bounces are handled apart (velocity sigma grows by sqrt(q dt), 0.13 m/s in 17 ms)."""
    friction_per_s: float = 0.5
    """beta: the rolling ball's velocity decays as exp(-beta t) [1/s]. Measured on the
    simulator's match logs (true velocities): a ball at 1-2 m/s loses about 30 % of its speed
    per second, at 2-3 m/s 45 %, faster (just after a kick, still sliding) more; 0.5 is the
    middle. (pybullet's linear damping alone would be 0.05.)"""
    gate: float = GATE_CHI2_999
    """Largest accepted Mahalanobis distance squared d^2."""
    kick_sigma_m_s: float = 6.0
    """Sigma of a kick's velocity change, and of the velocity of a new track [m/s]."""
    max_speed_m_s: float = 12.0
    """Fastest ball: bounds how far two estimates that corroborate each other may lie."""
    manoeuvre_ns: int = 150_000_000
    """How long a rejected estimate waits to be corroborated [ns]."""
    lost_after_ns: int = NS
    """A track without an accepted estimate for this long is lost [ns]."""
    memory_ns: int = 300_000_000
    """How far back late estimates are re-inserted [ns] (>= manoeuvre_ns)."""
    reacquire_ns: int = 300_000_000
    """Window of rejected estimates that may agree on a new path [ns] (memory_ns at most)."""
    reacquire_count: int = 2
    """Fewest rejected estimates that agree on a new path and may restart the track."""
    confirm_ns: int = 40_000_000
    """A tentative track that a robot disagreed with is confirmed only when its accepted
    estimates span at least this long [ns] (two robots taking the same box for the ball
    9 ms apart, against a third that sees the ball, do not confirm it)."""
    lone_kick_ns: int = 250_000_000
    """A lone rejected estimate may explain a kick when the track's last accepted estimate
    is at most this old [ns] and within the tracker's memory (0: never; a kick then needs
    corroboration)."""

    def __post_init__(self) -> None:
        positive = (self.gate, self.kick_sigma_m_s, self.max_speed_m_s, self.lost_after_ns)
        if not (all(v > 0 for v in positive) and self.accel_noise_m2_s3 >= 0.0
                and self.friction_per_s >= 0.0 and 0 <= self.manoeuvre_ns <= self.memory_ns
                and self.reacquire_ns >= 0 and self.reacquire_count >= 2
                and self.lone_kick_ns >= 0 and self.confirm_ns >= 0):
            raise FusionError(
                f"tracker parameters {self}: gate, kick_sigma_m_s, max_speed_m_s and "
                "lost_after_ns must be > 0, accel_noise_m2_s3 and friction_per_s >= 0, "
                "0 <= manoeuvre_ns <= memory_ns, reacquire_ns >= 0, reacquire_count >= 2, "
                "lone_kick_ns >= 0, confirm_ns >= 0"
            )


@dataclass(frozen=True)
class Measurement:
    """One robot's estimate of the ball's position at its stamp, with its covariance."""

    stamp_ns: int
    robot: str
    x_m: float
    y_m: float
    covariance: Covariance
    """R [m^2], 2 x 2, symmetric positive definite."""


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


def covariance(m: Matrix) -> Covariance:
    return ((float(m[0, 0]), float(m[0, 1])), (float(m[1, 0]), float(m[1, 1])))


def track_state(stamp_ns: int, g: Gaussian, confirmed: bool) -> TrackState:
    x, p = g
    return TrackState(stamp_ns, float(x[0]), float(x[1]), float(x[2]), float(x[3]),
                      covariance(p[:2, :2]), covariance(p[2:, 2:]), confirmed)
