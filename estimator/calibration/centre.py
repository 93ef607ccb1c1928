"""The image centre and the camera's mounting rotation, fitted to where the ball was seen.

A radially symmetric omni camera sees a ball in the robot-frame direction theta (0 forward,
+pi/2 left) on the ray from the image centre (cu, cv) at the image bearing
``atan2(-du, -dv) = theta - psi`` (du = u - cu, dv = v - cv), where psi is the camera's
mounting rotation: the robot-frame direction that image up shows (docs/api.md). Whatever
the radial law, each centroid (u, v) then lies on a known line through the centre, and its
distance from that line

    e_i = (u_i - cu) cos(phi_i) - (v_i - cv) sin(phi_i),   phi_i = theta_i - psi

is linear in (cu, cv) for a fixed psi: least squares in closed form, and a 1-D search over
psi (a grid, then golden-section refinement) minimises the sum of e_i^2. The lines fix the
centre only when the ball was seen in several directions (at least two, well apart);
:func:`fit_mount` fits psi alone about a centre that is known.

The lines are only as sharp as the measured directions (a robot's heading off by 0.3 deg
moves a ball 500 px out by 2.6 px across its line). The ranges are sharper far out, where
a pixel of radius is many centimetres: :func:`fit_centre_to_ranges` moves the centre to
where the radii fit the ranges best (the RMS of the parametric model, linear or mirror,
that predicts held-out ranges best), a 2-D simplex search started at the lines' centre.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from estimator.calibration.fit import FITTERS, holdout_rms_m
from estimator.errors import CalibrationError, FitError

__all__ = ["CentreFit", "fit_centre_and_mount", "fit_centre_to_ranges", "fit_mount"]

FloatArray = npt.NDArray[np.float64]

MIN_SPREAD = 0.05
"""The smallest eigenvalue ratio of the lines' normal matrix that fixes a centre: the
directions must spread (two directions 90 deg apart give 1, 26 deg apart about 0.05)."""


@dataclass(frozen=True)
class CentreFit:
    """The fitted image centre [px], mounting rotation [rad] and the centroids' RMS distance
    from their lines [px]."""

    cu_px: float
    cv_px: float
    mount_yaw_rad: float
    rms_px: float
    n: int
    centre_fitted: bool
    """False when the centre was given (:func:`fit_mount`)."""


def _arrays(u_px: Sequence[float] | FloatArray, v_px: Sequence[float] | FloatArray,
            theta_rad: Sequence[float] | FloatArray, minimum: int
            ) -> tuple[FloatArray, FloatArray, FloatArray]:
    u, v, t = (np.asarray(a, dtype=np.float64).ravel() for a in (u_px, v_px, theta_rad))
    if not u.shape == v.shape == t.shape:
        raise FitError(f"{u.size} columns, {v.size} rows and {t.size} bearings; give one of "
                       "each per sample")
    if u.size < minimum:
        raise FitError(f"{u.size} samples; fitting the centre needs at least {minimum}")
    if not all(np.all(np.isfinite(a)) for a in (u, v, t)):
        raise FitError("samples contain NaN or inf; drop those samples before fitting")
    return u, v, t


def _solve(u: FloatArray, v: FloatArray, t: FloatArray, psi: float
           ) -> tuple[float, float, float]:
    """(cu, cv, sum of squared distances) for one psi."""
    c, s = np.cos(t - psi), np.sin(t - psi)
    a = np.stack([c, -s], axis=1)
    b = u * c - v * s
    x, *_ = np.linalg.lstsq(a, b, rcond=None)
    e = a @ x - b
    return float(x[0]), float(x[1]), float(e @ e)


def _oriented(u: FloatArray, v: FloatArray, t: FloatArray, cu: float, cv: float,
              psi: float) -> float:
    """psi or psi + pi: the one that puts the centroids on their rays, not behind the centre."""
    phi = t - psi
    r = -((u - cu) * np.sin(phi) + (v - cv) * np.cos(phi))
    return math.remainder(psi if float(np.sum(r)) >= 0.0 else psi + math.pi, math.tau)


def fit_centre_and_mount(u_px: Sequence[float] | FloatArray, v_px: Sequence[float] | FloatArray,
                         theta_rad: Sequence[float] | FloatArray, *, grid: int = 720
                         ) -> CentreFit:
    """The centre and mounting rotation that put every centroid (u, v) on the line of its
    ball's robot-frame direction ``theta_rad``. Raises :class:`FitError` when the directions
    do not spread enough to fix a centre."""
    u, v, t = _arrays(u_px, v_px, theta_rad, 3)
    # the lines' normals spread whatever psi is (a rotation keeps the eigenvalues)
    normals = np.stack([np.cos(t), np.sin(t)], axis=1)
    eig = np.linalg.eigvalsh(normals.T @ normals)
    if eig[0] < MIN_SPREAD * eig[1]:
        raise FitError("the ball was seen in too narrow a spread of directions to fix the "
                       "image centre; place it all around the robot, or give the centre")
    psis = np.arange(grid) * (math.pi / grid)  # the lines repeat every pi
    costs = [_solve(u, v, t, float(p))[2] for p in psis]
    i = int(np.argmin(costs))
    lo, hi = float(psis[i]) - math.pi / grid, float(psis[i]) + math.pi / grid
    ratio = (math.sqrt(5.0) - 1.0) / 2.0
    for _ in range(60):
        m1, m2 = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
        if _solve(u, v, t, m1)[2] <= _solve(u, v, t, m2)[2]:
            hi = m2
        else:
            lo = m1
    psi = (lo + hi) / 2.0
    cu, cv, sse = _solve(u, v, t, psi)
    return CentreFit(cu, cv, _oriented(u, v, t, cu, cv, psi), math.sqrt(sse / u.size),
                     int(u.size), True)


def fit_mount(u_px: Sequence[float] | FloatArray, v_px: Sequence[float] | FloatArray,
              theta_rad: Sequence[float] | FloatArray, centre_px: tuple[float, float]
              ) -> CentreFit:
    """The mounting rotation about a known centre: the mean of each ball's direction less its
    image bearing, weighted by its pixel radius (a far ball's bearing is the sharper)."""
    u, v, t = _arrays(u_px, v_px, theta_rad, 1)
    du, dv = u - centre_px[0], v - centre_px[1]
    r = np.hypot(du, dv)
    if not np.any(r > 0.0):
        raise FitError("every centroid is at the image centre; the bearing is undefined")
    diff = t - np.arctan2(-du, -dv)
    psi = math.atan2(float(np.sum(r * np.sin(diff))), float(np.sum(r * np.cos(diff))))
    phi = t - psi
    e = du * np.cos(phi) - dv * np.sin(phi)
    return CentreFit(float(centre_px[0]), float(centre_px[1]), psi,
                     math.sqrt(float(e @ e) / u.size), int(u.size), False)


PARAMETRIC = ("linear", "mirror")
"""The models whose fit moves smoothly with the centre (a lookup table fits any radii)."""


def _fit_rms(model: str, u: FloatArray, v: FloatArray, d: FloatArray, cu: float,
             cv: float) -> float:
    """RMS [m] of ``model`` fitted to the radii about (cu, cv) against the ranges."""
    try:
        return FITTERS[model](np.hypot(u - cu, v - cv), d).rms_m
    except CalibrationError:
        return math.inf


def _family(u: FloatArray, v: FloatArray, d: FloatArray, start: tuple[float, float]) -> str:
    """The parametric model that predicts held-out ranges best about ``start``."""
    r = np.hypot(u - start[0], v - start[1])
    held = {m: holdout_rms_m(m, r, d) for m in PARAMETRIC}
    return min(PARAMETRIC, key=lambda m: held[m])


def fit_centre_to_ranges(u_px: Sequence[float] | FloatArray, v_px: Sequence[float] | FloatArray,
                         range_m: Sequence[float] | FloatArray, start_px: tuple[float, float],
                         *, model: str | None = None, step_px: float = 2.0,
                         tolerance_px: float = 0.01, max_iterations: int = 200
                         ) -> tuple[float, float, float]:
    """The centre (cu, cv) near ``start_px`` whose radii fit the ranges best, and that fit's
    RMS [m]: Nelder-Mead on the RMS of ``model`` (default: of linear and mirror, the one that
    predicts held-out ranges best about ``start_px``), which moves smoothly with the centre."""
    u, v, d = _arrays(u_px, v_px, range_m, 6)
    family = model or _family(u, v, d, start_px)

    def cost(p: FloatArray) -> float:
        return _fit_rms(family, u, v, d, float(p[0]), float(p[1]))

    simplex = np.array([start_px, (start_px[0] + step_px, start_px[1]),
                        (start_px[0], start_px[1] + step_px)], dtype=np.float64)
    costs = np.array([cost(p) for p in simplex])
    for _ in range(max_iterations):
        order = np.argsort(costs, kind="stable")
        simplex, costs = simplex[order], costs[order]
        if float(np.max(np.abs(simplex[1:] - simplex[0]))) < tolerance_px:
            break
        centroid = simplex[:2].mean(axis=0)
        reflected = centroid + (centroid - simplex[2])
        c_r = cost(reflected)
        if c_r < costs[0]:
            expanded = centroid + 2.0 * (centroid - simplex[2])
            c_e = cost(expanded)
            simplex[2], costs[2] = (expanded, c_e) if c_e < c_r else (reflected, c_r)
        elif c_r < costs[1]:
            simplex[2], costs[2] = reflected, c_r
        else:
            contracted = centroid + 0.5 * (simplex[2] - centroid)
            c_c = cost(contracted)
            if c_c < costs[2]:
                simplex[2], costs[2] = contracted, c_c
            else:  # shrink towards the best
                simplex[1:] = simplex[0] + 0.5 * (simplex[1:] - simplex[0])
                costs[1:] = [cost(p) for p in simplex[1:]]
    i = int(np.argmin(costs))
    return float(simplex[i][0]), float(simplex[i][1]), float(costs[i])
