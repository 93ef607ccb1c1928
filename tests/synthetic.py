"""Small synthetic ROS 2 MCAP logs for replay tests (no pybullet).

Robots stand (or turn) at known poses, a ball sits (or rolls) at a known field position. Each
image is a dark-green frame with an orange disc drawn where the paper's ideal camera puts the
ball: pixel radius ``r = (d - B_M) / K_M_PER_PX`` for the range ``d`` from the robot to the
ball, direction by the docs/api.md convention (``theta = atan2(-du, -dv)``, 0 = forward).
Poses come at a higher rate than images; the ball's ground truth at the pose rate.

Options damage the log in the ways replay must survive: drop a robot's poses over a time
span, corrupt chosen images, write raw sensor_msgs/Image instead of PNG.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from mcap.writer import CompressionType
from mcap_ros2.writer import Writer

from dsp import contract
from estimator.constants import (
    PAPER_B_M,
    PAPER_CENTRE_PX,
    PAPER_IMAGE_SIZE_PX,
    PAPER_K_M_PER_PX,
)

K_M_PER_PX = PAPER_K_M_PER_PX
B_M = PAPER_B_M
CENTRE_PX = PAPER_CENTRE_PX
SIZE_PX = PAPER_IMAGE_SIZE_PX
DISC_RADIUS_PX = 10
GREEN_BGR = (30, 90, 20)
ORANGE_BGR = (0, 110, 255)
NS = 1_000_000_000

DEFAULT_ROBOTS: dict[str, tuple[float, float, float]] = {
    "robot1": (-3.0, 0.0, 0.0),
    "robot2": (-1.0, 2.0, -math.pi / 2),
    "robot3": (-2.0, -1.5, math.pi / 4),
}
DEFAULT_BALL = (0.5, 0.3)


@dataclass
class SyntheticLog:
    """What was written, for the tests to compare against."""

    path: Path
    robots: dict[str, tuple[float, float, float]]
    ball: tuple[float, float]
    image_stamps_ns: list[int] = field(default_factory=list)
    pose_stamps_ns: list[int] = field(default_factory=list)
    n_images: int = 0
    all_image_stamps_ns: list[int] = field(default_factory=list)
    """Every robot's image stamps, in write order."""

    def ball_at(self, t_ns: int) -> tuple[float, float]:
        return self.ball  # static unless ball_velocity was given (see write_log)


def quaternion_from_yaw(yaw: float) -> dict[str, float]:
    return {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}


def ball_pixel(
    robot: tuple[float, float, float], ball: tuple[float, float],
    centre_px: tuple[float, float] = CENTRE_PX, mount_yaw_rad: float = 0.0,
) -> tuple[float, float]:
    """Where the paper's ideal camera on ``robot`` (x, y, yaw), turned so that image up shows
    the robot-frame direction ``mount_yaw_rad``, sees the ball centre."""
    rx, ry, yaw = robot
    dx, dy = ball[0] - rx, ball[1] - ry
    d = math.hypot(dx, dy)
    r = (d - B_M) / K_M_PER_PX
    theta = math.atan2(dy, dx) - yaw - mount_yaw_rad  # bearing in the image
    du, dv = -r * math.sin(theta), -r * math.cos(theta)
    return centre_px[0] + du, centre_px[1] + dv


def render(u: float, v: float, size: int | tuple[int, int] = SIZE_PX,
           colour: tuple[int, int, int] = ORANGE_BGR, *,
           background: np.ndarray | None = None) -> np.ndarray:
    """A dark-green frame (``size`` px square, or (width, height); or ``background``) with a
    disc of ``colour`` centred at (u, v) (sub-pixel accurate)."""
    width, height = (size, size) if isinstance(size, int) else size
    img = np.empty((height, width, 3), np.uint8)
    img[:] = GREEN_BGR if background is None else background
    shift = 4
    centre = (round(u * (1 << shift)), round(v * (1 << shift)))
    cv2.circle(img, centre, DISC_RADIUS_PX << shift, colour, -1, cv2.LINE_8, shift)
    return img


def _header(t_ns: int, frame_id: str) -> dict[str, object]:
    return {"stamp": contract.stamp_from_ns(t_ns), "frame_id": frame_id}


def _pose_msg(t_ns: int, x: float, y: float, yaw: float) -> dict[str, object]:
    return {
        "header": _header(t_ns, contract.FIELD_FRAME),
        "pose": {"position": {"x": x, "y": y, "z": 0.0}, "orientation": quaternion_from_yaw(yaw)},
    }


def write_log(
    path: str | Path,
    *,
    robots: dict[str, tuple[float, float, float]] | None = None,
    ball: tuple[float, float] = DEFAULT_BALL,
    ball_velocity: tuple[float, float] = (0.0, 0.0),
    yaw_rate_rad_s: float = 0.0,
    duration_s: float = 1.0,
    image_hz: float = 10.0,
    pose_hz: float = 50.0,
    image_encoding: str = "png",
    drop_poses: dict[str, tuple[float, float]] | None = None,
    corrupt_images: Sequence[int] = (),
    with_truth: bool = True,
    with_cameras: bool = False,
    cameras: str | None = "paper",
    with_poses: bool = True,
    chunk_size: int = 256 * 1024,
    compression: CompressionType = CompressionType.ZSTD,
    image_offset_ns: int = 0,
    centre_px: tuple[float, float] = CENTRE_PX,
    pose_schema: str = contract.POSE_STAMPED,
    pose_topic: str = contract.POSE_TOPIC,
    camera_phases_ns: dict[str, int] | None = None,
    ball_path: Callable[[int], tuple[tuple[float, float], tuple[float, float]]] | None = None,
    with_odometry: bool = False,
    pose_bias_m: dict[str, tuple[float, float]] | None = None,
    yaw_bias_rad: dict[str, float] | None = None,
    carpet: bool = False,
    image_size_px: tuple[int, int] = (SIZE_PX, SIZE_PX),
    mount_yaw_rad: float = 0.0,
    map_origin: tuple[float, float] = (0.0, 0.0),
    stamp_offset_ns: int = 0,
    stamp_jump: tuple[float, int] | None = None,
    truth_topic: str = contract.GT_BALL_TOPIC,
    ball_colour: tuple[int, int, int] = ORANGE_BGR,
    image_topic: str | None = None,
    robot_velocity: tuple[float, float] = (0.0, 0.0),
    pose_covariance: dict[str, Sequence[float]] | None = None,
    scenario: tuple[str, int] = ("synthetic", 0),
    metadata: bool = True,
) -> SyntheticLog:
    """Write a synthetic log. ``drop_poses={"robot1": (t0, t1)}`` drops that robot's poses
    with t0 <= t < t1 (seconds); ``corrupt_images`` are image indices (in write order) whose
    bytes are garbage; ``image_encoding`` is "png", "jpeg" or "bgr8"/"rgb8"/"mono8" (raw).
    ``pose_schema`` POSE_WITH_COVARIANCE_STAMPED writes poses as a localiser (AMCL) does,
    on ``pose_topic``, each robot's with its ``pose_covariance`` (36 values; default zeros).
    ``camera_phases_ns={"robot2": 17_000_000}`` delays a robot's images (free-running,
    unsynchronised cameras); ``ball_path(t_ns) -> ((x, y), (vx, vy))`` moves the ball any way
    (instead of ``ball + ball_velocity t``); ``with_odometry`` writes the true position and
    velocity on /ground_truth/ball/odometry too; ``pose_bias_m={"robot3":
    (dx, dy)}`` shifts the pose a robot believes (its images stay true), so its estimate of
    the ball is off by (dx, dy). The log's camera metadata describes the camera the images
    are drawn for (``cameras="paper"``: the paper's lookup entry, eq. 4 at ``centre_px``);
    ``with_cameras`` writes the ideal camera model at ``centre_px`` instead, ``cameras=None``
    none at all (as a robot's own log). ``image_size_px`` (width, height) draws other images
    than 1080 x 1080 (their centre is ``centre_px``), ``mount_yaw_rad`` a camera turned on
    the robot, ``map_origin`` poses in a map frame whose origin is that field point, and
    ``stamp_offset_ns`` moves every stamp (a robot's clock in Unix time), ``stamp_jump`` (t_s,
    jump_ns) those at or after t_s by jump_ns more (a clock that jumps); the truth goes on
    ``truth_topic``; ``ball_colour`` paints the ball (BGR); ``image_topic`` is a pattern for
    the images (default: the contract's, less ``/compressed`` for raw images);
    ``robot_velocity`` (m/s) moves every robot; ``yaw_bias_rad`` turns the pose a robot
    believes; ``carpet`` draws the ball on the 18x12 field's carpet seen through the ideal
    camera model from the true pose (:mod:`field_images`; the camera and the field are in
    the metadata), for the field-line localisation; ``scenario`` is the (name, seed) its
    dsp.scenario metadata records; ``metadata=False`` writes no dsp metadata at all (a team's
    own bag: no scenario, no field, no cameras, whatever the images are drawn with)."""
    with_cameras = with_cameras or carpet
    robots = dict(DEFAULT_ROBOTS if robots is None else robots)
    path = Path(path)
    log = SyntheticLog(path, robots, ball)
    drop_poses = drop_poses or {}
    pose_dt = round(NS / pose_hz)
    image_dt = round(NS / image_hz)
    end_ns = round(duration_s * NS)

    def robot_at(name: str, t_ns: int) -> tuple[float, float, float]:
        x, y, yaw = robots[name]
        s = t_ns / NS
        return (x + robot_velocity[0] * s, y + robot_velocity[1] * s,
                yaw + yaw_rate_rad_s * s)

    def ball_state(t_ns: int) -> tuple[tuple[float, float], tuple[float, float]]:
        if ball_path is not None:
            return ball_path(t_ns)
        s = t_ns / NS
        return (ball[0] + ball_velocity[0] * s, ball[1] + ball_velocity[1] * s), ball_velocity

    def ball_at(t_ns: int) -> tuple[float, float]:
        return ball_state(t_ns)[0]

    def _carpet(name: str, t_ns: int) -> np.ndarray:
        from field_images import render_carpet

        from estimator.camera import make_camera
        from estimator.geometry import RobotPose

        cam = make_camera("ideal", cu_px=centre_px[0], cv_px=centre_px[1])
        return render_carpet(cam, RobotPose(*robot_at(name, t_ns)), noise=2.0, seed=t_ns)

    # events: (time, order, kind, robot); at equal times poses precede images
    events: list[tuple[int, int, str, str]] = []
    for t in range(0, end_ns + 1, pose_dt):
        for name in robots:
            events.append((t, 0, "pose", name))
        if with_truth:
            events.append((t, 1, "truth", ""))
    phases = camera_phases_ns or {}
    for name in robots:
        for t in range(image_offset_ns + phases.get(name, 0), end_ns + 1, image_dt):
            events.append((t, 2, "image", name))
    events.sort(key=lambda e: (e[0], e[1]))

    with path.open("wb") as f:
        writer = Writer(f, chunk_size=chunk_size, compression=compression)
        schemas = {
            name: writer.register_msgdef(name, text)
            for name, text in contract.MESSAGE_DEFINITIONS.items()
        }
        if metadata:
            writer.add_metadata(
                contract.SCENARIO_METADATA,
                {"name": scenario[0], "seed": str(scenario[1]), "params": json.dumps(
                    {"field_length_m": 18.0, "field_width_m": 12.0,
                     **({"field": "18x12"} if carpet else {})}, sort_keys=True)},
            )
        cam: dict[str, object] | None = None
        if with_cameras:
            from estimator.camera import make_camera

            cam = make_camera("ideal", cu_px=centre_px[0], cv_px=centre_px[1]).to_dict()
        elif cameras == "paper":
            cam = {"model": "lookup", "width_px": image_size_px[0],
                   "height_px": image_size_px[1],
                   "cu_px": centre_px[0], "cv_px": centre_px[1],
                   "calibration": {"model": "linear", "a_m_per_px": K_M_PER_PX, "b_m": B_M}}
        if cam is not None and metadata:
            writer.add_metadata(
                contract.CAMERAS_METADATA,
                {name: json.dumps(cam, sort_keys=True) for name in robots},
            )
        image_index = 0
        for t, _order, kind, name in events:
            off = stamp_offset_ns + (stamp_jump[1] if stamp_jump is not None
                                     and t >= stamp_jump[0] * NS else 0)
            if kind == "pose":
                if not with_poses:
                    continue
                span = drop_poses.get(name)
                if span is not None and span[0] * NS <= t < span[1] * NS:
                    continue
                x, y, yaw = robot_at(name, t)
                bias = (pose_bias_m or {}).get(name, (0.0, 0.0))
                x, y = x + bias[0] - map_origin[0], y + bias[1] - map_origin[1]
                msg = _pose_msg(t + off, x, y,
                                yaw + (yaw_bias_rad or {}).get(name, 0.0))
                if pose_schema == contract.POSE_WITH_COVARIANCE_STAMPED:
                    cov = (pose_covariance or {}).get(name, [0.0] * 36)
                    msg = {"header": msg["header"],
                           "pose": {"pose": msg["pose"], "covariance": list(cov)}}
                writer.write_message(
                    contract.topic_for(pose_topic, name), schemas[pose_schema],
                    msg, log_time=t + off, publish_time=t + off,
                )
                if name == next(iter(robots)):
                    log.pose_stamps_ns.append(t)
            elif kind == "truth":
                (bx, by), (vx, vy) = ball_state(t)
                writer.write_message(
                    truth_topic, schemas[contract.POSE_STAMPED],
                    _pose_msg(t + off, bx, by, 0.0), log_time=t + off,
                    publish_time=t + off,
                )
                if with_odometry:
                    writer.write_message(
                        contract.GT_BALL_ODOMETRY_TOPIC, schemas[contract.ODOMETRY],
                        contract.odometry(t, "ball", bx, by, vx, vy), log_time=t,
                        publish_time=t)
            else:
                u, v = ball_pixel(robot_at(name, t), ball_at(t), centre_px, mount_yaw_rad)
                img = render(u, v, image_size_px, ball_colour,
                             background=_carpet(name, t) if carpet else None)
                topic = contract.topic_for(contract.IMAGE_TOPIC, name)
                header = _header(t + off, contract.camera_frame(name))
                if image_encoding in ("png", "jpeg"):
                    ext = ".png" if image_encoding == "png" else ".jpg"
                    ok, buf = cv2.imencode(ext, img)
                    assert ok
                    data = buf.tobytes()
                    if image_index in corrupt_images:
                        data = b"\x89PNG garbage" + bytes(64)
                    msg: dict[str, object] = {"header": header, "format": image_encoding,
                                              "data": data}
                    schema = schemas[contract.COMPRESSED_IMAGE]
                else:
                    if image_encoding == "rgb8":
                        px = cv2.cvtColor(img, cv2.COLOR_BGR2RGB)
                    elif image_encoding == "mono8":
                        px = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
                    else:
                        px = img
                    data = px.tobytes()
                    if image_index in corrupt_images:
                        data = data[: len(data) // 3]
                    channels = 1 if image_encoding == "mono8" else 3
                    msg = {"header": header, "height": image_size_px[1],
                           "width": image_size_px[0], "encoding": image_encoding,
                           "is_bigendian": 0, "step": image_size_px[0] * channels,
                           "data": data}
                    schema = schemas[contract.IMAGE]
                    topic = topic.replace("/compressed", "")
                if image_topic is not None:
                    topic = contract.topic_for(image_topic, name)
                writer.write_message(topic, schema, msg, log_time=t + off,
                                     publish_time=t + off)
                if name == next(iter(robots)):
                    log.image_stamps_ns.append(t)
                log.all_image_stamps_ns.append(t)
                image_index += 1
        writer.finish()
    log.n_images = image_index
    return log
