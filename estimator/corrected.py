"""The corrected estimator: calibration applied to the RANGE, bearing by atan2.

Differences from paper mode (:mod:`estimator.paper`): the calibration d(r) maps the
pixel radius to the range along the bearing (not per field axis, the paper's eq. 11-12
erratum), the image centre and the calibration are parameters, and the bearing uses
atan2 (no branch on Cy).

Conventions (docs/api.md), converted here once: image up = robot forward (x_r), image
right = robot right (-y_r). With du = u - cu, dv = v - cv (pixels)::

    r     = hypot(du, dv)                         (eq. 3)
    theta = atan2(-du, -dv)                       robot frame: 0 forward, +pi/2 left
    d     = calibration.range_m(r)                (eq. 4, any calibration model)
    x     = x_robot + d cos(yaw + theta)          field frame (cf. eq. 9-14)
    y     = y_robot + d sin(yaw + theta)

At r == 0 the bearing is undefined; we define theta = 0 (forward), so the ball is put
d(0) in front of the robot.

A camera mounted turned on the robot (image up showing the robot-frame direction
``mount_yaw_rad``, 0 = forward, +pi/2 = left) adds that angle to theta.
"""

from __future__ import annotations

import math

from estimator.calibration.models import PAPER_CALIBRATION, Calibration
from estimator.constants import PAPER_CENTRE_PX
from estimator.estimates import BallEstimate
from estimator.geometry import RobotPose, wrap_angle

__all__ = ["ball_visibility", "estimate_ball"]


def ball_visibility(area_px: float, expected_area_px: float) -> float:
    """Detected blob area over the expected area of a whole ball, clipped to [0, 1]; 1 when
    the expected area is unknown (NaN or not positive)."""
    if not (math.isfinite(expected_area_px) and expected_area_px > 0.0):
        return 1.0
    return min(max(area_px / expected_area_px, 0.0), 1.0)


def estimate_ball(
    cx_px: float,
    cy_px: float,
    pose: RobotPose,
    calibration: Calibration = PAPER_CALIBRATION,
    *,
    centre_px: tuple[float, float] = PAPER_CENTRE_PX,
    robot: str = "",
    mount_yaw_rad: float = 0.0,
) -> BallEstimate:
    """The ball's field position from its centroid (cx_px, cy_px) seen by a robot at ``pose``
    through a camera whose image up shows the robot-frame direction ``mount_yaw_rad``."""
    du = cx_px - centre_px[0]
    dv = cy_px - centre_px[1]
    r = math.hypot(du, dv)  # eq. 3
    theta = math.atan2(-du, -dv) if r > 0.0 else 0.0  # robot frame, 0 = forward
    if mount_yaw_rad:
        theta = wrap_angle(theta + mount_yaw_rad)
    d = calibration.range_m(r)  # eq. 4, applied to the range
    phi = pose.yaw_rad + theta  # field bearing of the ball from the robot
    return BallEstimate(
        robot=robot,
        robot_x_m=pose.x_m,
        robot_y_m=pose.y_m,
        range_m=d,
        bearing_rad=theta,
        x_m=pose.x_m + d * math.cos(phi),
        y_m=pose.y_m + d * math.sin(phi),
        r_px=r,
    )
