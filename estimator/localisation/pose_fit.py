"""A robot's pose from the white lines it sees, around the pose it believes (the prior).

Given line points p_i in the robot frame (:mod:`.line_points`) and the prior pose
q0 = (x0, y0, yaw0) with covariance P0, the fit finds the pose q = (x, y, yaw) that puts the
points on the field's lines (:class:`~.field_lines.DistanceGrid`), minimising::

    E(q) = sum_i rho(d_i(q) / sigma_i) + (q - q0)^T P0^-1 (q - q0) / 2
    d_i(q) = D(t + R(yaw) p_i)                 distance of the point, put on the field by q,
                                               to the nearest line's centre

with rho Cauchy's robust loss at scale c (rho(u) = c^2/2 log(1 + u^2/c^2)): a point far
from every line (a goal post, a net frame, noise) weighs almost nothing. Gauss-Newton on the
iteratively reweighted problem (point-to-line ICP: each point pulls along its line's
normal n_i, J_i = n_i^T [I, perp(R(yaw) p_i)]), from the prior, with c shrinking over
``stages`` so the first steps see a wide basin and the last ones only the line's width.

Covariance. At the minimum the lines' information is H_L = sum_i w_i J_i^T J_i / sigma_i^2.
The points are not independent (a line's points share its blur, the grid's phase), so
H_L is divided by ``information_scale`` (measured on the tuning logs); the result's covariance
is (P0^-1 + H_L / information_scale)^-1 + diag(floor_sigma^2), the floor for what no
Hessian sees (the painted lines' own few millimetres). In a direction the lines do not
constrain (one straight line in view: along it) the prior stays.

Failure (the prior is kept, :class:`FitStatus` says why):

- TOO_FEW_POINTS: fewer than ``min_points`` points fall on the field (inside the outer
  lines grown by ``field_margin_m``) under the prior;
- POOR_FIT: at the minimum fewer than ``min_inliers`` points, or a fraction below
  ``min_inlier_fraction``, lie within ``inlier_m`` of a line: what is seen is not the field
  where the prior says;
- JUMP: the correction is further from the prior than its covariance allows
  (Mahalanobis^2 > ``max_jump_chi2``): a neighbouring minimum (the field is symmetric, and
  its lines parallel), never taken.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import cv2
import numpy as np
from numpy.typing import NDArray

from estimator.errors import LocalisationError
from estimator.geometry import RobotPose, wrap_angle
from estimator.localisation.field_lines import MAP_COLS, DistanceGrid, FieldLines
from estimator.localisation.line_points import LinePoints

__all__ = ["FitStatus", "PoseCorrection", "PoseFitParams", "correct_pose"]

FloatArray = NDArray[np.float64]


class FitStatus(Enum):
    OK = "ok"
    TOO_FEW_POINTS = "too_few_points"
    POOR_FIT = "poor_fit"
    JUMP = "jump"


@dataclass(frozen=True)
class PoseFitParams:
    """How the pose is fitted (defaults chosen on the tuning logs, docs/method.md)."""

    field_margin_m: float = 0.3
    """Points further outside the outer lines under the prior are not used [m]."""
    refine_margin_m: float = 0.1
    """... and, after the first stage, further outside under the pose found so far [m]."""
    stages: tuple[float, ...] = (0.25, 0.12, 0.06)
    """Cauchy scale c [m] of each stage, wide to narrow."""
    iterations: int = 8
    """Most Gauss-Newton steps per stage (a stage ends early once a step is below the
    tolerances)."""
    tolerance_m: float = 1e-3
    tolerance_rad: float = 1e-4
    """A stage ends once a step moves the pose less than these (|dx| + |dy| [m], |dyaw|
    [rad]): a millimetre, a twentieth of the points' own spread. Tighter (0.2 mm, 2e-5
    rad) took 1.5 more steps a fit and moved no replay's fused RMSE by 0.1 %."""
    min_points: int = 80
    min_inliers: int = 60
    min_inlier_fraction: float = 0.35
    inlier_m: float = 0.08
    max_jump_chi2: float = 16.27
    """chi-square, 3 degrees of freedom, 0.999."""
    information_scale: float = 0.5
    """The lines' Hessian is divided by it. Measured on the tuning logs (median NEES
    against the truth): 0.5 with the floor below leaves the covariance about 1.6 times
    too wide in sigma; the points' ``sigma_m`` is generous and covers their correlation."""
    floor_sigma: tuple[float, float, float] = (0.001, 0.001, 0.0001)
    """Added to the result's standard deviations (x [m], y [m], yaw [rad]) in quadrature:
    what the Hessian cannot see (the painted lines' and the exposure's few millimetres)."""
    max_points: int = 6000
    """More points are thinned to this many (every k-th, in their fixed order)."""
    warm_stages: int = 1
    """Stages run (the last ones) when the fit starts from a recent correction (``start``
    of :func:`correct_pose`: near the minimum already, so the wide basins of the first
    stages are not needed)."""

    def __post_init__(self) -> None:
        ok = (self.stages and all(c > 0 for c in self.stages) and self.iterations >= 1
              and self.min_points >= 3 and self.max_points >= self.min_points
              and 0 <= self.min_inlier_fraction <= 1 and self.inlier_m > 0
              and self.max_jump_chi2 > 0 and self.information_scale > 0
              and len(self.floor_sigma) == 3 and all(f >= 0 for f in self.floor_sigma)
              and self.field_margin_m >= 0 and self.refine_margin_m >= 0
              and 1 <= self.warm_stages <= len(self.stages))
        if not ok:
            raise LocalisationError(f"bad pose fit parameters: {self}")


@dataclass(frozen=True, eq=False)
class PoseCorrection:
    """The pose the lines give (the prior when the fit failed) and what the fit saw."""

    pose: RobotPose
    covariance: FloatArray
    """(3, 3) over (x_m, y_m, yaw_rad): the prior's when the fit failed."""
    status: FitStatus
    points: int
    """Line points on the field under the prior."""
    inliers: int
    """Points within ``inlier_m`` of a line at the result."""
    line_information: FloatArray
    """(3, 3): H_L / information_scale, the lines' own information (zero when failed)."""
    found: RobotPose | None = None
    """Where a fit refused as a JUMP went (None otherwise): how far the lines would move the
    pose (:mod:`.spread` learns the belief's spread from it)."""

    @property
    def ok(self) -> bool:
        return self.status is FitStatus.OK


def _to_field(q: FloatArray, p: FloatArray) -> FloatArray:
    c, s = math.cos(q[2]), math.sin(q[2])
    out = np.empty_like(p)
    out[:, 0] = q[0] + c * p[:, 0] - s * p[:, 1]
    out[:, 1] = q[1] + s * p[:, 0] + c * p[:, 1]
    return out


class _Points:
    """One stage's points laid out once for the distance grid's reads: their coordinates
    apart, the remap tables' buffers (rows of :data:`~.field_lines.MAP_COLS`, the tail
    off the grid) and the Jacobian's, so an evaluation allocates little and calls few
    numpy functions (the fit runs every frame; its cost is mostly calls, not arithmetic)."""

    def __init__(self, p: FloatArray, inv_var: FloatArray) -> None:
        n = len(p)
        self.px, self.py = np.ascontiguousarray(p[:, 0]), np.ascontiguousarray(p[:, 1])
        self.inv_var = inv_var
        size = -(-n // MAP_COLS) * MAP_COLS
        mx, my = np.full(size, -1e4, np.float32), np.full(size, -1e4, np.float32)
        self.mx, self.my = mx[:n], my[:n]
        self.maps = (mx.reshape(-1, MAP_COLS), my.reshape(-1, MAP_COLS))
        self.j = np.empty((3, n))


def _normal_equations(q: FloatArray, pts: _Points, grid: DistanceGrid, c_m: float
                      ) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.bool_]]:
    """(H_L, g_L, d^2, off): the lines' Gauss-Newton Hessian and gradient at q, the squared
    distances and which points fell off the grid. With v_i the grid's vector from the
    nearest line (d_i = |v_i|, n_i = v_i / d_i) and J'_i = d_i J_i = [v_i, v_i x R p_i]:
    H_L = sum w_i J'_i J'_i^T / d_i^2, g_L = sum w_i J'_i (as :meth:`DistanceGrid.distance`
    and J_i = n_i^T [I, perp(R p_i)] give them, in fewer steps)."""
    c, s = math.cos(q[2]), math.sin(q[2])
    relx = c * pts.px - s * pts.py  # R(yaw) p_i
    rely = s * pts.px + c * pts.py
    k = 1.0 / grid.step_m
    np.multiply(relx + (q[0] - grid.x0_m), k, out=pts.mx)
    np.multiply(rely + (q[1] - grid.y0_m), k, out=pts.my)
    read = cv2.remap(grid.offset_m, pts.maps[0], pts.maps[1], cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_CONSTANT, borderValue=(np.nan, np.nan))
    v = read.reshape(-1, 2)[:len(relx)]
    j = pts.j  # (3, n): rows contiguous, the sums below run along them
    j[0], j[1] = v[:, 0], v[:, 1]
    np.subtract(j[1] * relx, j[0] * rely, out=j[2])
    off = np.isnan(j[0])
    if off.any():
        j[:, off] = 0.0
    d2 = np.einsum("in,in->n", j[:2], j[:2])
    w = pts.inv_var / (1.0 + d2 * (1.0 / (c_m * c_m)))  # Cauchy's IRLS weight over sigma^2
    u = w / np.maximum(d2, 1e-18)
    # einsum, not BLAS: a sum in one fixed order whatever the thread count (bit-identical)
    return np.einsum("in,jn->ij", j * u, j), np.einsum("in,n->i", j, w), d2, off


def _gauss_newton(q0: FloatArray, info0: FloatArray, p: FloatArray, inv_var: FloatArray,
                  grid: DistanceGrid, lines: FieldLines, params: PoseFitParams,
                  start: FloatArray | None = None) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The minimum of E from q0 (from ``start`` when given: then only the last
    ``warm_stages`` stages run); returns (q, H_L, distances): H_L and the distances where
    the last step began (a step under ``tolerance_m`` and ``tolerance_rad`` ends the
    search: they move less than the points' own noise over it, and another evaluation
    would be a quarter of the fit's cost), at q when it ran out of iterations. After the
    first stage the points are kept to the field grown by ``refine_margin_m`` under the
    pose found so far (what stands just behind an outer line, a goal, drops out)."""
    q = q0.copy() if start is None else start.copy()
    pts = _Points(p, inv_var)
    stages = params.stages if start is None else params.stages[-params.warm_stages:]
    last: tuple[FloatArray, FloatArray, NDArray[np.bool_]] | None = None
    for k, c_m in enumerate(stages):
        if k == 1 or (start is not None and k == 0):
            use = lines.inside(_to_field(q, p), params.refine_margin_m)
            pts = _Points(p[use], inv_var[use])
        last = None
        for _ in range(params.iterations):
            h, g, d2, off = _normal_equations(q, pts, grid, c_m)
            dq = q - q0
            dq[2] = wrap_angle(float(dq[2]))
            step = np.linalg.solve(h + info0, -(g + info0 @ dq))
            q = q + step
            if abs(step[0]) + abs(step[1]) < params.tolerance_m and (
                    abs(step[2]) < params.tolerance_rad):
                last = (h, d2, off)
                break
    if last is None:  # the last stage ran out of iterations: H and d where it stopped
        h, _g, d2, off = _normal_equations(q, pts, grid, params.stages[-1])
    else:  # converged: those of its last step's start, under a millimetre away
        h, d2, off = last
    d = np.sqrt(d2)
    d[off] = grid.outside_m
    q[2] = wrap_angle(float(q[2]))
    return q, h, d


def _failed(prior: RobotPose, cov0: FloatArray, status: FitStatus, points: int,
            inliers: int = 0, found: RobotPose | None = None) -> PoseCorrection:
    return PoseCorrection(prior, cov0.copy(), status, points, inliers, np.zeros((3, 3)),
                          found)


def _prior_covariance(value: FloatArray) -> FloatArray:
    """The prior's 3 x 3 covariance, checked: finite, symmetric, positive definite."""
    cov = np.asarray(value, dtype=np.float64)
    if cov.shape != (3, 3) or not np.all(np.isfinite(cov)):
        raise LocalisationError(f"the prior covariance must be a finite 3 x 3 matrix over "
                                f"(x, y, yaw), got shape {cov.shape}")
    if not np.allclose(cov, cov.T, rtol=1e-9, atol=1e-15) or np.linalg.eigvalsh(
            0.5 * (cov + cov.T)).min() <= 0:
        raise LocalisationError("the prior covariance must be symmetric positive definite")
    return cov


def correct_pose(prior: RobotPose, prior_covariance: FloatArray, points: LinePoints,
                 grid: DistanceGrid, lines: FieldLines,
                 params: PoseFitParams | None = None, *,
                 start: RobotPose | None = None) -> PoseCorrection:
    """The pose that fits ``points`` (robot frame) to the field's lines around ``prior``
    (covariance ``prior_covariance``, 3 x 3 over x, y, yaw). ``start``: where the search
    begins when it is not the prior (a recent correction carried to this frame): the
    minimum sought is the same, fewer steps reach it. Deterministic: the same inputs give
    the same bits (no randomness; the points' order is fixed)."""
    p = params or PoseFitParams()
    cov0 = _prior_covariance(prior_covariance)
    q0 = np.array([prior.x_m, prior.y_m, prior.yaw_rad])
    if not np.all(np.isfinite(q0)):
        raise LocalisationError(f"the prior pose must be finite, got {prior}")
    on_field = lines.inside(_to_field(q0, points.xy_m), p.field_margin_m)
    xy = np.asarray(points.xy_m[on_field], dtype=np.float64)
    sigma = np.asarray(points.sigma_m[on_field], dtype=np.float64)
    n = len(xy)
    if n < p.min_points:
        return _failed(prior, cov0, FitStatus.TOO_FEW_POINTS, n)
    if n > p.max_points:
        keep = np.arange(0, n, math.ceil(n / p.max_points))
        xy, sigma = xy[keep], sigma[keep]
    info0 = np.asarray(np.linalg.inv(cov0), dtype=np.float64)
    q_start = None if start is None else np.array([start.x_m, start.y_m, start.yaw_rad])
    q, h, d = _gauss_newton(q0, info0, xy, 1.0 / (sigma * sigma), grid, lines, p, q_start)
    inliers = int(np.count_nonzero(d <= p.inlier_m))
    if inliers < p.min_inliers or inliers < p.min_inlier_fraction * len(d):
        return _failed(prior, cov0, FitStatus.POOR_FIT, n, inliers)
    h_lines = h / p.information_scale
    cov = np.linalg.inv(info0 + h_lines) + np.diag(np.square(p.floor_sigma))
    dq = q - q0
    dq[2] = wrap_angle(float(dq[2]))
    if float(dq @ np.linalg.solve(cov0, dq)) > p.max_jump_chi2:
        return _failed(prior, cov0, FitStatus.JUMP, n, inliers,
                       RobotPose(float(q[0]), float(q[1]), float(q[2])))
    return PoseCorrection(RobotPose(float(q[0]), float(q[1]), float(q[2])),
                          0.5 * (cov + cov.T), FitStatus.OK, n, inliers, h_lines)
