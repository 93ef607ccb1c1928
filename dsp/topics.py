"""The topic patterns a log's topics follow, found from the topics themselves.

A team's log names its robots in its topics (``/robot1/camera/image_raw``,
``/robot2/camera/image_raw``): the name is the one path segment in which otherwise equal
topics differ. :func:`infer_patterns` finds that segment among the image topics (by their
message type), and the pose topics that name the same robots at the same place, so
``dsp-info`` can list a foreign log's robots and say which ``--image-topic`` and
``--pose-topic`` replay it. Pure: strings in, strings out.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from dsp.contract import robot_names_in, topic_for

__all__ = ["IMAGE_TYPES", "POSE_TYPES", "TopicPatterns", "infer_patterns"]

IMAGE_TYPES = frozenset({"sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage",
                         "sensor_msgs/Image", "sensor_msgs/CompressedImage"})
POSE_TYPES = frozenset({"geometry_msgs/msg/PoseStamped",
                        "geometry_msgs/msg/PoseWithCovarianceStamped", "nav_msgs/msg/Odometry",
                        "geometry_msgs/PoseStamped", "geometry_msgs/PoseWithCovarianceStamped",
                        "nav_msgs/Odometry"})
_EVALUATION = "/ground_truth/"
"""Topics under this prefix are the simulator's truth, never a robot's own."""


@dataclass(frozen=True)
class TopicPatterns:
    """A log's robots and the patterns (``{robot}`` where the name goes) of their topics."""

    robots: tuple[str, ...]
    image_topic: str
    pose_topic: str | None
    """None when no pose topic names every robot the images name."""


def _split(topic: str) -> list[str]:
    return topic.strip("/").split("/")


def _pattern(parts: list[str], i: int) -> str:
    return "/" + "/".join([*parts[:i], "{robot}", *parts[i + 1:]])


def _best_pattern(topics: list[str]) -> str | None:
    """The pattern that the most topics share with {robot} at one segment (ties: the
    earliest segment); a lone topic's robot is its first segment (a ROS namespace)."""
    candidates: dict[str, set[str]] = {}
    for topic in topics:
        parts = _split(topic)
        if len(parts) < 2:
            continue
        for i in range(len(parts)):
            candidates.setdefault(_pattern(parts, i), set()).add(parts[i])
    if not candidates:
        return None
    ranked = sorted(candidates.items(),
                    key=lambda kv: (-len(kv[1]), kv[0].index("{robot}"), kv[0]))
    return ranked[0][0]


def infer_patterns(types: Mapping[str, str]) -> TopicPatterns | None:
    """The robots and topic patterns of a log whose topics and their message types are
    ``types`` (topic -> type name); None when it has no image topic."""
    images = sorted(t for t, kind in types.items()
                    if kind in IMAGE_TYPES and not t.startswith(_EVALUATION))
    image_pattern = _best_pattern(images)
    if image_pattern is None:
        return None
    robots = tuple(robot_names_in(images, image_pattern))
    poses = [t for t, kind in types.items()
             if kind in POSE_TYPES and not t.startswith(_EVALUATION)]
    return TopicPatterns(robots, image_pattern, _pose_pattern(robots, poses))


def _pose_pattern(robots: Iterable[str], poses: list[str]) -> str | None:
    """The pattern under which every robot has a pose topic (the shortest, if several).

    Each candidate pattern is checked once, against a set: linear in the robots for each
    pattern, so a log naming thousands of robots is read in a moment."""
    names = list(robots)
    wanted = set(names)
    pose_set = set(poses)
    tried: set[str] = set()
    found: set[str] = set()
    for topic in poses:
        parts = _split(topic)
        for i, part in enumerate(parts):
            if part not in wanted:
                continue
            pattern = _pattern(parts, i)
            if pattern in tried:
                continue
            tried.add(pattern)
            if all(topic_for(pattern, r) in pose_set for r in names):
                found.add(pattern)
    return min(found, key=lambda p: (len(p), p)) if found else None
