"""Each robot's pose uncertainty, learnt from how its ball disagrees with the others'.

A log that states no pose covariance (a PoseStamped, no line fit) says nothing of how far
each robot's believed pose is off; a fixed guess is wrong both ways: too large for exact
poses (the tracker then trusts far estimates too little and lags a fast ball), too small for
poses that drift by a decimetre. So it is estimated as the log replays, by covariance
matching (the adaptive Kalman filters' method since Mehra, 1970): the residual of a robot's
estimate z against the track predicted from every robot's estimates before it,
r = z - x_pred, has the covariance

    E[r r^T] = R + P + J Sigma J^T,    J = [[1, 0, -dy], [0, 1, dx]],

with R the estimate's own noise (the calibration's), P the prediction's, (dx, dy) from the
robot to the ball and Sigma = diag(s_m^2, s_m^2, s_t^2) the pose's covariance (position,
yaw). J Sigma J^T is s_m^2 along the ray and s_m^2 + s_t^2 rho^2 across it (rho the range),
so the excess E = r r^T - R - P, read along the ray and across it, gives two equations in
(s_m^2, s_t^2) per residual. Their least-squares solution over an exponentially fading
window (:attr:`PoseNoiseParams.tau_s`), with a weak prior and both variances kept >= 0, is
the robot's pose covariance.

What the residual holds: a drifting bias and a pose's white noise alike (the second moment
counts both), and any share of the estimate's noise R does not model (so a camera noisier
than its calibration says is weighed as such). The track is partly the robot's own: with n
robots supporting it, a robot's own error reaches its residual shrunk by about (n - 1) / n,
which the excess is scaled back by. Only residuals against a track other robots support
count (a robot alone has nothing to be compared with), and a residual beyond
:attr:`PoseNoiseParams.max_residual_m` (a false blob, a kick) is left out. Deterministic and
causal: the covariance at a frame uses only residuals before it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from estimator.estimates import Covariance3, Matrix, covariance3_rows

__all__ = ["PoseNoiseEstimator", "PoseNoiseParams"]

NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class PoseNoiseParams:
    """How the pose covariance is learnt."""

    tau_s: float = 10.0
    """Time constant [s] over which old residuals fade (a drift's own is seconds)."""
    prior_sigma_m: float = 0.03
    """The position's standard deviation [m] before any residual: a weak start (four
    residuals' worth), which exact poses pull down within a second or two and drifting
    ones up (chosen on dsp-record matches of seed 31 with exact poses and drifting
    5 cm / 1 deg and 10 cm / 2 deg: 0.01 m and 0.2 deg made the drifting ones' first
    seconds worse, 0.04 m and 0.75 deg no better; the exact one the same for all)."""
    prior_sigma_rad: float = math.radians(0.5)
    """The yaw's standard deviation [rad] before any residual."""
    prior_weight: float = 4.0
    """How many residuals the prior counts as (it never fades)."""
    prior_range_m: float = 4.0
    """The range [m] the prior's yaw equation is written at."""
    max_residual_m: float = 1.0
    """A residual further than this [m] is not the pose's: left out."""
    gate: float = 16.0
    """A residual whose squared Mahalanobis distance under its covariance as learnt so far
    (R + P + J Sigma J^T) exceeds this is left out: a ball in the air placed on the ground,
    a false blob the tracker took. Four sigma: a pose that drifts further than learnt
    still teaches, through the residuals within it."""


class _Moments:
    """The fading normal equations of one robot's (s_m^2, s_t^2)."""

    def __init__(self) -> None:
        self.stamp_ns: int | None = None
        self.n = np.zeros((2, 2))
        self.b = np.zeros(2)
        self.count = 0

    def fade(self, stamp_ns: int, tau_s: float) -> None:
        if self.stamp_ns is not None and stamp_ns > self.stamp_ns:
            a = math.exp(-(stamp_ns - self.stamp_ns) / NS_PER_S / tau_s)
            self.n *= a
            self.b *= a
        self.stamp_ns = stamp_ns if self.stamp_ns is None else max(stamp_ns, self.stamp_ns)

    def add(self, along: float, across: float, rho2: float, weight: float = 1.0) -> None:
        # along the ray: s_m^2 = along; across it: s_m^2 + s_t^2 rho^2 = across
        self.n += weight * np.array([[2.0, rho2], [rho2, rho2 * rho2]])
        self.b += weight * np.array([along + across, rho2 * across])


class PoseNoiseEstimator:
    """Per-robot pose covariances learnt from the track's residuals (module docstring)."""

    def __init__(self, params: PoseNoiseParams | None = None) -> None:
        self.params = params or PoseNoiseParams()
        self._robots: dict[str, _Moments] = {}
        self.residuals = 0
        """Residuals taken in, all robots."""

    def _prior(self) -> tuple[float, float, float]:
        p = self.params
        rho2 = p.prior_range_m**2
        along = p.prior_sigma_m**2
        return along, along + p.prior_sigma_rad**2 * rho2, rho2

    def variances(self, robot: str) -> tuple[float, float]:
        """(s_m^2 [m^2], s_t^2 [rad^2]) as learnt so far (the prior before any residual)."""
        m = self._robots.get(robot)
        along, across, rho2 = self._prior()
        n = np.zeros((2, 2)) if m is None else m.n.copy()
        b = np.zeros(2) if m is None else m.b.copy()
        w = self.params.prior_weight
        n += w * np.array([[2.0, rho2], [rho2, rho2 * rho2]])
        b += w * np.array([along + across, rho2 * across])
        return _nonnegative(n, b)

    def sigma(self, robot: str) -> tuple[float, float]:
        """The robot's pose standard deviations (position [m], yaw [rad])."""
        s_m2, s_t2 = self.variances(robot)
        return math.sqrt(s_m2), math.sqrt(s_t2)

    def covariance(self, robot: str) -> Covariance3:
        """The robot's pose covariance over (x, y, yaw)."""
        s_m2, s_t2 = self.variances(robot)
        return covariance3_rows(np.diag([s_m2, s_m2, s_t2]))

    def count(self, robot: str) -> int:
        """The robot's residuals taken in."""
        m = self._robots.get(robot)
        return 0 if m is None else m.count

    def observe(self, robot: str, stamp_ns: int, residual_m: tuple[float, float],
                offset_m: tuple[float, float], expected: Matrix, supporters: int) -> bool:
        """Take in one residual z - x_pred [m] of ``robot`` at ``stamp_ns``: ``offset_m``
        from the robot to its ball, ``expected`` the residual's covariance without the pose's
        share (R + P), ``supporters`` the robots the track stood on (this one included).
        Returns whether it was taken in (a robot alone, or a residual beyond
        :attr:`PoseNoiseParams.max_residual_m`, is not)."""
        r = np.asarray(residual_m, np.float64)
        rho = math.hypot(*offset_m)
        if supporters < 2 or rho <= 0.0 or not np.all(np.isfinite(r)) or (
                math.hypot(*r) > self.params.max_residual_m):
            return False
        d = np.array(offset_m) / rho
        u = np.array([-d[1], d[0]])
        s_m2, s_t2 = self.variances(robot)
        s = np.asarray(expected, np.float64) + s_m2 * np.eye(2) + s_t2 * rho * rho * np.outer(u, u)
        if float(r @ np.linalg.solve(s, r)) > self.params.gate:
            return False
        excess = np.outer(r, r) - np.asarray(expected, np.float64)
        scale = supporters / (supporters - 1.0)  # the robot's own share of the track
        m = self._robots.setdefault(robot, _Moments())
        m.fade(stamp_ns, self.params.tau_s)
        m.add(scale * float(d @ excess @ d), scale * float(u @ excess @ u), rho * rho)
        m.count += 1
        self.residuals += 1
        return True


def _nonnegative(n: Matrix, b: Matrix) -> tuple[float, float]:
    """The least-squares (s_m^2, s_t^2) of normal equations ``n x = b``, both >= 0."""
    x = np.linalg.solve(n, b)
    if x[0] >= 0.0 and x[1] >= 0.0:
        return float(x[0]), float(x[1])
    # on the boundary: the better of the two one-variable fits, each clipped at zero
    s_m2 = max(0.0, float(b[0] / n[0, 0]))
    s_t2 = max(0.0, float(b[1] / n[1, 1]))
    cost_m = s_m2 * s_m2 * n[0, 0] - 2.0 * s_m2 * b[0]
    cost_t = s_t2 * s_t2 * n[1, 1] - 2.0 * s_t2 * b[1]
    return (s_m2, 0.0) if cost_m <= cost_t else (0.0, s_t2)
