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
made again. The fits of one scan are solved together (:func:`fit_kinks`: one batch of
normal equations per pass, a dropped ray weighing nothing), and a rough fit (one pass,
the worst rays dropped at once) tells cheaply whether a fit is worth making well. Pure and
deterministic.
"""

from __future__ import annotations

import bisect
import functools
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from estimator.constants import BALL_RADIUS_M, NS_PER_S
from estimator.estimates import Matrix
from estimator.rays import BallRay

__all__ = ["RAY_GATE_CHI2", "Gap", "Job", "Kink", "StampedRay", "best_gap", "best_of",
           "contact_time", "fit_jobs", "fit_kink", "fit_kinks", "gap_spans", "middles",
           "ray_rows", "refine"]

G_MPS2 = 9.81
RAY_GATE_CHI2 = 13.82
"""A ray whose two offsets across it, in its sigmas, sum to more than this chi-square
(2 degrees of freedom, 99.9 %) is not the fitted ball's."""
_MIN_LENGTH_M = 0.1
_PASSES = 3
_MAX_DROPPED = 3
_REFINE_NS = 1_000_000
_REFINE_STEPS = 32
"""A gap searched for the contact is tried every :data:`_REFINE_NS` or at this many
instants and one more, then at half as many about the best of them."""

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


def _columns(taus: Matrix, before: str, after: str) -> tuple[list[tuple[int, Matrix | None]],
                                                          Matrix]:
    """The fit's unknowns for rays at ``taus`` (any shape: the rays' instants after each
    contact tried): p(t_i) = sum over theta's entries k of theta_k f_k(t_i) e_axis(k), + b_i.
    Each entry's axis and factor (None: 1), and b. ``before="free"``: no contact, one flight
    through all the rays, theta = (x, y, z) at ``contact_ns`` and the velocity then."""
    b = np.zeros((*taus.shape, 3))
    if before == "free":
        cols: list[tuple[int, Matrix | None]] = [(0, None), (1, None), (2, None)]
        pieces = [(after, taus)]
    else:
        cols = [(0, None), (1, None)]
        b[..., 2] = BALL_RADIUS_M
        pieces = [(before, np.minimum(taus, 0.0)), (after, np.maximum(taus, 0.0))]
    for piece, t in pieces:
        cols += [(j, t) for j in range(3 if piece == "fly" else 2)]
        if piece == "fly":
            b[..., 2] -= 0.5 * G_MPS2 * t * t
    return cols, b


@functools.lru_cache(maxsize=4096)
def ray_rows(ray: BallRay) -> Matrix:
    """A ray as the fits (and the follower's surprise) use it, one row: camera (3),
    direction (3), the two unit vectors across it (6: :meth:`~estimator.rays.BallRay.across`),
    its two sigmas, the distance to its ground point (made once a ray, in plain floats: a
    ray's numpy arrays cost more than its arithmetic)."""
    (ox, oy, oz), (ux, uy, uz) = ray.origin, ray.direction
    h = math.hypot(ux, uy)
    ax, ay = (-uy / h, ux / h) if h > 1e-12 else (0.0, 1.0)
    ex, ey, ez = -uz * ay, uz * ax, ux * ay - uy * ax  # u x e_az (e_az level)
    norm = math.sqrt(ex * ex + ey * ey + ez * ez)
    t = (oz - BALL_RADIUS_M) / -uz if uz != 0.0 else math.inf
    length = max(math.sqrt((t * ux) ** 2 + (t * uy) ** 2 + (t * uz) ** 2), _MIN_LENGTH_M)
    return np.array([ox, oy, oz, ux, uy, uz, ax, ay, 0.0, ex / norm, ey / norm, ez / norm,
                     ray.sigma_azimuth_rad, ray.sigma_elevation_rad, length])


_Solved = tuple[Matrix, Matrix, Matrix, Matrix]
_Design = tuple[Matrix, Matrix, Matrix, Matrix, Matrix]
"""Per fit and ray: its two offsets across the ray per unknown (g, m, 2, w), its distance
along it per unknown (g, m, w), the offsets and the distance of the rest (g, m, 2 and g, m),
and which of the w unknowns the fit has not (1, else 0; g, w)."""
Job = tuple[Sequence[int], str, str]
"""Contacts to fit at, and the pieces before and after them (:func:`fit_kink`)."""


def _design(rows: Matrix, taus: Matrix, before: str, after: str, width: int) -> _Design:
    cols, b = _columns(taus, before, after)
    g, m = taus.shape
    c, d, E = rows[:, 0:3], rows[:, 3:6], rows[:, 6:12].reshape(-1, 2, 3)
    EM = np.zeros((g, m, 2, width))
    dM = np.zeros((g, m, width))
    for k, (axis, f) in enumerate(cols):
        EM[..., k] = E[:, :, axis] if f is None else E[:, :, axis] * f[..., None]
        dM[..., k] = d[:, axis] if f is None else d[:, axis] * f
    Ey = (E @ c[:, :, None])[None, :, :, 0] - E[None, :, :, 2] * b[..., 2:3]
    dbc = d[:, 2] * b[..., 2] - (d * c).sum(axis=1)
    pad = np.broadcast_to((np.arange(width) >= len(cols)).astype(np.float64), (g, width))
    return EM, dM, Ey, dbc, pad


def _solve(rows: Matrix, design: _Design, keep: Matrix, passes: int) -> _Solved:
    """Many fits at once, one per row of ``design``, with the rays ``keep`` says (a dropped
    ray weighs nothing; an unknown a fit has not, nothing either): each fit's theta, its
    covariance, each ray's chi-square, and whether the rays fix it."""
    EM, dM, Ey, dbc, pad = design
    g, m, _, width = EM.shape
    sig, length = rows[:, 12:14], np.broadcast_to(rows[:, 14], (g, m))
    diagonal = (slice(None), np.arange(width), np.arange(width))
    ok = np.ones(g, bool)
    theta = cov = chi = np.zeros(0)
    for k in range(passes):
        w = keep[:, :, None] / (length[:, :, None] * sig)
        A = (EM * w[..., None]).reshape(g, 2 * m, width)
        y = (Ey * w).reshape(g, 2 * m, 1)
        At = A.transpose(0, 2, 1)
        N = At @ A
        fill = N[diagonal].sum(axis=1) / np.maximum(width - pad.sum(axis=1), 1.0)
        N[diagonal] += pad * fill[:, None]  # between its least and largest eigenvalues
        if k == 0:
            eig = np.abs(np.linalg.eigvalsh(N))
            ok = eig.max(axis=1) <= 1e12 * eig.min(axis=1)
        N[~ok] = np.eye(width)  # not fixed: solved as anything, and dropped
        cov = np.linalg.inv(N)
        theta = cov @ (At @ y)
        length = np.maximum((dM @ theta)[..., 0] + dbc, _MIN_LENGTH_M)
        chi = ((A @ theta - y).reshape(g, m, 2) ** 2).sum(axis=2)
    return theta[..., 0], 0.5 * (cov + cov.transpose(0, 2, 1)), chi, ok


def fit_jobs(rays: Sequence[StampedRay], jobs: Sequence[Job], rough: bool = False
             ) -> list[list[Kink | None]]:
    """:func:`fit_kink` at each job's contacts, all solved together. ``rough``: the
    distances along the rays those of their ground points, the worst rays beyond the gate
    dropped all at once (a third of the solves)."""
    if not rays or not any(contacts for contacts, _, _ in jobs):
        return [[None] * len(contacts) for contacts, _, _ in jobs]
    rows = np.array([ray_rows(r) for _, r in rays])
    stamps = np.array([t for t, _ in rays], dtype=np.int64)
    at = np.array([t for contacts, _, _ in jobs for t in contacts], dtype=np.int64)
    taus = (stamps[None, :] - at[:, None]) / NS_PER_S
    sizes = [len(_columns(taus[:1], before, after)[0]) for _, before, after in jobs]
    parts, first = [], 0
    for (contacts, before, after) in jobs:
        parts.append(_design(rows, taus[first:first + len(contacts)], before, after,
                             max(sizes)))
        first += len(contacts)
    EM, dM, Ey, dbc, pad = (np.concatenate(arrays) for arrays in zip(*parts, strict=True))
    design = (EM, dM, Ey, dbc, pad)
    n = np.repeat(sizes, [len(contacts) for contacts, _, _ in jobs])
    keep = np.ones(taus.shape, bool)
    passes, rounds, at_once = (1, 1, _MAX_DROPPED) if rough else (_PASSES, _MAX_DROPPED, 1)
    theta, cov, chi, ok = _solve(rows, design, keep, passes)
    live = ok.copy()
    for _ in range(rounds):
        kept_chi = np.where(keep, chi, -np.inf)
        worst = np.argsort(-kept_chi, axis=1)[:, :at_once]
        beyond = (np.take_along_axis(kept_chi, worst, axis=1) > RAY_GATE_CHI2) & (
            np.arange(worst.shape[1]) < (keep.sum(axis=1) - n)[:, None])
        drop = live & beyond[:, 0]
        if not drop.any():
            break
        some = np.flatnonzero(drop)
        fit, which = np.nonzero(beyond[some])
        keep[some[fit], worst[some[fit], which]] = False
        part = (EM[some], dM[some], Ey[some], dbc[some], pad[some])
        theta[some], cov[some], chi[some], again = _solve(rows, part, keep[some], passes)
        ok[some] = again
        live = drop & ok
    names = sorted({r.robot for _, r in rays})
    seen = np.array([[r.robot == name for name in names] for _, r in rays])  # (m, robots)
    after = keep & ((stamps[None, :] >= at[:, None]) | np.repeat(
        [before == "free" for _, before, _ in jobs], [len(c) for c, _, _ in jobs])[:, None])
    robots = ((after.astype(np.int64) @ seen) > 0).sum(axis=1)
    total, kept = np.where(keep, chi, 0.0).sum(axis=1), keep.sum(axis=1)
    out: list[list[Kink | None]] = []
    i = 0
    for (contacts, before, after_), size in zip(jobs, sizes, strict=True):
        out.append([])
        for contact in contacts:
            out[-1].append(None if not ok[i] else Kink(
                contact, before, after_, theta[i, :size], cov[i, :size, :size],
                float(total[i]), int(kept[i]), int(robots[i])))
            i += 1
    return out


def fit_kinks(rays: Sequence[StampedRay], contacts: Sequence[int], before: str = "roll",
              after: str = "fly", rough: bool = False) -> list[Kink | None]:
    """:func:`fit_kink` at each of ``contacts``, solved together (:func:`fit_jobs`)."""
    return fit_jobs(rays, [(contacts, before, after)], rough)[0]


def fit_kink(rays: Sequence[StampedRay], contact_ns: int, before: str = "roll",
             after: str = "fly", rough: bool = False) -> Kink | None:
    """The two pieces meeting on the ground at ``contact_ns`` that the rays fit best (the
    worst rays beyond :data:`RAY_GATE_CHI2` dropped, up to three); None when the rays kept
    do not fix them (too few on either side)."""
    return fit_kinks(rays, [contact_ns], before, after, rough)[0]


Gap = tuple[Kink, int, int]
"""A contact's fit at the middle of a gap between the rays' stamps, and the gap [ns]."""


def gap_spans(rays: Sequence[StampedRay], lo_ns: int, hi_ns: int, min_after: int = 2,
              min_before: int = 1) -> list[tuple[int, int]]:
    """The gaps between two rays' stamps (within ``lo_ns`` and ``hi_ns``) with
    ``min_after`` rays after them and ``min_before`` before [ns]."""
    times = sorted(t for t, _ in rays)
    spans = []
    for t0, t1 in itertools.pairwise(sorted(set(times))):
        a, b = max(t0 + 1, lo_ns), min(t1, hi_ns)
        if a <= b and len(times) - bisect.bisect_left(times, t1) >= min_after and (
                bisect.bisect_right(times, t0) >= min_before):
            spans.append((a, b))
    return spans


def middles(spans: Sequence[tuple[int, int]]) -> list[int]:
    """Each gap's middle [ns]."""
    return [(a + b) // 2 for a, b in spans]


def best_of(fits: Sequence[Kink | None], spans: Sequence[tuple[int, int]]) -> Gap | None:
    """The gap whose fit at its middle (``fits``, of :func:`middles`) drops the fewest rays
    and, among those, has the smallest chi-square."""
    gaps = [(k, a, b) for k, (a, b) in zip(fits, spans, strict=True) if k is not None]
    return min(gaps, key=lambda g: _rank(g[0])) if gaps else None


def best_gap(rays: Sequence[StampedRay], lo_ns: int, hi_ns: int, before: str = "roll",
             after: str = "fly", min_after: int = 2, min_before: int = 1) -> Gap | None:
    """Of the gaps of :func:`gap_spans`, :func:`best_of`; all the gaps' fits solved
    together."""
    spans = gap_spans(rays, lo_ns, hi_ns, min_after, min_before)
    return best_of(fit_kinks(rays, middles(spans), before, after), spans)


def refine(rays: Sequence[StampedRay], gap: Gap) -> Kink:
    """The best contact in a gap (:func:`best_gap`): between two rays' stamps the
    chi-square is smooth in the contact's instant, so the gap is tried at up to
    :data:`_REFINE_STEPS` instants a millisecond or more apart, then at half as many
    about the best of them (each time all together)."""
    best, a, b = gap
    steps = min(_REFINE_STEPS, max(1, -(-(b - a) // _REFINE_NS)))
    for _ in range(2):
        at = [a + (b - a) * i // steps for i in range(steps + 1)]
        found = [k for k in fit_kinks(rays, at, best.before, best.after) if k is not None]
        best = min([best, *found], key=_rank)
        step = (b - a) // steps
        a, b = max(a, best.contact_ns - step), min(b, best.contact_ns + step)
        steps = _REFINE_STEPS // 2
    return best


def contact_time(rays: Sequence[StampedRay], lo_ns: int, hi_ns: int, before: str = "roll",
                 after: str = "fly", min_after: int = 2, min_before: int = 1) -> Kink | None:
    """The contact between ``lo_ns`` and ``hi_ns`` whose fit drops the fewest rays and,
    among those, has the smallest chi-square; None when no instant leaves ``min_after``
    rays after it and a fit: the best gap (:func:`best_gap`) searched through
    (:func:`refine`)."""
    gap = best_gap(rays, lo_ns, hi_ns, before, after, min_after, min_before)
    return None if gap is None else refine(rays, gap)


def _rank(kink: Kink) -> tuple[int, float]:
    return -kink.rays, kink.chi2


def height_at(kink: Kink, stamp_ns: int) -> float:
    """The fitted centre's height at ``stamp_ns``."""
    return float(kink.state_at(stamp_ns)[0][2])


def per_dof(kink: Kink) -> float:
    """The fit's chi-square per degree of freedom (inf with none)."""
    dof = 2 * kink.rays - kink.theta.size
    return kink.chi2 / dof if dof > 0 else math.inf
