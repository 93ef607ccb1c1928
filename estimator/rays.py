"""The ball in 3-D: each robot's detection as a bearing ray, several rays triangulated.

A robot's estimate (:class:`~estimator.estimates.BallEstimate`) says where the ball's centre
would be if it lay on the ground: the calibration turns the pixel radius into the ground
range ``d`` of the point where the camera's ray meets the plane z = R (R the ball's radius,
the centre of a ball on the ground). That is an angle: seen from the optical centre
``h`` above the ground, the ray to the ball's centre leaves

    nadir angle  n = atan2(d, h - R)          (0 straight down, pi/2 the horizon)
    azimuth      phi = atan2(y - y_robot, x - x_robot)     (field frame)
    direction    u = (sin n cos phi, sin n sin phi, -cos n)

from ``(x_robot, y_robot, h)``. A ball in the air lies on the same ray, nearer the robot
and higher: one ray cannot tell how high. Two robots' rays cross at the ball.

Each ray's noise comes from its ground estimate's covariance Sigma (the noise models'):
with r and t the radial and tangential unit vectors of the ground plane,

    sigma_azimuth   = sqrt(t' Sigma t) / sqrt(d^2 + (h - R)^2)     (across the ray, level)
    sigma_elevation = sqrt(r' Sigma r) (h - R) / ((h - R)^2 + d^2)     (dn/dd)

:func:`triangulate` finds the point X minimising sum_i (X - o_i)' A_i (X - o_i), where A_i
weighs the two directions across ray i by its angular sigmas times the distance along the
ray to X (so metres across the ray, at the ball): weighted least squares, iterated three
times on the distances; its covariance is (sum_i A_i)^-1. A solution below the ball's
radius (a ball is never lower) is solved again with z = R (the covariance stays the
unconstrained one's). It returns None when the rays
cannot fix a point: fewer than two, no two more than ``min_angle_rad`` apart, or X behind
a camera.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from estimator.constants import BALL_RADIUS_M
from estimator.errors import EstimatorError
from estimator.estimates import (
    BallEstimate,
    FusedEstimate,
    Matrix,
    covariance3_rows,
    covariance_rows,
)

__all__ = [
    "MIN_RAY_ANGLE_RAD",
    "BallRay",
    "Point3",
    "aloft",
    "ball_ray",
    "height_unknown_covariance",
    "on_the_ray",
    "ray_of",
    "triangulate",
]

MIN_RAY_ANGLE_RAD = math.radians(2.0)
"""Rays closer than this in direction are near parallel: they fix no point."""
_MIN_SIGMA_RAD = 1e-5
_ITERATIONS = 3

Point3 = tuple[float, float, float]


@dataclass(frozen=True)
class BallRay:
    """One robot's ray to the ball's centre in the field frame."""

    robot: str
    origin: Point3
    """The camera's optical centre [m]."""
    direction: Point3
    """Unit vector towards the ball's centre."""
    sigma_azimuth_rad: float
    """The sigma of the ray's direction across it, level [rad]."""
    sigma_elevation_rad: float
    """The sigma of its nadir angle [rad]."""

    @property
    def ground_point(self) -> Point3:
        """Where the ray meets z = R: the robot's ground-plane estimate."""
        o, u = np.array(self.origin), np.array(self.direction)
        t = (o[2] - BALL_RADIUS_M) / -u[2]
        p = o + t * u
        return (float(p[0]), float(p[1]), float(p[2]))

    def across(self) -> tuple[Matrix, Matrix]:
        """Unit vectors across the ray: horizontal (azimuth) and upward (elevation)."""
        u = np.array(self.direction)
        horizontal = np.hypot(u[0], u[1])
        e_az = (np.array([-u[1], u[0], 0.0]) / horizontal if horizontal > 1e-12
                else np.array([0.0, 1.0, 0.0]))
        e_el = np.cross(u, e_az)
        return e_az, e_el / np.linalg.norm(e_el)


def ball_ray(estimate: BallEstimate, camera_height_m: float, covariance: Matrix, *,
             ball_radius_m: float = BALL_RADIUS_M) -> BallRay:
    """The ray of a robot's ground-plane ``estimate`` from a camera ``camera_height_m`` up,
    its angular sigmas from the estimate's 2 x 2 ``covariance`` [m^2]."""
    drop = camera_height_m - ball_radius_m
    if not drop > 0.0:
        raise EstimatorError(f"camera height {camera_height_m} m is not above the ball's "
                             f"centre ({ball_radius_m} m): no ray")
    dx, dy = estimate.x_m - estimate.robot_x_m, estimate.y_m - estimate.robot_y_m
    d = math.hypot(dx, dy)
    phi = math.atan2(dy, dx) if d > 0.0 else 0.0
    if estimate.ray_range_m is not None:  # placed under a ball in the air: the ray's own
        d = estimate.ray_range_m
    n = math.atan2(d, drop)
    direction = (math.sin(n) * math.cos(phi), math.sin(n) * math.sin(phi), -math.cos(n))
    cov = np.asarray(covariance, dtype=np.float64)[:2, :2]
    radial = np.array([math.cos(phi), math.sin(phi)])
    tangential = np.array([-math.sin(phi), math.cos(phi)])
    sigma_r = math.sqrt(max(float(radial @ cov @ radial), 0.0))
    sigma_t = math.sqrt(max(float(tangential @ cov @ tangential), 0.0))
    sigma_az = sigma_t / math.hypot(d, drop)  # the angle the shift subtends across the ray
    sigma_el = sigma_r * drop / (drop * drop + d * d)
    return BallRay(estimate.robot, (estimate.robot_x_m, estimate.robot_y_m, camera_height_m),
                   direction, max(sigma_az, _MIN_SIGMA_RAD), max(sigma_el, _MIN_SIGMA_RAD))


def _spread(rays: Sequence[BallRay]) -> float:
    """The largest angle between two rays' directions [rad]."""
    dirs = np.array([r.direction for r in rays])
    cos = np.clip(dirs @ dirs.T, -1.0, 1.0)
    return float(np.arccos(cos.min()))


def _solve(info: Sequence[Matrix], origins: Sequence[Matrix], z_fixed: float | None
           ) -> tuple[Matrix, Matrix]:
    """argmin sum (X - o)' A (X - o), with z = z_fixed if given; (X, (sum A)^-1), the
    covariance of the unconstrained solution either way (the constraint is a bound, not a
    measurement)."""
    total = np.sum(info, axis=0)
    rhs = np.sum([a @ o for a, o in zip(info, origins, strict=True)], axis=0)
    cov = np.linalg.inv(total)
    if z_fixed is None:
        return cov @ rhs, cov
    xy = np.linalg.solve(total[:2, :2], rhs[:2] - total[:2, 2] * z_fixed)
    return np.array([xy[0], xy[1], z_fixed]), cov


def triangulate(rays: Sequence[BallRay], *, min_angle_rad: float = MIN_RAY_ANGLE_RAD,
                ball_radius_m: float = BALL_RADIUS_M) -> tuple[Point3, Matrix] | None:
    """The point where ``rays`` cross (weighted least squares) and its 3 x 3 covariance
    [m^2]; None when they fix none (see the module doc)."""
    if len(rays) < 2 or _spread(rays) < min_angle_rad:
        return None
    origins = [np.array(r.origin) for r in rays]
    dirs = [np.array(r.direction) for r in rays]
    frames = [r.across() for r in rays]
    lengths = [float(np.linalg.norm(np.array(r.ground_point) - o))
               for r, o in zip(rays, origins, strict=True)]
    z_fixed: float | None = None
    x = cov = np.zeros(3)
    for _ in range(_ITERATIONS):
        info = [np.outer(e_az, e_az) / (length * r.sigma_azimuth_rad) ** 2
                + np.outer(e_el, e_el) / (length * r.sigma_elevation_rad) ** 2
                for r, (e_az, e_el), length in zip(rays, frames, lengths, strict=True)]
        try:
            x, cov = _solve(info, origins, z_fixed)
            if z_fixed is None and x[2] < ball_radius_m:
                z_fixed = ball_radius_m
                x, cov = _solve(info, origins, z_fixed)
        except np.linalg.LinAlgError:
            return None
        along = [float(u @ (x - o)) for u, o in zip(dirs, origins, strict=True)]
        if min(along) <= 0.0:
            return None
        lengths = along
    if not np.all(np.isfinite(x)):
        return None
    cov = 0.5 * (cov + cov.T)
    return (float(x[0]), float(x[1]), float(x[2])), cov


def height_unknown_covariance(ground_covariance: Matrix, ray: BallRay, top_m: float) -> Matrix:
    """The 3 x 3 covariance of a ball one ray sees, placed at its ground point: the ground
    covariance, plus the ray's segment from the ground point up to ``top_m`` (or the
    camera, if lower) as a spread along the ray (second moment of a uniform spread about
    its end, L^2 / 3): the height is not known, and says so."""
    g = np.array(ray.ground_point)
    o = np.array(ray.origin)
    u = np.array(ray.direction)
    top = min(top_m, o[2])
    cov = np.zeros((3, 3))
    cov[:2, :2] = np.asarray(ground_covariance, dtype=np.float64)[:2, :2]
    if top > g[2] and u[2] < 0.0:
        segment = -u * (top - g[2]) / -u[2]  # from the ground point up the ray to top
        cov += np.outer(segment, segment) / 3.0
    return cov


def on_the_ray(ray: BallRay, range_m: float, range_sigma_m: float) -> tuple[Point3, Matrix]:
    """The point of ``ray`` ``range_m`` from its camera's axis (a ball whose horizontal
    range a second measure gives, :mod:`estimator.width`) and its 3 x 3 covariance: the
    range's sigma along the ray, the ray's angular sigmas across it at that distance."""
    o, u = np.array(ray.origin), np.array(ray.direction)
    level = max(math.hypot(u[0], u[1]), 1e-9)
    t = range_m / level
    p = o + t * u
    e_az, e_el = ray.across()
    cov = ((range_sigma_m / level) ** 2 * np.outer(u, u)
           + (t * ray.sigma_azimuth_rad) ** 2 * np.outer(e_az, e_az)
           + (t * ray.sigma_elevation_rad) ** 2 * np.outer(e_el, e_el))
    return (float(p[0]), float(p[1]), float(p[2])), 0.5 * (cov + cov.T)


def aloft(ground: FusedEstimate, ray: BallRay, estimate: BallEstimate) -> FusedEstimate:
    """One robot's ``ground`` estimate, its blob's width showing the ball in the air
    (``estimate.ray_range_m`` set: :mod:`estimator.width`): the ball on its ``ray`` at the
    width's range (:func:`on_the_ray`), with its height and 3-D covariance."""
    point, cov = on_the_ray(ray, estimate.range_m, estimate.range_sigma_m or 0.0)
    return replace(ground, x_m=point[0], y_m=point[1], z_m=point[2],
                   covariance=covariance_rows(cov[:2, :2]), covariance_3d=covariance3_rows(cov))


def ray_of(estimate: BallEstimate, covariance: Callable[[BallEstimate], Matrix]) -> BallRay:
    """``estimate``'s ray (its ``camera_height_m`` set), its sigmas from ``covariance`` (a
    noise model's) of the estimate where the ray meets the ground: for a ball its blob's
    width placed under itself (``ray_range_m``, :mod:`estimator.width`; :func:`ball_ray`
    draws the ray through that point), as sure as the blob, not the width's range."""
    if estimate.camera_height_m is None:
        raise EstimatorError(f"{estimate.robot}: no camera height, no ray")
    e = estimate
    if e.ray_range_m is not None and e.range_m > 0.0:
        k = e.ray_range_m / e.range_m
        e = replace(e, x_m=e.robot_x_m + k * (e.x_m - e.robot_x_m),
                    y_m=e.robot_y_m + k * (e.y_m - e.robot_y_m), range_m=e.ray_range_m,
                    range_sigma_m=None, ray_range_m=None)
    return ball_ray(estimate, estimate.camera_height_m, covariance(e))
