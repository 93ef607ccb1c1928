"""The log contract: topic names, ROS 2 message definitions and metadata keys.

This is the ONE place both the recorder (writer) and replay (reader) take them from.
It imports nothing but the standard library (no pybullet, no mcap), so replay can use
it without pulling in the simulator.

Logs are plain ROS 2 MCAP (CDR encoding). Robots are named ``robot1`` .. ``robotN``.

Time: every stamp is an integer count of nanoseconds of *sim time* from 0; an MCAP
message's ``log_time`` and ``publish_time`` equal its ``header.stamp``. No wall-clock
time is written anywhere, so the same scenario, seed and renderer give the same bytes.
"""

from __future__ import annotations

import re

__all__ = [
    "CAMERAS_METADATA",
    "COMPRESSED_IMAGE",
    "FIELD_FRAME",
    "GT_BALL_TOPIC",
    "GT_POSE_TOPIC",
    "IMAGE",
    "IMAGE_TOPIC",
    "MESSAGE_DEFINITIONS",
    "POINT_STAMPED",
    "POSE_STAMPED",
    "POSE_TOPIC",
    "POSE_WITH_COVARIANCE_STAMPED",
    "PROFILE",
    "RECORDER_METADATA",
    "SCENARIO_METADATA",
    "TF_MESSAGE",
    "TF_TOPIC",
    "camera_frame",
    "robot_name",
    "robot_names_in",
    "stamp_from_ns",
    "stamp_to_ns",
    "topic_for",
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
"""geometry_msgs/msg/PoseStamped in "field": the robot's true pose. Evaluation only."""

# --- metadata records (MCAP metadata: name -> {str: str}) -----------------------------------
SCENARIO_METADATA = "dsp.scenario"
"""{"name": str, "seed": str(int), "params": JSON object of the scenario's parameters}."""
CAMERAS_METADATA = "dsp.cameras"
"""{robot name: JSON object of that robot's camera model (estimator.camera model dict)}."""
RECORDER_METADATA = "dsp.recorder"
"""{"renderer": "egl" | "tiny", "dual_sight": version, "pybullet": version, "numpy": ..., ...}."""


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
