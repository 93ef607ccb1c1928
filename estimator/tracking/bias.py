"""Each robot's slowly drifting localisation bias, estimated from the ball it sees.

A robot that believes it stands at (x, y, yaw) while it stands at (x + bx, y + by, yaw + bt)
puts a ball it sees at z, while the ball is at z + H b to first order in bt, with
b = (bx, by, bt) and H = [[1, 0, -dy], [0, 1, dx]], (dx, dy) from the robot to the ball
(the same Jacobian as :func:`estimator.noise.localisation_covariance`). Each robot's b is
modelled as a Gauss-Markov process per axis (stationary standard deviation ``sigma_m`` /
``sigma_rad``, time constant ``tau_s``: the recorder's drifting bias) and filtered by its
own Kalman filter, whose measurement is the tracked ball at the robot's stamp (predicted
from the estimates before it, of every robot) minus the robot's estimate, with the
estimate's covariance and the track's (scaled up: :attr:`BiasParams.residual_scale`). The
caller locates each estimate from the believed pose plus the robot's current b
(:meth:`BiasEstimator.corrected`), so the track is made of corrected estimates, and feeds a
residual only while other robots' estimates go into the track too.

What the ball tells and what it does not: only the robots' biases relative to each other
are observable. A shift all robots share moves the track with them and leaves every
residual at zero, so the robots' mean position bias is held at zero (its prior), and what
they truly share stays in the fused ball (the floor of any fusion of their estimates). A
robot that sees the ball alone for a while has nothing to be compared with; its b relaxes
to zero with ``tau_s``. A yaw bias and a position bias are told apart only as the ball's
range and bearing from the robot change (the yaw's effect grows with the range); a yaw
all robots share is seen, as it moves each robot's ball across its own bearing. The field
lines (``--localise lines``) observe the absolute pose, shared part included.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from estimator.estimates import Covariance, Covariance3, Matrix, covariance3_rows
from estimator.tracking.pose_noise import PoseNoiseEstimator

__all__ = ["BiasEstimator", "BiasParams", "bias_jacobian"]

NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class BiasParams:
    """The bias model: stationary standard deviations and time constant."""

    sigma_m: float = 0.05
    """Of each position axis [m]."""
    sigma_rad: float = math.radians(1.0)
    """Of the yaw [rad]."""
    tau_s: float = 5.0
    """Time constant of the drift [s]."""
    residual_scale: float = 10.0
    """A residual's covariance is taken this many times larger than the estimate's and the
    track's: a camera's error at a given range and bearing persists while the ball rolls
    on, so consecutive residuals are far from independent, and a filter that took each at
    face value would soon be sure of a bias it has not seen (chosen on the realistic
    matches of seeds 4-7: 1 and 100 both did worse)."""

    yaw_noise_rad: float = math.radians(0.3)
    """Standard deviation of the yaw's frame-to-frame noise [rad], which no bias filter
    removes: a corrected pose's yaw is as unsure as its b's plus this (the recorder's white
    yaw noise under ``--realism field``). Without it a robot whose b the filter had learnt
    was weighed as if its heading were exact to a small fraction of a degree, and its
    frames' noise, growing with the range, went into the track's velocity (chosen on the
    realistic matches of seeds 4-7: with ``--hops --pose-uncertainty`` the velocity median
    0.168 -> 0.145 m/s, the fused RMSE the same; the recorder's 1 cm of position noise as well
    did no better there, and made ``--localise ball`` alone worse on seed 6)."""

    def stationary(self) -> Matrix:
        """The prior covariance of a robot's b (x [m], y [m], yaw [rad])."""
        return np.diag([self.sigma_m**2, self.sigma_m**2, self.sigma_rad**2])


def bias_jacobian(dx_m: float, dy_m: float) -> Matrix:
    """H: how a bias (bx, by, bt) moves a ball seen at (dx, dy) from the robot."""
    return np.array([[1.0, 0.0, -dy_m], [0.0, 1.0, dx_m]])


@dataclass
class _Robot:
    stamp_ns: int
    b: Matrix
    p: Matrix


class BiasEstimator:
    """Per-robot Kalman filters over the robots' pose biases (module docstring).

    With ``learnt`` (:class:`~estimator.tracking.pose_noise.PoseNoiseEstimator`), each
    robot's stationary spread is not ``params``' but the one learnt from its uncorrected
    residuals (:meth:`update` feeds it), and the yaw's own noise is at most that spread: a
    robot whose poses are exact gets no correction and no uncertainty it does not show."""

    def __init__(self, params: BiasParams | None = None,
                 learnt: PoseNoiseEstimator | None = None) -> None:
        self.params = params or BiasParams()
        self.learnt = learnt
        self._stated: dict[str, Matrix] = {}
        self._robots: dict[str, _Robot] = {}
        self.updates = 0
        """Residuals taken in."""

    def state(self, robot: str, covariance: Matrix) -> None:
        """The robot's pose covariance as its log states it (x, y, yaw): its b's spread from
        now on, in place of the learnt one or the params'."""
        self._stated[robot] = np.diag(np.maximum(np.diag(np.asarray(covariance)), 0.0))

    def stationary(self, robot: str) -> Matrix:
        """The prior covariance of the robot's b: the one its log states, else the learnt
        one, else the params'."""
        if robot in self._stated:
            return np.array(self._stated[robot], dtype=np.float64)
        if self.learnt is None:
            return self.params.stationary()
        s_m2, s_t2 = self.learnt.variances(robot)
        return np.diag([s_m2, s_m2, s_t2])

    def _yaw_noise2(self, robot: str) -> float:
        own = self.params.yaw_noise_rad**2
        if robot not in self._stated and self.learnt is None:
            return own
        return min(own, float(self.stationary(robot)[2, 2]))

    def bias(self, robot: str) -> tuple[Matrix, Matrix]:
        """The robot's b (x, y, yaw) as last updated, less the robots' mean shift (which the
        ball cannot see: module docstring), and its covariance (zero and the prior before
        any residual)."""
        r = self._robots.get(robot)
        if r is None:
            return np.zeros(3), self.stationary(robot)
        return r.b - self._common(), r.p.copy()

    def _common(self) -> Matrix:
        """The mean of the robots' position biases (yaw: none), held at zero: a shift all
        robots share moves the track with them, so the residuals never tell it, and its
        best estimate is the prior's, zero."""
        if not self._robots:
            return np.zeros(3)
        mean = np.mean([r.b for r in self._robots.values()], axis=0)
        return np.array([mean[0], mean[1], 0.0])

    def corrected(self, robot: str, x_m: float, y_m: float, yaw_rad: float
                  ) -> tuple[tuple[float, float, float], Covariance3]:
        """The believed pose plus the robot's b, and the corrected pose's covariance: b's
        plus the yaw's own frame-to-frame noise (:attr:`BiasParams.yaw_noise_rad`)."""
        b, p = self.bias(robot)
        yaw = math.remainder(yaw_rad + float(b[2]), math.tau)
        own = np.diag([0.0, 0.0, self._yaw_noise2(robot)])
        return (x_m + float(b[0]), y_m + float(b[1]), yaw), covariance3_rows(p + own)

    def _predicted(self, robot: str, stamp_ns: int) -> _Robot:
        """The robot's filter carried to ``stamp_ns`` (a stamp before its last: as it is)."""
        prior = self.stationary(robot)
        r = self._robots.get(robot)
        if r is None:
            return _Robot(stamp_ns, np.zeros(3), prior)
        dt = (stamp_ns - r.stamp_ns) / NS_PER_S
        if dt <= 0:
            return r
        a = math.exp(-dt / self.params.tau_s)
        return _Robot(stamp_ns, a * r.b, a * a * r.p + (1.0 - a * a) * prior)

    def update(self, robot: str, stamp_ns: int, residual_m: tuple[float, float],
               offset_m: tuple[float, float], covariance: Covariance,
               used: tuple[float, float, float], supporters: int = 2) -> None:
        """Take in one residual: the track's position minus the robot's estimate at
        ``stamp_ns``, the estimate located with the bias ``used`` (x, y, yaw) added to the
        believed pose; ``offset_m`` from the corrected robot position to its estimate;
        ``covariance`` the residual's own (the estimate's plus the track's); ``supporters``
        the robots the track stood on (this one included), for the learnt spread."""
        h = bias_jacobian(*offset_m)
        if self.learnt is not None:  # the uncorrected estimate's residual, estimate - track
            raw = -(np.asarray(residual_m) + h @ np.asarray(used))
            self.learnt.observe(robot, stamp_ns, (float(raw[0]), float(raw[1])), offset_m,
                                np.asarray(covariance, np.float64), supporters)
        r = self._predicted(robot, stamp_ns)
        # the estimate without any correction is z - H used: the residual against it is
        # residual + H used, and its innovation that minus H b (b as corrections see it)
        seen = r.b - self._common()
        innovation = np.asarray(residual_m) + h @ (np.asarray(used) - seen)
        s = h @ r.p @ h.T + self.params.residual_scale * np.asarray(covariance, np.float64)
        k = np.linalg.solve(s, h @ r.p).T  # P H^T S^-1 (S and P symmetric)
        b = r.b + k @ innovation
        p = (np.eye(3) - k @ h) @ r.p
        self._robots[robot] = _Robot(stamp_ns, b, 0.5 * (p + p.T))
        self.updates += 1
