"""The log contract: topic names, ROS 2 message definitions and builders, metadata names.

This is the ONE place both the recorder (writer) and replay (reader, estimates sink) take
them from; :mod:`dsp.metadata` types the metadata records. It imports nothing but the
standard library (no pybullet, no mcap), so replay can use it without pulling in the
simulator.

Logs are plain ROS 2 MCAP (CDR encoding). Robots are named ``robot1`` .. ``robotN``.

Time: every stamp is an integer count of nanoseconds of *sim time* from 0; an MCAP
message's ``log_time`` and ``publish_time`` equal its ``header.stamp``. No wall-clock
time is written anywhere, so the same scenario, seed and renderer give the same bytes.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Any

__all__ = [
    "CAMERAS_METADATA",
    "COMPRESSED_IMAGE",
    "ESTIMATE_LANDING_TOPIC",
    "ESTIMATE_ODOMETRY_TOPIC",
    "ESTIMATE_TOPIC",
    "FIELD_FRAME",
    "GT_BALL_ODOMETRY_TOPIC",
    "GT_BALL_TOPIC",
    "GT_POSE_TOPIC",
    "IMAGE",
    "IMAGE_TOPIC",
    "MESSAGE_DEFINITIONS",
    "ODOMETRY",
    "POINT_STAMPED",
    "POSE_STAMPED",
    "POSE_TOPIC",
    "POSE_WITH_COVARIANCE_STAMPED",
    "PROFILE",
    "RECORDER_METADATA",
    "RENDERERS",
    "SCENARIO_METADATA",
    "TF_MESSAGE",
    "TF_TOPIC",
    "Quaternion",
    "camera_frame",
    "compressed_image",
    "header",
    "odometry",
    "point_stamped",
    "pose",
    "pose_stamped",
    "pose_with_covariance_stamped",
    "robot_name",
    "robot_names_in",
    "stamp_from_ns",
    "stamp_to_ns",
    "tf_message",
    "topic_for",
    "transform_stamped",
]

PROFILE = "ros2"
"""MCAP profile of every log."""

FIELD_FRAME = "field"
"""World frame: origin at the field centre, x towards the opponent goal, y left, z up."""

# --- topics -----------------------------------------------------------------------------
# `{robot}` stands for the robot's name (robot1, robot2, ...).
IMAGE_TOPIC = "/{robot}/omni/image/compressed"
"""sensor_msgs/msg/CompressedImage, header.frame_id = "{robot}/omni", stamp = capture time."""
POSE_TOPIC = "/{robot}/pose"
"""geometry_msgs/msg/PoseStamped in frame "field": the robot's own belief (noise optional)."""
TF_TOPIC = "/tf"
"""tf2_msgs/msg/TFMessage: field -> robotN (the believed pose), for viewers."""
GT_BALL_TOPIC = "/ground_truth/ball"
"""geometry_msgs/msg/PoseStamped in "field": the ball centre's true position. Evaluation only."""
GT_POSE_TOPIC = "/ground_truth/{robot}/pose"
GT_BALL_ODOMETRY_TOPIC = "/ground_truth/ball/odometry"
"""nav_msgs/msg/Odometry: the ball's true position and velocity (frame ``field``)."""
ESTIMATE_TOPIC = "/estimate/ball"
"""geometry_msgs/msg/PoseWithCovarianceStamped: the fused estimate, written by replay."""
ESTIMATE_ODOMETRY_TOPIC = "/estimate/ball/odometry"
"""nav_msgs/msg/Odometry: the tracked ball's position and velocity, written by replay."""
ESTIMATE_LANDING_TOPIC = "/estimate/ball/landing"
"""geometry_msgs/msg/PointStamped in "field": where the flying ball's centre is predicted to
meet the ground (z = the ball's radius); header.stamp = the predicted landing time,
log_time = the step that predicted it. Written by replay (``ballistic``), while it flies."""
"""geometry_msgs/msg/PoseStamped in "field": the robot's true pose. Evaluation only."""

# --- metadata records (MCAP metadata: name -> {str: str}); typed below -----------------------
SCENARIO_METADATA = "dsp.scenario"
"""{"name", "seed": str(int), "params": JSON object}: :class:`ScenarioMetadata`."""
CAMERAS_METADATA = "dsp.cameras"
"""{robot name: JSON object of its camera model}: :class:`CamerasMetadata`."""
RECORDER_METADATA = "dsp.recorder"
"""{"renderer", "physics_hz", "face_px", package: version, ...}: :class:`RecorderMetadata`."""

RENDERERS = ("auto", "egl", "tiny")
"""The recorder's renderer choices: auto (EGL when it loads, else TinyRenderer), egl, tiny."""


def topic_for(pattern: str, robot: str) -> str:
    """Fill a topic pattern: ``topic_for("/{robot}/pose", "robot2") == "/robot2/pose"``."""
    return pattern.replace("{robot}", robot)


def robot_name(index: int) -> str:
    """1-based robot index to its name: ``robot_name(1) == "robot1"``."""
    if index < 1:
        raise ValueError(f"robot index must be >= 1, got {index}")
    return f"robot{index}"


def camera_frame(robot: str) -> str:
    """The image header's frame_id for a robot's omni camera."""
    return f"{robot}/omni"


def robot_names_in(topics: list[str] | set[str], pattern: str) -> list[str]:
    """Robot names that a topic pattern matches among ``topics``, in natural order.

    ``robot_names_in(["/robot1/pose", "/robot10/pose", "/robot2/pose"], POSE_TOPIC)``
    gives ``["robot1", "robot2", "robot10"]``.
    """
    if "{robot}" not in pattern:
        raise ValueError(f"topic pattern {pattern!r} has no '{{robot}}' placeholder")
    head, tail = pattern.split("{robot}", 1)
    rx = re.compile("^" + re.escape(head) + r"([^/]+)" + re.escape(tail) + "$")
    names = {m.group(1) for t in topics if (m := rx.match(t))}

    def natural(name: str) -> tuple[str, int, str]:
        m = re.match(r"^(.*?)(\d+)$", name)
        return (m.group(1), int(m.group(2)), name) if m else (name, -1, name)

    return sorted(names, key=natural)


def stamp_from_ns(t_ns: int) -> dict[str, int]:
    """Nanoseconds to a builtin_interfaces/Time dict {"sec", "nanosec"}."""
    sec, nanosec = divmod(int(t_ns), 1_000_000_000)
    return {"sec": sec, "nanosec": nanosec}


def stamp_to_ns(stamp: object) -> int:
    """A decoded builtin_interfaces/Time (object with sec, nanosec) to nanoseconds."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)  # type: ignore[attr-defined]


# --- ROS 2 message definitions (the text mcap's ros2msg schema encoding wants) --------------
# The text is rosbag2's form: each type's .msg as ROS 2 ships it (comments dropped), then
# its dependencies. tests/dsp/test_message_definitions.py proves every definition, and every
# schema in the golden logs, equal to rosbags' ROS 2 type store type by type and field by
# field. The text is kept rather than generated from the type store at run time because the
# store's own rendering spells names out (geometry_msgs/Pose for Pose) and has no defaults
# (Quaternion's w = 1): every log's bytes would change for no difference in meaning.
_SEP = "=" * 80 + "\n"


def _with_deps(main: str, *deps: str) -> str:
    return main + "".join(_SEP + f"MSG: {name}\n" + _DEFS[name] for name in deps)


_DEFS: dict[str, str] = {
    "builtin_interfaces/Time": "int32 sec\nuint32 nanosec\n",
    "std_msgs/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "geometry_msgs/Point": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/Quaternion": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
    "geometry_msgs/Pose": "Point position\nQuaternion orientation\n",
    "geometry_msgs/PoseWithCovariance": "Pose pose\nfloat64[36] covariance\n",
    "geometry_msgs/Twist": "Vector3 linear\nVector3 angular\n",
    "geometry_msgs/TwistWithCovariance": "Twist twist\nfloat64[36] covariance\n",
    "geometry_msgs/Transform": "Vector3 translation\nQuaternion rotation\n",
    "geometry_msgs/TransformStamped": (
        "std_msgs/Header header\nstring child_frame_id\nTransform transform\n"
    ),
}

COMPRESSED_IMAGE = "sensor_msgs/msg/CompressedImage"
IMAGE = "sensor_msgs/msg/Image"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
POINT_STAMPED = "geometry_msgs/msg/PointStamped"
POSE_WITH_COVARIANCE_STAMPED = "geometry_msgs/msg/PoseWithCovarianceStamped"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
ODOMETRY = "nav_msgs/msg/Odometry"

_HEADER_DEPS = ("std_msgs/Header", "builtin_interfaces/Time")
_POSE_DEPS = ("geometry_msgs/Pose", "geometry_msgs/Point", "geometry_msgs/Quaternion")

MESSAGE_DEFINITIONS: dict[str, str] = {
    COMPRESSED_IMAGE: _with_deps(
        "std_msgs/Header header\nstring format\nuint8[] data\n", *_HEADER_DEPS
    ),
    IMAGE: _with_deps(
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n"
        "uint8 is_bigendian\nuint32 step\nuint8[] data\n",
        *_HEADER_DEPS,
    ),
    POSE_STAMPED: _with_deps(
        "std_msgs/Header header\nPose pose\n", *_HEADER_DEPS, *_POSE_DEPS
    ),
    POINT_STAMPED: _with_deps(
        "std_msgs/Header header\nPoint point\n", *_HEADER_DEPS, "geometry_msgs/Point"
    ),
    POSE_WITH_COVARIANCE_STAMPED: _with_deps(
        "std_msgs/Header header\nPoseWithCovariance pose\n",
        *_HEADER_DEPS,
        "geometry_msgs/PoseWithCovariance",
        *_POSE_DEPS,
    ),
    ODOMETRY: _with_deps(
        "std_msgs/Header header\nstring child_frame_id\n"
        "geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n",
        *_HEADER_DEPS,
        "geometry_msgs/PoseWithCovariance",
        *_POSE_DEPS,
        "geometry_msgs/TwistWithCovariance",
        "geometry_msgs/Twist",
        "geometry_msgs/Vector3",
    ),
    TF_MESSAGE: _with_deps(
        "geometry_msgs/TransformStamped[] transforms\n",
        "geometry_msgs/TransformStamped",
        *_HEADER_DEPS,
        "geometry_msgs/Transform",
        "geometry_msgs/Vector3",
        "geometry_msgs/Quaternion",
    ),
}
"""Schema name -> ROS 2 .msg text with its dependencies, as rosbag2 writes it."""


# --- message builders: the dicts mcap_ros2's writer encodes with the definitions above ------
Quaternion = tuple[float, float, float, float]
"""(x, y, z, w), as geometry_msgs/Quaternion."""
_IDENTITY: Quaternion = (0.0, 0.0, 0.0, 1.0)


def header(stamp_ns: int, frame_id: str) -> dict[str, Any]:
    """std_msgs/Header."""
    return {"stamp": stamp_from_ns(stamp_ns), "frame_id": frame_id}


def _vector(x: float, y: float, z: float) -> dict[str, float]:
    return {"x": float(x), "y": float(y), "z": float(z)}


def _quaternion(q: Quaternion) -> dict[str, float]:
    return dict(zip("xyzw", map(float, q), strict=True))


def pose(x_m: float, y_m: float, z_m: float, q: Quaternion = _IDENTITY) -> dict[str, Any]:
    """geometry_msgs/Pose."""
    return {"position": _vector(x_m, y_m, z_m), "orientation": _quaternion(q)}


def pose_stamped(stamp_ns: int, x_m: float, y_m: float, z_m: float, q: Quaternion = _IDENTITY,
                 *, frame_id: str = FIELD_FRAME) -> dict[str, Any]:
    """geometry_msgs/PoseStamped."""
    return {"header": header(stamp_ns, frame_id), "pose": pose(x_m, y_m, z_m, q)}


def point_stamped(stamp_ns: int, x_m: float, y_m: float, z_m: float,
                  *, frame_id: str = FIELD_FRAME) -> dict[str, Any]:
    """geometry_msgs/PointStamped."""
    return {"header": header(stamp_ns, frame_id), "point": _vector(x_m, y_m, z_m)}


def pose_with_covariance_stamped(
    stamp_ns: int, x_m: float, y_m: float, xy_covariance: Sequence[Sequence[float]],
    *, z_m: float = 0.0, q: Quaternion = _IDENTITY, frame_id: str = FIELD_FRAME,
) -> dict[str, Any]:
    """geometry_msgs/PoseWithCovarianceStamped whose 6x6 row-major covariance holds the 2x2
    ``xy_covariance`` [m^2] in its x/y block, or a 3x3 one in its x/y/z block (every other
    entry 0)."""
    return {"header": header(stamp_ns, frame_id),
            "pose": {"pose": pose(x_m, y_m, z_m, q), "covariance": _covariance6(xy_covariance)}}


def _covariance6(block: Sequence[Sequence[float]] | None) -> list[float]:
    """A 6x6 row-major covariance holding the 2x2 x/y or 3x3 x/y/z ``block`` (every other
    entry 0)."""
    cov = [0.0] * 36
    if block is not None:
        for i, row in enumerate(block):
            for j, value in enumerate(row):
                cov[6 * i + j] = float(value)
    return cov


def odometry(
    stamp_ns: int, child_frame_id: str, x_m: float, y_m: float, vx_m_s: float, vy_m_s: float,
    *, z_m: float = 0.0, vz_m_s: float = 0.0,
    position_covariance: Sequence[Sequence[float]] | None = None,
    velocity_covariance: Sequence[Sequence[float]] | None = None,
    frame_id: str = FIELD_FRAME,
) -> dict[str, Any]:
    """nav_msgs/Odometry: position in ``frame_id`` and velocity [m/s], here also expressed
    in ``frame_id`` (the ball has no orientation); each covariance [m^2, m^2/s^2], 2x2 x/y
    or 3x3 x/y/z, goes into its 6x6 block, every other entry 0."""
    return {
        "header": header(stamp_ns, frame_id),
        "child_frame_id": child_frame_id,
        "pose": {"pose": pose(x_m, y_m, z_m), "covariance": _covariance6(position_covariance)},
        "twist": {"twist": {"linear": _vector(vx_m_s, vy_m_s, vz_m_s),
                            "angular": _vector(0.0, 0.0, 0.0)},
                  "covariance": _covariance6(velocity_covariance)},
    }


def transform_stamped(stamp_ns: int, child_frame_id: str, x_m: float, y_m: float, z_m: float,
                      q: Quaternion = _IDENTITY, *, frame_id: str = FIELD_FRAME
                      ) -> dict[str, Any]:
    """geometry_msgs/TransformStamped: ``frame_id`` -> ``child_frame_id``."""
    return {"header": header(stamp_ns, frame_id), "child_frame_id": child_frame_id,
            "transform": {"translation": _vector(x_m, y_m, z_m), "rotation": _quaternion(q)}}


def tf_message(transforms: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """tf2_msgs/TFMessage of :func:`transform_stamped` dicts."""
    return {"transforms": list(transforms)}


def compressed_image(stamp_ns: int, frame_id: str, fmt: str, data: bytes) -> dict[str, Any]:
    """sensor_msgs/CompressedImage (``fmt`` "png" or "jpeg")."""
    return {"header": header(stamp_ns, frame_id), "format": fmt, "data": data}
