"""The estimates that flow between the estimator's parts: one robot's, and the team's.

A :class:`BallEstimate` is what one robot makes of one image (:mod:`estimator.corrected`,
:mod:`estimator.paper`); the noise models (:mod:`estimator.noise`) give it a covariance;
fusion (:mod:`estimator.fusion`) and the tracker (:mod:`estimator.tracking`) turn several
into a :class:`FusedEstimate`. A leaf: every one of those imports it, it imports none of
them, so the estimator's parts depend on each other in one direction only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["BallEstimate", "Covariance", "Covariance3", "FusedEstimate", "Matrix",
           "covariance3_rows", "covariance_rows"]

Covariance = tuple[tuple[float, float], tuple[float, float]]
"""A 2 x 2 covariance [m^2] as a tuple of rows."""

Covariance3 = tuple[tuple[float, float, float], tuple[float, float, float],
                    tuple[float, float, float]]
"""A 3 x 3 covariance as a tuple of rows: a point's over (x, y, z) [m^2], or a robot pose's
over (x [m], y [m], yaw [rad])."""

Matrix = npt.NDArray[np.float64]


def covariance_rows(m: Matrix) -> Covariance:
    """The top-left 2 x 2 block of ``m`` as plain floats, row by row."""
    return ((float(m[0, 0]), float(m[0, 1])), (float(m[1, 0]), float(m[1, 1])))


def covariance3_rows(m: Matrix) -> Covariance3:
    """A 3 x 3 matrix as plain floats, row by row."""
    r = [(float(m[i, 0]), float(m[i, 1]), float(m[i, 2])) for i in range(3)]
    return (r[0], r[1], r[2])


@dataclass(frozen=True)
class BallEstimate:
    """One robot's estimate of the ball: range and bearing from the robot, field position."""

    robot: str
    robot_x_m: float
    robot_y_m: float
    range_m: float
    """Horizontal range from the robot's centre to the ball's centre [m]."""
    bearing_rad: float
    """Bearing of the ball in the ROBOT frame [rad]: 0 forward, +pi/2 left."""
    x_m: float
    y_m: float
    visibility: float = 1.0
    """How much of the ball the blob shows: detected area / the area a whole ball at this
    range would have (:func:`estimator.corrected.ball_visibility`), 1 when unknown. A partly
    hidden ball's centroid is biased, so fusion trusts it less."""
    r_px: float | None = None
    """Pixel radius of the centroid from the image centre (eq. 3), None when unknown: the
    calibrated noise model (:class:`estimator.noise.CalibratedNoise`) takes the
    calibration's slope there."""
    camera_height_m: float | None = None
    """The camera's optical centre above the ground [m], None when unknown: with it the
    estimate is also a ray (:func:`estimator.rays.ball_ray`)."""
    pose_covariance: Covariance3 | None = None
    """The covariance of the robot's own pose over (x [m], y [m], yaw [rad]) the estimate
    was located from, None when unknown: the noise models then add the ball's share of it
    (:func:`estimator.noise.localisation_covariance`), so a robot that is unsure where it
    stands, or which way it faces at a long range, weighs less."""
    range_sigma_m: float | None = None
    """The sigma of ``range_m`` [m] when a second measure gave it in place of the
    calibration's (``--width-range``, :mod:`estimator.width`), None otherwise: the
    calibrated noise model then takes it along the bearing."""
    ray_range_m: float | None = None
    """Where the blob's ray meets the ground-plane (z = R) [m], when the estimate is not
    there (a ball in the air placed under itself, :mod:`estimator.width`); None: at
    ``range_m``. Rays (:func:`estimator.rays.ball_ray`) are drawn through it."""


@dataclass(frozen=True)
class FusedEstimate:
    """The team's ball estimate: field position [m], its covariance [m^2], robots used;
    a 3-D fusion also gives the height of the ball's centre and the 3 x 3 covariance."""

    x_m: float
    y_m: float
    covariance: Covariance
    robots: tuple[str, ...]
    z_m: float | None = None
    covariance_3d: Covariance3 | None = None
    triangulated: bool = False
    """True when the height comes from crossing rays, False when it is assumed (z = R)."""
