"""Rays of free-running cameras: each robot's image at its own stamp, so no two rays share
an instant and none cross where the ball is.

A track whose height is known (flying) takes each ray as it comes
(:meth:`~estimator.tracking.ballistic.BallisticTracker.update_ray`). One that rolls, or has
no height, needs a point to see a kick up: :class:`RayPairs` keeps each robot's last ray and
crosses the new ray with another robot's from at most ``pair_s`` before, that ray moved with
the track over the time between them (the ball on it then is there now, if it kept the
track's velocity), the point's covariance widened by that velocity's over the time
(dt^2 P_v). Rays that miss each other by more than ``n_sigma`` (in their sigmas) give none.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from estimator.constants import NS_PER_S
from estimator.estimates import Matrix
from estimator.rays import BallRay, triangulate
from estimator.tracking.ballistic import BallisticTracker

__all__ = ["RayPairs", "ray_residual"]


def ray_residual(ray: BallRay, point: Matrix) -> float:
    """How far ``point`` lies off ``ray``, in the ray's sigmas (root of the chi-square)."""
    o = np.array(ray.origin)
    e_az, e_el = ray.across()
    length = max(float(np.array(ray.direction) @ (point - o)), 1e-6)
    a = float(e_az @ (point - o)) / (length * ray.sigma_azimuth_rad)
    b = float(e_el @ (point - o)) / (length * ray.sigma_elevation_rad)
    return math.hypot(a, b)


class RayPairs:
    """Each robot's last ray, and the point a new ray makes with a recent one of another's."""

    def __init__(self, pair_s: float = 0.1, n_sigma: float = 4.0,
                 speed_sigma_mps: float = 1.0) -> None:
        self.pair_ns = round(pair_s * NS_PER_S)
        self.speed_sigma_mps = speed_sigma_mps
        self.n_sigma = n_sigma
        self._last: dict[str, tuple[int, BallRay]] = {}

    def remember(self, stamp_ns: int, ray: BallRay) -> None:
        self._last[ray.robot] = (stamp_ns, ray)

    def forget(self) -> None:
        """Drop every ray kept (a kick: moved with the velocity before it, they would
        cross a new ray where the ball is not)."""
        self._last.clear()

    def point(self, stamp_ns: int, ray: BallRay, tracker: BallisticTracker
              ) -> tuple[tuple[float, float, float], Matrix] | None:
        """The point ``ray`` crosses the latest other robot's recent ray at (moved with the
        track to ``stamp_ns``), with its covariance; None without a track, such a ray, or
        a crossing both pass within ``n_sigma`` of."""
        if tracker.x is None:
            return None
        others = [(t, r) for robot, (t, r) in sorted(self._last.items())
                  if robot != ray.robot and 0 < stamp_ns - t < self.pair_ns]
        if not others:
            return None
        t0, old = max(others, key=lambda tr: tr[0])
        dt = (stamp_ns - t0) / NS_PER_S
        shift = tracker.x[3:6] * dt
        # the way moved is known to sigma_v dt: the old ray's direction is that much less sure
        sigma_v = max(math.sqrt(max(float(np.linalg.eigvalsh(tracker.P[3:6, 3:6])[-1]), 0.0)),
                      self.speed_sigma_mps)
        length = float(np.linalg.norm(np.array(old.ground_point) - np.array(old.origin)))
        extra = sigma_v * dt / max(length, 0.1)
        moved = replace(old, origin=(old.origin[0] + float(shift[0]),
                                     old.origin[1] + float(shift[1]),
                                     old.origin[2] + float(shift[2])),
                        sigma_azimuth_rad=math.hypot(old.sigma_azimuth_rad, extra),
                        sigma_elevation_rad=math.hypot(old.sigma_elevation_rad, extra))
        solved = triangulate([moved, ray])
        if solved is None:
            return None
        point, cov = solved
        p = np.array(point)
        if max(ray_residual(moved, p), ray_residual(ray, p)) > self.n_sigma:
            return None
        return point, cov
