"""Poses, yaw and quaternions.

Conventions (stated once, as in docs/api.md): the field frame has x towards the opponent
goal, y left, z up; yaw is counter-clockwise from field +x, in radians. Quaternions are
(x, y, z, w) as in geometry_msgs/Quaternion. Yaw from a quaternion is the ZYX
(roll-pitch-yaw) yaw, as ROS ``getRPY``::

    yaw = atan2(2 (w z + x y), 1 - 2 (y^2 + z^2))
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from estimator.errors import GeometryError

__all__ = [
    "Quaternion",
    "RobotPose",
    "normalise_quaternion",
    "quaternion_from_yaw",
    "slerp",
    "wrap_angle",
    "yaw_from_quaternion",
]

Quaternion = tuple[float, float, float, float]
"""(x, y, z, w)."""


def normalise_quaternion(x: float, y: float, z: float, w: float) -> Quaternion:
    """The unit quaternion (x, y, z, w) / ``|q|``; raises GeometryError for a zero or
    non-finite one."""
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if not math.isfinite(n) or n == 0.0:
        raise GeometryError(
            f"quaternion (x, y, z, w) = ({x}, {y}, {z}, {w}) has length {n}; "
            "pass a finite, non-zero quaternion (the identity is (0, 0, 0, 1))"
        )
    return (x / n, y / n, z / n, w / n)


def yaw_from_quaternion(x: float, y: float, z: float, w: float) -> float:
    """Yaw [rad, in (-pi, pi]] of the quaternion (x, y, z, w), normalised first."""
    x, y, z, w = normalise_quaternion(x, y, z, w)
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def quaternion_from_yaw(yaw_rad: float) -> Quaternion:
    """The quaternion (x, y, z, w) of a pure rotation by ``yaw_rad`` about z."""
    return (0.0, 0.0, math.sin(yaw_rad / 2.0), math.cos(yaw_rad / 2.0))


def slerp(q0: Quaternion, q1: Quaternion, t: float) -> Quaternion:
    """Spherical linear interpolation from q0 (t = 0) to q1 (t = 1), the short way round."""
    a = normalise_quaternion(*q0)
    b = normalise_quaternion(*q1)
    dot = sum(ai * bi for ai, bi in zip(a, b, strict=True))
    if dot < 0.0:  # q and -q are the same rotation: take the shorter arc
        b = (-b[0], -b[1], -b[2], -b[3])
        dot = -dot
    if dot > 0.9995:  # nearly parallel: linear interpolation is exact to rounding
        q = tuple(ai + t * (bi - ai) for ai, bi in zip(a, b, strict=True))
        return normalise_quaternion(q[0], q[1], q[2], q[3])
    omega = math.acos(min(1.0, dot))
    s0 = math.sin((1.0 - t) * omega) / math.sin(omega)
    s1 = math.sin(t * omega) / math.sin(omega)
    return (
        s0 * a[0] + s1 * b[0],
        s0 * a[1] + s1 * b[1],
        s0 * a[2] + s1 * b[2],
        s0 * a[3] + s1 * b[3],
    )


def wrap_angle(a_rad: float) -> float:
    """The angle ``a_rad`` wrapped into [-pi, pi)."""
    return (a_rad + math.pi) % (2.0 * math.pi) - math.pi


@dataclass(frozen=True)
class RobotPose:
    """A robot's pose on the field: position [m] and yaw [rad, CCW from field +x]."""

    x_m: float
    y_m: float
    yaw_rad: float

    @classmethod
    def from_quaternion(cls, x_m: float, y_m: float, quaternion: Quaternion) -> RobotPose:
        """The pose at (x_m, y_m) whose yaw is that of ``quaternion`` (x, y, z, w)."""
        return cls(x_m, y_m, yaw_from_quaternion(*quaternion))
