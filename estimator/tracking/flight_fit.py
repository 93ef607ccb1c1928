"""One flight from many rays, each at its own stamp: a weighted linear least squares.

Under gravity (air drag neglected) a ball that left the ground at ``t_c`` from the point
``(x_c, y_c, R)`` flies p(t) = p_c + v (t - t_c) + a (t - t_c)^2 / 2 with a = (0, 0, -g):
with g known, p(t) is linear in the unknowns (x_c, y_c, v). A ray (camera c_i, unit
direction d_i, stamp t_i) says p(t_i) lies on it: the two components of p(t_i) - c_i across
d_i (:meth:`~estimator.rays.BallRay.across`) are zero, each known to its angular sigma times
the distance along the ray, L_i sigma. So every ray gives two linear equations, whichever
robot saw it and whenever, and free-running cameras need no two rays of one instant: rays
of three robots over a few images fix a flight, and one robot's rays over several images
fix one too where the camera moves across the ball's path or the ball's path curves in its
view (gravity is known: the height shows in how the ray falls).

:func:`fit_kink` fits two pieces that meet at the ground at ``t_c``: before it the ball
rolled (z = R, a constant level velocity) or flew (a previous flight: the contact is a
bounce); after it the ball flies (``after="fly"``) or rolls (a kick along the ground: the
hypothesis a lob must beat). The unknowns are (x_c, y_c), the velocity before and the
velocity after; the distances L_i come from the previous solution (three passes, the first
from each ray's ground point). :func:`contact_time` scans the instants between the rays'
stamps for the ``t_c`` that fits best. Rays more than :data:`RAY_GATE_CHI2` off the fit
(a false blob, a ray of the ball held by a robot) are dropped, the worst first, and the fit
made again. Pure and deterministic.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from estimator.constants import BALL_RADIUS_M, NS_PER_S
from estimator.estimates import Matrix
from estimator.rays import BallRay

__all__ = ["RAY_GATE_CHI2", "Kink", "StampedRay", "contact_time", "fit_kink"]

G_MPS2 = 9.81
RAY_GATE_CHI2 = 13.82
"""A ray whose two offsets across it, in its sigmas, sum to more than this chi-square
(2 degrees of freedom, 99.9 %) is not the fitted ball's."""
_MIN_LENGTH_M = 0.1
_PASSES = 3
_MAX_DROPPED = 3

StampedRay = tuple[int, BallRay]
"""A ray and its image's stamp [ns]."""


@dataclass(frozen=True)
class Kink:
    """Two pieces of the ball's way meeting on the ground at ``contact_ns``."""

    contact_ns: int
    before: str
    """"roll" or "fly"."""
    after: str
    theta: Matrix
    """(x_c, y_c, the velocity before, the velocity after): 2 + 2 or 3 + 2 or 3 values."""
    cov: Matrix
    chi2: float
    rays: int
    """The rays the fit kept."""
    robots: int
    """How many robots' rays after the contact it kept."""

    def _columns(self, piece: str, first: int) -> slice:
        return slice(first, first + (3 if piece == "fly" else 2))

    @property
    def _first_after(self) -> int:
        return {"fly": 5, "roll": 4, "free": 3}[self.before]

    def state_at(self, stamp_ns: int) -> tuple[Matrix, Matrix]:
        """The ball's (x, y, z, vx, vy, vz) after the contact at ``stamp_ns``, and its
        covariance."""
        tau = (stamp_ns - self.contact_ns) / NS_PER_S
        n = self.theta.size
        M = np.zeros((6, n))
        M[0, 0] = M[1, 1] = 1.0
        if self.before == "free":
            M[2, 2] = 1.0
        cols = self._columns(self.after, self._first_after)
        k = cols.stop - cols.start
        M[0:k, cols] += np.eye(k) * tau
        M[3:3 + k, cols] = np.eye(k)
        b = np.array([0.0, 0.0, 0.0 if self.before == "free" else BALL_RADIUS_M, 0, 0, 0])
        if self.after == "fly":
            b[2] -= 0.5 * G_MPS2 * tau * tau
            b[5] -= G_MPS2 * tau
        return M @ self.theta + b, M @ self.cov @ M.T

    @property
    def velocity_after(self) -> Matrix:
        v = self.theta[self._columns(self.after, self._first_after)]
        return v if v.size == 3 else np.array([v[0], v[1], 0.0])

    def landing_ns(self) -> int | None:
        """When the flight after the contact meets the ground again (None: it rolls)."""
        if self.after != "fly":
            return None
        x, _ = self.state_at(self.contact_ns)
        vz, h = float(x[5]), max(float(x[2]) - BALL_RADIUS_M, 0.0)
        t = (vz + math.sqrt(vz * vz + 2.0 * G_MPS2 * h)) / G_MPS2
        return self.contact_ns + round(t * NS_PER_S) if t > 1e-3 else None


def _model(taus: Matrix, before: str, after: str) -> tuple[Matrix, Matrix]:
    """Each ray's M (3 x n) and b (3): p(t_i) = M_i theta + b_i. ``before="free"``: no
    contact, one flight through all the rays, theta = (x, y, z) at ``contact_ns`` and the
    velocity then."""
    free = before == "free"
    nb = {"fly": 3, "roll": 2, "free": 1}[before]
    na = 3 if after == "fly" else 2
    n = 2 + nb + na
    m = len(taus)
    M = np.zeros((m, 3, n))
    M[:, 0, 0] = M[:, 1, 1] = 1.0
    b = np.zeros((m, 3))
    if free:
        M[:, 2, 2] = 1.0
    else:
        b[:, 2] = BALL_RADIUS_M
    pieces = [(after, 2 + nb, na, np.ones(m, bool))] if free else [
        (before, 2, nb, taus < 0.0), (after, 2 + nb, na, taus >= 0.0)]
    for piece, first, k, mask in pieces:
        t = np.where(mask, taus, 0.0)
        for j in range(k):
            M[:, j, first + j] = t
        if piece == "fly":
            b[:, 2] -= 0.5 * G_MPS2 * t * t
    return M, b


@functools.lru_cache(maxsize=4096)
def _ray_rows(ray: BallRay) -> Matrix:
    """A ray as the fits use it, one row: camera (3), direction (3), the two unit vectors
    across it (6), its two sigmas, the distance to its ground point (made once a ray)."""
    c = np.array(ray.origin)
    e_az, e_el = ray.across()
    length = max(float(np.linalg.norm(np.array(ray.ground_point) - c)), _MIN_LENGTH_M)
    return np.concatenate([c, ray.direction, e_az, e_el,
                           [ray.sigma_azimuth_rad, ray.sigma_elevation_rad, length]])


def _solve(rays: Sequence[StampedRay], contact_ns: int, before: str, after: str
           ) -> tuple[Matrix, Matrix, Matrix] | None:
    """theta, its covariance and each ray's chi-square; None when the rays do not fix it."""
    taus = np.array([(t - contact_ns) / NS_PER_S for t, _ in rays])
    M, b = _model(taus, before, after)
    rows = np.array([_ray_rows(r) for _, r in rays])
    c, d, E = rows[:, 0:3], rows[:, 3:6], rows[:, 6:12].reshape(-1, 2, 3)
    sig, length = rows[:, 12:14], rows[:, 14]
    EM = np.einsum("mij,mjn->min", E, M)  # (m, 2, n)
    Ey = np.einsum("mij,mj->mi", E, c - b)
    theta = cov = chi = None
    for k in range(_PASSES):
        w = 1.0 / (length[:, None] * sig)
        A = (EM * w[:, :, None]).reshape(-1, M.shape[2])
        y = (Ey * w).reshape(-1)
        N = A.T @ A
        if k == 0 and np.linalg.cond(N) > 1e12:
            return None
        cov = np.linalg.inv(N)
        theta = cov @ (A.T @ y)
        p = np.einsum("mjn,n->mj", M, theta) + b
        length = np.maximum(np.einsum("mj,mj->m", d, p - c), _MIN_LENGTH_M)
        chi = (((A @ theta - y).reshape(-1, 2)) ** 2).sum(axis=1)
    assert theta is not None and cov is not None and chi is not None
    return theta, 0.5 * (cov + cov.T), chi


def fit_kink(rays: Sequence[StampedRay], contact_ns: int, before: str = "roll",
             after: str = "fly") -> Kink | None:
    """The two pieces meeting on the ground at ``contact_ns`` that the rays fit best (the
    worst rays beyond :data:`RAY_GATE_CHI2` dropped, up to three); None when the rays kept
    do not fix them (too few on either side)."""
    kept = list(rays)
    solved = _solve(kept, contact_ns, before, after)
    for _ in range(_MAX_DROPPED):
        if solved is None:
            return None
        worst = int(np.argmax(solved[2]))
        if solved[2][worst] <= RAY_GATE_CHI2 or len(kept) <= solved[0].size:
            break
        del kept[worst]
        solved = _solve(kept, contact_ns, before, after)
    if solved is None:
        return None
    theta, cov, chi = solved
    robots = len({r.robot for t, r in kept if t >= contact_ns or before == "free"})
    return Kink(contact_ns, before, after, theta, cov, float(chi.sum()), len(kept), robots)


def contact_time(rays: Sequence[StampedRay], lo_ns: int, hi_ns: int, before: str = "roll",
                 after: str = "fly", min_after: int = 2, min_before: int = 1) -> Kink | None:
    """The contact between ``lo_ns`` and ``hi_ns`` whose fit drops the fewest rays and,
    among those, has the smallest chi-square; None when no instant leaves ``min_after``
    rays after it and a fit. Between two rays' stamps the chi-square is smooth in the
    contact's instant: each gap is tried at its middle, and the best one searched
    through (golden section, to a millisecond)."""
    stamps = sorted({t for t, _ in rays})
    gaps: list[tuple[Kink, int, int]] = []
    for t0, t1 in itertools.pairwise(stamps):
        a, b = max(t0 + 1, lo_ns), min(t1, hi_ns)
        if a > b or sum(1 for t, _ in rays if t >= t1) < min_after or sum(
                1 for t, _ in rays if t <= t0) < min_before:
            continue
        kink = fit_kink(rays, (a + b) // 2, before, after)
        if kink is not None:
            gaps.append((kink, a, b))
    gaps.sort(key=lambda g: _rank(g[0]))
    found = [_refine(rays, kink, a, b) for kink, a, b in gaps[:1]]
    return min(found, key=_rank) if found else None


def _rank(kink: Kink) -> tuple[int, float]:
    return -kink.rays, kink.chi2


def _refine(rays: Sequence[StampedRay], kink: Kink, a: int, b: int) -> Kink:
    """The best contact in [a, b] (golden section on the chi-square, to 1 ms)."""
    best = kink
    r = (math.sqrt(5.0) - 1.0) / 2.0
    while b - a > 1_000_000:
        m1, m2 = round(b - r * (b - a)), round(a + r * (b - a))
        k1 = fit_kink(rays, m1, kink.before, kink.after)
        k2 = fit_kink(rays, m2, kink.before, kink.after)
        if k1 is None or k2 is None:
            break
        if _rank(k1) <= _rank(k2):
            b = m2
            best = min(best, k1, key=_rank)
        else:
            a = m1
            best = min(best, k2, key=_rank)
    return best


def height_at(kink: Kink, stamp_ns: int) -> float:
    """The fitted centre's height at ``stamp_ns``."""
    return float(kink.state_at(stamp_ns)[0][2])


def per_dof(kink: Kink) -> float:
    """The fit's chi-square per degree of freedom (inf with none)."""
    dof = 2 * kink.rays - kink.theta.size
    return kink.chi2 / dof if dof > 0 else math.inf
