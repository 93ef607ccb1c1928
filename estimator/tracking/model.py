"""The ball's motion model and the Kalman filter's steps, as the maths reads.

State ``x = [p_x, p_y, v_x, v_y]^T`` in the field frame [m, m/s], covariance ``P``. Between
stamps ``dt = (t_k - t_{k-1}) / 1e9`` [s] the ball rolls with linear friction (velocity decays
at the rate beta [1/s]; beta = 0 is constant velocity)::

    a = exp(-beta dt),   g = (1 - a) / beta   (g = dt when beta = 0)
    p_k = p_{k-1} + g v_{k-1},   v_k = a v_{k-1}                  x_k = F(dt) x_{k-1}
    F(dt) = [[I, g I], [0, a I]]

driven by white acceleration noise of spectral density q [m^2/s^3], discretised as for the
constant-velocity model (Bar-Shalom, Li & Kirubarajan, *Estimation with Applications to
Tracking and Navigation*, 2001, sec. 6.2.2)::

    Q(dt) = q [[dt^3/3 I, dt^2/2 I], [dt^2/2 I, dt I]]

A robot's estimate measures the position, ``z = H x + w``, ``H = [I 0]``, ``w ~ N(0, R)``
with the robot's own 2 x 2 covariance R. Predict and update (Joseph form, which keeps P
symmetric positive definite)::

    x^- = F x,   P^- = F P F^T + Q                                predict
    nu = z - H x^-,   S = H P^- H^T + R,   K = P^- H^T S^-1       innovation, gain
    x = x^- + K nu,   P = (I - K H) P^- (I - K H)^T + K R K^T     update
    d^2 = nu^T S^-1 nu                                            Mahalanobis distance

d^2 is chi-square with 2 degrees of freedom when the model holds; the gate compares it with
a quantile. Pure numpy, no state: the tracker (:mod:`estimator.tracking.tracker`) keeps the state.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

__all__ = ["Gaussian", "innovation", "predict", "process_noise", "transition", "update"]

Matrix = npt.NDArray[np.float64]
Gaussian = tuple[Matrix, Matrix]
"""(x, P): a mean and its covariance."""

_H = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
_I4 = np.eye(4)


def transition(dt_s: float, friction_per_s: float) -> Matrix:
    """F(dt) of the rolling ball with linear friction beta (module docstring)."""
    if friction_per_s > 0.0:
        a = math.exp(-friction_per_s * dt_s)
        g = -math.expm1(-friction_per_s * dt_s) / friction_per_s
    else:
        a, g = 1.0, dt_s
    return np.array([[1.0, 0.0, g, 0.0], [0.0, 1.0, 0.0, g],
                     [0.0, 0.0, a, 0.0], [0.0, 0.0, 0.0, a]])


def process_noise(dt_s: float, q: float) -> Matrix:
    """Q(dt) = q [[dt^3/3 I, dt^2/2 I], [dt^2/2 I, dt I]] (white acceleration noise)."""
    t = abs(dt_s)
    c3, c2, c1 = q * t**3 / 3.0, q * t * t / 2.0, q * t
    return np.array([[c3, 0.0, c2, 0.0], [0.0, c3, 0.0, c2],
                     [c2, 0.0, c1, 0.0], [0.0, c2, 0.0, c1]])


def predict(state: Gaussian, dt_s: float, *, q: float, friction_per_s: float) -> Gaussian:
    """x^- = F x, P^- = F P F^T + Q (no noise added for dt <= 0)."""
    x, p = state
    if dt_s == 0.0:
        return x, p
    f = transition(dt_s, friction_per_s)
    p_pred = f @ p @ f.T
    if dt_s > 0.0:
        p_pred = p_pred + process_noise(dt_s, q)
    return f @ x, 0.5 * (p_pred + p_pred.T)


def innovation(state: Gaussian, z: Matrix, r: Matrix) -> tuple[Matrix, Matrix, float]:
    """(nu, S, d^2) of a position measurement z with covariance R."""
    x, p = state
    nu = z - x[:2]
    s = p[:2, :2] + r
    d2 = float(nu @ np.linalg.solve(s, nu))
    return nu, s, d2


def update(state: Gaussian, z: Matrix, r: Matrix) -> Gaussian:
    """The Kalman update with z ~ N(H x, R), Joseph form."""
    x, p = state
    nu, s, _ = innovation(state, z, r)
    k = np.linalg.solve(s, p[:2, :]).T  # K = P H^T S^-1 (S and P symmetric)
    ikh = _I4 - k @ _H
    p_new = ikh @ p @ ikh.T + k @ r @ k.T
    return x + k @ nu, 0.5 * (p_new + p_new.T)
