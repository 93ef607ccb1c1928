"""Re-acquisition: do the estimates the track rejected agree on another ball path?

After a hard bounce straight back, or when a track started on a false blob (an orange object
a robot that cannot see the ball reports), the correct estimates all fall outside the track's
gate, and the track coasts away. :func:`reacquire_from` looks at the rejected estimates of the
last ``window_ns`` that one ball at constant velocity explains (:func:`cv_fit`) and says
whether the track should restart from them:

- when the track heard nothing since they began (a bounce the gate missed);
- when more robots support them than the track heard over the window (a false blob is
  usually seen by one robot at a time, the ball by several);
- but a false blob is a still object: still estimates never displace a moving track, and a
  still track yields to moving estimates even when fewer robots see them. Estimates are
  moving when their fit says so and they moved by more than their noise.

The constant-velocity test is a weighted least-squares fit of ``z_i = p + v (t_i - t_0) + w_i`` with
``w_i ~ N(0, R_i + M_i)``, where ``M_i = (m^2 + (a_max dt_i^2 / 2)^2) I`` allows for a few
centimetres of localisation bias between robots and for rolling friction over the window.
The fit's residual ``chi^2`` (``2n - 4`` degrees of freedom) must not exceed its 0.999
quantile, and ``|v| <= max_speed``. Pure numpy, no state.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from estimator.constants import NS_PER_S
from estimator.tracking.model import Gaussian, Matrix

__all__ = ["Candidate", "Point", "chi_square_tail", "cv_fit", "reachable", "reacquire_from",
           "travelled"]

Point = tuple[float, Matrix, Matrix]
"""(time [s], z [m] (2,), R [m^2] (2, 2))."""

MODEL_SIGMA_M = 0.03
"""m: allowance for localisation bias between robots [m]."""
MAX_ACCEL_M_S2 = 2.0
"""a_max: allowance for friction and hops over the window [m/s^2]."""
STILL_M_S = 0.2
"""A track slower than this is still [m/s]."""
MOVING_M_S = 0.5
"""Estimates whose fitted speed exceeds this are moving [m/s]."""
TRAVELLED_M = 0.5
"""A track that has been this far from its first estimate has followed something that
moves [m]: the ball, not a still false blob (the tracker then lets no clutter displace it)."""


@dataclass(frozen=True)
class Candidate:
    """One estimate in the track's memory, as re-acquisition sees it."""

    stamp_ns: int
    robot: str
    z: Matrix
    """position [m] (2,)"""
    r: Matrix
    """covariance [m^2] (2, 2)"""
    accepted: bool
    shared: Matrix | None = None
    """the part of r its robot's estimates share (its pose's) [m^2] (2, 2), or None"""


def chi_square_tail(x: float, dof: int) -> float:
    """P(chi^2_dof > x) for an even number of degrees of freedom (closed form)."""
    half = 0.5 * x
    term, total = 1.0, 1.0
    for j in range(1, dof // 2):
        term *= half / j
        total += term
    return math.exp(-half) * total


def cv_fit(points: Sequence[Point], *, max_speed_m_s: float,
           p_value: float = 0.001) -> tuple[float, float] | None:
    """The velocity [m/s] of one ball at a constant velocity (at most ``max_speed_m_s``)
    that gives every point; None when there is none."""
    t0 = points[-1][0]
    normal = np.zeros((4, 4))
    rhs = np.zeros(4)
    rows = []
    for t, z, r in points:
        dt = t - t0
        w = np.linalg.inv(r + (MODEL_SIGMA_M**2 + (0.5 * MAX_ACCEL_M_S2 * dt * dt) ** 2)
                          * np.eye(2))
        a = np.hstack([np.eye(2), dt * np.eye(2)])
        normal += a.T @ w @ a
        rhs += a.T @ w @ z
        rows.append((a, w, z))
    x = np.linalg.lstsq(normal, rhs, rcond=None)[0]
    v = (float(x[2]), float(x[3]))
    if math.hypot(*v) > max_speed_m_s:
        return None
    dof = 2 * len(points) - 4
    chi2 = sum(float((z - a @ x) @ w @ (z - a @ x)) for a, w, z in rows)
    return v if dof <= 0 or chi_square_tail(chi2, dof) >= p_value else None


def reachable(a: Candidate, b: Candidate, *, max_speed_m_s: float, gate: float) -> bool:
    """Could one ball at a free velocity (|v| <= max_speed) give both estimates?"""
    dt = abs(b.stamp_ns - a.stamp_ns) / NS_PER_S
    c = a.r + b.r + (max_speed_m_s * dt) ** 2 * np.eye(2)
    dz = b.z - a.z
    return float(dz @ np.linalg.solve(c, dz)) <= gate


def travelled(state: Gaussian, origin: Gaussian, *, gate: float) -> bool:
    """Is a track's position (``state``: x, P) ``TRAVELLED_M`` or more from its first
    estimate (``origin``: z, R), and beyond the ``gate`` of their noise? A still false blob's
    track stays within its noise; the ball's travels."""
    (x, p), (z0, r0) = state, origin
    dz = x[:2] - z0
    return bool(math.hypot(dz[0], dz[1]) >= TRAVELLED_M
                and float(dz @ np.linalg.solve(r0 + p[:2, :2], dz)) > gate)


def _moving(first: Candidate, last: Candidate, v: tuple[float, float], *,
            own_noise: bool = False) -> bool:
    """Moving: the fitted speed exceeds MOVING_M_S and the estimates moved by more than 3
    sigma of their noise (two estimates 13 ms apart give a speed of metres per second from
    centimetres of noise alone). ``own_noise``: two estimates of one robot leave out the
    noise they share (its pose's bias is in both, so it moves neither from the other)."""
    dz = last.z - first.z
    s = first.r + last.r
    if own_noise and first.robot == last.robot and first.shared is not None and (
            last.shared is not None):
        s = s - first.shared - last.shared
    return math.hypot(*v) > MOVING_M_S and float(dz @ np.linalg.solve(s, dz)) > 9.0


def reacquire_from(history: Sequence[Candidate], *, track_speed_m_s: float, window_ns: int,
                   count: int, max_speed_m_s: float, gate: float,
                   tentative: bool = False) -> int | None:
    """The index in ``history`` (the track's estimates in stamp order, ending with a rejected
    one) of the first estimate the track should restart from; None to keep the track.
    ``track_speed_m_s``: the track's speed before the last estimate. ``tentative``: the
    track is not confirmed, and one robot's estimates that moved by more than the noise
    they do not share (their pose's) are moving; a confirmed track needs them to move by
    more than all of it (a far robot's false blob, its pose unsure, does not take it)."""
    newest = history[-1]
    agree, v = [len(history) - 1], (0.0, 0.0)
    for i in range(len(history) - 2, -1, -1):
        f = history[i]
        if newest.stamp_ns - f.stamp_ns > window_ns:
            break
        if f.accepted or not all(reachable(f, history[j], max_speed_m_s=max_speed_m_s,
                                           gate=gate) for j in agree):
            continue
        fit = cv_fit([(history[j].stamp_ns / NS_PER_S, history[j].z, history[j].r)
                      for j in [i, *agree]], max_speed_m_s=max_speed_m_s)
        if fit is not None:
            agree, v = [i, *agree], fit
    first = history[agree[0]].stamp_ns
    heard = [x for x in history
             if x.accepted and x.stamp_ns >= min(first, newest.stamp_ns - window_ns)]
    support = len({history[j].robot for j in agree}) - len({x.robot for x in heard})
    silent = not any(x.stamp_ns >= first for x in heard)
    still = track_speed_m_s < STILL_M_S
    moving = _moving(history[agree[0]], newest, v, own_noise=tentative)
    if len(agree) < count or not (still or moving) or not (
            silent or support > 0 or (still and moving)):
        return None
    return agree[0]
