"""Paper mode: the ball position exactly as the paper computes it (eq. 3-14).

This reproduces Section II.I and the worked example of Section IV, including the paper's
erratum: the calibration offset ``b`` is added to EACH field axis after rotation (eq.
11-12) instead of to the radial distance, which biases every estimate by about
(+0.28, +0.28) m. It is kept on purpose so that the paper's tables can be reproduced; the
corrected estimator is :mod:`estimator.corrected`.

Symbols as in the paper: (Cx, Cy) the blob centroid [px], (539, 539) the image centre
(:data:`~estimator.constants.PAPER_CENTRE_PX`),
r the pixel radius, alpha the bearing in the image, alpha0 and alpha1 the yaw-corrected
angles, (Cx1, Cy1) the rotated centroid, (dx, dy) the calibrated offsets [m], Pr the robot
position and Pb the ball position on the field [m].
"""

from __future__ import annotations

import math

from estimator.constants import PAPER_B_M, PAPER_CENTRE_PX, PAPER_K_M_PER_PX
from estimator.geometry import normalise_quaternion

__all__ = ["locate_ball", "rpy_from_quaternion"]


def locate_ball(
    cx_px: float,
    cy_px: float,
    robot_x_m: float,
    robot_y_m: float,
    robot_yaw_rad: float,
    *,
    k_m_per_px: float = PAPER_K_M_PER_PX,
    b_m: float = PAPER_B_M,
    centre_px: tuple[float, float] = PAPER_CENTRE_PX,
) -> tuple[float, float]:
    """The ball's field position (Pb_x, Pb_y) [m] by the paper's eq. 3-14.

    ``(cx_px, cy_px)`` is the ball's centroid in the image, ``robot_*`` the robot's pose
    (yaw in radians, CCW from field +x; 360 deg and 0 rad give the same result).

    At r == 0 (the centroid exactly on the image centre) the bearing alpha is undefined;
    we define Cx1 = Cy1 = 0 there, the limit of eq. 9-10 as r -> 0, so the result is
    (robot_x + b, robot_y + b) whatever alpha would be.
    """
    c_x0, c_y0 = centre_px
    d_cx = cx_px - c_x0
    d_cy = cy_px - c_y0
    r = math.sqrt(d_cx**2 + d_cy**2)  # eq. 3
    if r == 0.0:
        c_x1 = c_y1 = 0.0  # limit of eq. 9-10 as r -> 0
    else:
        alpha = math.acos(max(-1.0, min(1.0, d_cx / r)))  # eq. 5
        if cy_px > c_y0:
            alpha = 2.0 * math.pi - alpha  # eq. 6: the lower half of the image
        alpha_0 = math.pi / 2.0 - robot_yaw_rad  # eq. 7
        alpha_1 = alpha - alpha_0  # eq. 8
        c_x1 = r * math.cos(alpha_1)  # eq. 9
        c_y1 = r * math.sin(alpha_1)  # eq. 10
    d_x = k_m_per_px * c_x1 + b_m  # eq. 11 (offset per axis: the paper's erratum, kept)
    d_y = k_m_per_px * c_y1 + b_m  # eq. 12 (idem)
    pb_x = d_x + robot_x_m  # eq. 13
    pb_y = d_y + robot_y_m  # eq. 14
    return (pb_x, pb_y)


def rpy_from_quaternion(x: float, y: float, z: float, w: float) -> tuple[float, float, float]:
    """(roll, pitch, yaw) [rad] of the quaternion (x, y, z, w), as pseudo-code 1.

    Pseudo-code 1 builds the rotation matrix m(q) and calls ROS ``getRPY`` on it; this is
    tf2's ``Matrix3x3::getRPY`` (solution 1), gimbal lock included. The quaternion is
    normalised first.
    """
    x, y, z, w = normalise_quaternion(x, y, z, w)
    # m(q): the rotation matrix of the unit quaternion; only the entries getRPY reads.
    m00 = 1.0 - 2.0 * (y * y + z * z)
    m10 = 2.0 * (x * y + w * z)
    m20 = 2.0 * (x * z - w * y)
    m21 = 2.0 * (y * z + w * x)
    m22 = 1.0 - 2.0 * (x * x + y * y)
    if abs(m20) >= 1.0:  # gimbal lock: pitch = -+90 deg, yaw set to 0
        yaw = 0.0
        delta = math.atan2(m21, m22)
        pitch = math.pi / 2.0 if m20 < 0.0 else -math.pi / 2.0
        roll = delta
    else:
        pitch = -math.asin(m20)
        cp = math.cos(pitch)
        roll = math.atan2(m21 / cp, m22 / cp)
        yaw = math.atan2(m10 / cp, m00 / cp)
    return (roll, pitch, yaw)
