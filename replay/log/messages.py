"""The records replay streams (images, poses, ground truth) and their conversion from decoded
ROS 2 messages, validated once here: a pose with a non-finite value or a zero quaternion, an
empty image or a negative stamp is a bad message (:class:`BadMessage`), counted and skipped
by the reader, never handed on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from mcap.records import Message

from dsp import contract

__all__ = [
    "BadMessage",
    "ImageMessage",
    "PoseMessage",
    "TruthMessage",
    "convert",
    "pose_covariance",
]


@dataclass(frozen=True)
class ImageMessage:
    """One camera image. ``data`` is the compressed bytes (``fmt`` "png"/"jpeg"/...) or the
    raw pixel buffer (``fmt`` "raw", with ``encoding``, ``width_px``, ``height_px``, ``step``,
    ``big_endian``)."""

    robot: str
    stamp_ns: int
    log_time_ns: int
    fmt: str
    data: bytes
    encoding: str = ""
    width_px: int = 0
    height_px: int = 0
    step: int = 0
    big_endian: bool = False
    """Raw 16-bit samples are big-endian (``is_bigendian``)."""


@dataclass(frozen=True)
class PoseMessage:
    """A robot's pose in the field frame: position in metres, quaternion (x, y, z, w)."""

    robot: str
    stamp_ns: int
    x_m: float
    y_m: float
    qx: float
    qy: float
    qz: float
    qw: float
    covariance: tuple[float, ...] | None = None
    """The pose's 3 x 3 covariance over (x [m], y [m], yaw [rad]), row-major, from a
    PoseWithCovarianceStamped or Odometry (its 6 x 6's rows and columns x, y and yaw); None
    from a PoseStamped, or when the message's covariance is all zero (ROS: unknown)."""


POSE_COVARIANCE_AXES = (0, 1, 5)
"""x, y and yaw (rotation about z) in a ROS 6 x 6 pose covariance."""


def pose_covariance(values: Any) -> tuple[float, ...] | None:
    """The (x, y, yaw) block of a ROS row-major 6 x 6 pose covariance, row-major; None when
    all zero (unknown). Raises :class:`BadMessage` when it is no covariance."""
    flat = [float(v) for v in values]
    if len(flat) != 36:
        raise BadMessage(f"pose covariance of {len(flat)} values, not 36")
    block = tuple(flat[6 * i + j] for i in POSE_COVARIANCE_AXES for j in POSE_COVARIANCE_AXES)
    if not any(block):
        return None
    _finite(*block)
    if min(block[0], block[4], block[8]) < 0:
        raise BadMessage("negative pose variance")
    return block


@dataclass(frozen=True)
class TruthMessage:
    """The ball's true position [m], velocity [m/s] from Odometry, field frame (evaluation)."""

    stamp_ns: int
    x_m: float
    y_m: float
    vx_m_s: float | None = None
    vy_m_s: float | None = None
    z_m: float | None = None
    """The height of the ball's centre, when the message has one (every geometry type
    does; a ball on the ground is at its radius)."""


class BadMessage(Exception):
    """A message decodes but cannot be used; ``reason`` is its short class ("bad pose")."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def _stamp(msg: Any) -> int:
    stamp = contract.stamp_to_ns(msg.header.stamp)
    if stamp < 0:
        raise BadMessage("negative stamp")
    return stamp


MAX_ABS_VALUE = 1e9
"""Positions (metres) and quaternion components beyond this are not a robot on a field."""


def _finite(*values: float) -> tuple[float, ...]:
    out = tuple(float(v) for v in values)
    if not all(math.isfinite(v) for v in out):
        raise BadMessage("non-finite value")
    if any(abs(v) > MAX_ABS_VALUE for v in out):
        raise BadMessage("value out of range")
    return out


def convert(kind: str, robot: str, msg: Any, record: Message) -> (
    ImageMessage | PoseMessage | TruthMessage
):
    """The replay record of a decoded message of ``kind`` (image, pose, truth); raises
    :class:`BadMessage`, or AttributeError/TypeError/ValueError when the message is not of
    a type replay reads."""
    stamp = _stamp(msg)
    if kind == "pose":
        pose, cov = msg.pose, None
        if hasattr(pose, "pose"):  # PoseWithCovarianceStamped (AMCL), nav_msgs/Odometry
            cov = pose_covariance(pose.covariance)
            pose = pose.pose
        p, q = pose.position, pose.orientation
        x, y, qx, qy, qz, qw = _finite(p.x, p.y, q.x, q.y, q.z, q.w)
        if math.hypot(qx, qy, qz, qw) < 1e-9:
            raise BadMessage("zero quaternion")
        return PoseMessage(robot, stamp, x, y, qx, qy, qz, qw, cov)
    if kind == "truth":
        if hasattr(msg, "twist"):  # nav_msgs/Odometry: the true position and velocity
            p, v = msg.pose.pose.position, msg.twist.twist.linear
            tx, ty, tz, vx, vy = _finite(p.x, p.y, p.z, v.x, v.y)
            return TruthMessage(stamp, tx, ty, vx, vy, z_m=tz)
        pose = getattr(msg, "pose", None)
        if pose is not None and hasattr(pose, "pose"):  # PoseWithCovarianceStamped (mocap)
            pose = pose.pose
        p = msg.point if pose is None else pose.position
        tx, ty, tz = _finite(p.x, p.y, p.z)
        return TruthMessage(stamp, tx, ty, z_m=tz)
    data = bytes(msg.data)
    if not data:
        raise BadMessage("empty image")
    if hasattr(msg, "format"):  # sensor_msgs/CompressedImage
        fmt = str(msg.format).lower()
        fmt = "jpeg" if ("jpeg" in fmt or "jpg" in fmt) else ("png" if "png" in fmt else fmt)
        return ImageMessage(robot, stamp, record.log_time, fmt, data)
    return ImageMessage(  # sensor_msgs/Image
        robot, stamp, record.log_time, "raw", data, encoding=str(msg.encoding),
        width_px=int(msg.width), height_px=int(msg.height), step=int(msg.step),
        big_endian=bool(msg.is_bigendian),
    )
