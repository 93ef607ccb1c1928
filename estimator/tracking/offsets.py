"""The track's velocity free of how the robots disagree: each robot's offset beside the ball.

Two robots that see one ball place it a few centimetres apart (each its own pose error,
its own camera's), and the gap between them lasts for seconds. The tracker takes each
estimate as the ball plus white noise, so where the robots' estimates alternate (cameras
that run free, a few milliseconds apart) the gap reads as motion: 3 cm between two robots
10 ms apart is 3 m/s, of which the filter keeps a share at every step, and the track's
velocity wanders by tenths of a metre per second while its position stays within the
gap.

:class:`OffsetFilter` runs beside the tracker, on the estimates the tracker accepted and
with their covariances, a Kalman filter whose state is the ball's (x, y, vx, vy) and one
2-D offset per robot (the bias-augmented, or Schmidt, filter)::

    z_i = p + o_i + w_i,    w_i ~ N(0, R_i)

each o_i a first-order Gauss-Markov process per axis, stationary standard deviation
``sigma_m`` and time constant ``tau_s`` (the robots' bias model,
:class:`~estimator.tracking.bias.BiasParams`: 5 cm, 5 s), independent of the others. A
robot's own estimates, whatever their offset, then tell the ball's motion, and the
offsets between robots are what they disagree by, not motion. What all robots share
moves the ball with them (no estimate can tell it apart), so the offsets' mean is held
by their prior. The ball's part moves as the tracker's (constant velocity with rolling
friction, the same white acceleration noise), a kick widens its velocity as the
tracker's does, and the offsets carry on from one track to the next (a robot's error does
not end with a kick). The track's position stays the tracker's; its velocity is this
filter's. Deterministic: the same estimates in the same order give the same bits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from estimator.constants import NS_PER_S
from estimator.tracking.bias import BiasParams
from estimator.tracking.model import Gaussian, Matrix, process_noise, transition
from estimator.tracking.params import TrackerParams

__all__ = ["OffsetFilter"]


@dataclass
class OffsetFilter:
    """The ball and the robots' offsets (module docstring): one per tracker."""

    params: TrackerParams = field(default_factory=TrackerParams)
    """The tracker's: the ball's motion and its kicks."""
    sigma_m: float = BiasParams.sigma_m
    """Stationary standard deviation of each axis of a robot's offset [m]."""
    tau_s: float = BiasParams.tau_s
    """Time constant of a robot's offset [s]."""
    robots: dict[str, int] = field(default_factory=dict)
    """Robot -> its offset's index, in the order they were first seen."""
    _carry: tuple[int, Matrix, Matrix] | None = None
    """(stamp, offsets, their covariance) of the last state made final."""

    def _index(self, robot: str) -> int:
        return self.robots.setdefault(robot, len(self.robots))

    def _padded(self, g: Gaussian) -> Gaussian:
        """``g`` with a prior offset for each robot it does not hold yet."""
        x, p = g
        n = 4 + 2 * len(self.robots)
        if len(x) == n:
            return g
        x2, p2 = np.zeros(n), np.eye(n) * self.sigma_m**2
        x2[:len(x)] = x
        p2[:len(x), :len(x)] = p
        return x2, p2

    def step(self, g: Gaussian, dt_s: float, *, kick: bool, robot: str, z: Matrix, r: Matrix,
             accepted: bool) -> Gaussian:
        """The state after the tracker's next estimate, ``dt_s`` after ``g``'s: kicked
        before it where the tracker's was, updated with it where the tracker accepted it."""
        if kick:
            g = self.kicked(g)
        g = self.predict(g, dt_s)
        return self.update(g, robot, z, r) if accepted else g

    def predict(self, g: Gaussian, dt_s: float) -> Gaussian:
        """The state ``dt_s`` later (no noise added for dt <= 0, as the tracker's)."""
        x, p = self._padded(g)
        if dt_s == 0.0:
            return x, p
        n = len(x)
        f = np.eye(n)
        f[:4, :4] = transition(dt_s, self.params.friction_per_s)
        noise = np.zeros((n, n))
        if dt_s > 0.0:
            a = math.exp(-dt_s / self.tau_s)
            f[4:, 4:] *= a
            noise[:4, :4] = process_noise(dt_s, self.params.accel_noise_m2_s3)
            noise[4:, 4:] = np.eye(n - 4) * self.sigma_m**2 * (1.0 - a * a)
        pp = f @ p @ f.T + noise
        return f @ x, 0.5 * (pp + pp.T)

    def kicked(self, g: Gaussian) -> Gaussian:
        """``g`` after an impulse of unknown size (its velocity widened as the tracker's)."""
        x, p = self._padded(g)
        p = p.copy()
        p[2, 2] += self.params.kick_sigma_m_s**2
        p[3, 3] += self.params.kick_sigma_m_s**2
        return x, p

    def update(self, g: Gaussian, robot: str, z: Matrix, r: Matrix) -> Gaussian:
        """The Kalman update with the robot's estimate ``z`` (covariance ``r``), Joseph form."""
        k = self._index(robot)
        x, p = self._padded(g)
        n = len(x)
        h = np.zeros((2, n))
        h[:, :2] = np.eye(2)
        h[:, 4 + 2 * k:6 + 2 * k] = np.eye(2)
        s = h @ p @ h.T + r
        gain = np.linalg.solve(s, h @ p).T
        ikh = np.eye(n) - gain @ h
        pn = ikh @ p @ ikh.T + gain @ r @ gain.T
        return x + gain @ (z - h @ x), 0.5 * (pn + pn.T)

    def start(self, initial: Gaussian, robot: str, stamp_ns: int) -> Gaussian:
        """A new track's state at its first estimate (the tracker's ``initial``, from the
        robot's estimate alone): the offsets carried on from the last final state, decayed
        to ``stamp_ns``, and the ball where the estimate puts it less the robot's offset."""
        k = self._index(robot)
        n = 4 + 2 * len(self.robots)
        x, p = np.zeros(n), np.eye(n) * self.sigma_m**2
        x[:4], p[:4, :4] = initial
        if self._carry is not None:
            stamp, off, cov = self._carry
            a = math.exp(-max(stamp_ns - stamp, 0) / NS_PER_S / self.tau_s)
            m = len(off)
            x[4:4 + m] = a * off
            p[4:4 + m, 4:4 + m] = a * a * cov + np.eye(m) * self.sigma_m**2 * (1.0 - a * a)
        x[:2] -= x[4 + 2 * k:6 + 2 * k]
        return x, p

    def of(self, g: Gaussian) -> dict[str, tuple[float, float]]:
        """Each robot's offset in ``g`` (x, y) [m], in the order the robots were first seen."""
        x = g[0]
        return {r: (float(x[4 + 2 * k]), float(x[5 + 2 * k])) for r, k in self.robots.items()
                if 6 + 2 * k <= len(x)}

    def velocity(self, g: Gaussian, dt_s: float) -> Gaussian:
        """The ball's velocity and its covariance ``dt_s`` after ``g``."""
        x, p = self.predict(g, dt_s)
        return x[2:4], p[2:4, 2:4]

    def settle(self, g: Gaussian, stamp_ns: int) -> None:
        """``g`` at ``stamp_ns`` is final: its offsets carry on to the next track."""
        x, p = g
        self._carry = (stamp_ns, x[4:].copy(), p[4:, 4:].copy())
