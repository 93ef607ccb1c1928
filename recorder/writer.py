"""The log writer: ROS 2 MCAP (CDR, zstd chunks) exactly as ``recorder.contract`` says.

Every message's ``log_time`` and ``publish_time`` are its header stamp in sim nanoseconds
(mcap_ros2 would otherwise use the wall clock), so the same inputs give the same bytes.
"""

from __future__ import annotations

import json
import math
from typing import IO, Any

from mcap.writer import CompressionType
from mcap_ros2.writer import Writer

from recorder import contract as c

__all__ = ["LogWriter", "yaw_quaternion"]

DEFAULT_CHUNK_SIZE = 4 * 1024 * 1024


def yaw_quaternion(yaw_rad: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation by ``yaw_rad`` about z."""
    return (0.0, 0.0, math.sin(yaw_rad / 2.0), math.cos(yaw_rad / 2.0))


def _header(t_ns: int, frame_id: str) -> dict[str, Any]:
    return {"stamp": c.stamp_from_ns(t_ns), "frame_id": frame_id}


def _pose(x: float, y: float, z: float, q: tuple[float, float, float, float]) -> dict[str, Any]:
    return {
        "position": {"x": float(x), "y": float(y), "z": float(z)},
        "orientation": {"x": q[0], "y": q[1], "z": q[2], "w": q[3]},
    }


class LogWriter:
    """Writes one log to an open binary stream; use as a context manager or call finish()."""

    def __init__(self, stream: IO[bytes], *, chunk_size: int = DEFAULT_CHUNK_SIZE) -> None:
        self._w = Writer(stream, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        self._schemas = {
            name: self._w.register_msgdef(name, c.MESSAGE_DEFINITIONS[name])
            for name in (c.COMPRESSED_IMAGE, c.POSE_STAMPED, c.TF_MESSAGE)
        }
        self._seq: dict[str, int] = {}
        self.messages = 0

    def _write(self, topic: str, schema: str, msg: dict[str, Any], t_ns: int) -> None:
        seq = self._seq.get(topic, 0)
        self._seq[topic] = seq + 1
        self._w.write_message(topic, self._schemas[schema], msg, log_time=t_ns,
                              publish_time=t_ns, sequence=seq)
        self.messages += 1

    def metadata(self, name: str, data: dict[str, str]) -> None:
        self._w.add_metadata(name, {k: str(v) for k, v in sorted(data.items())})

    def write_image(self, robot: str, t_ns: int, data: bytes, fmt: str) -> None:
        msg = {"header": _header(t_ns, c.camera_frame(robot)), "format": fmt, "data": data}
        self._write(c.topic_for(c.IMAGE_TOPIC, robot), c.COMPRESSED_IMAGE, msg, t_ns)

    def write_pose(self, topic: str, t_ns: int, x: float, y: float, z: float,
                   yaw_rad: float) -> None:
        msg = {"header": _header(t_ns, c.FIELD_FRAME), "pose": _pose(x, y, z,
                                                                     yaw_quaternion(yaw_rad))}
        self._write(topic, c.POSE_STAMPED, msg, t_ns)

    def write_tf(self, t_ns: int, poses: dict[str, tuple[float, float, float]]) -> None:
        """field -> robot transforms for every robot's (x, y, yaw)."""
        transforms = []
        for robot, (x, y, yaw) in poses.items():
            q = yaw_quaternion(yaw)
            transforms.append({
                "header": _header(t_ns, c.FIELD_FRAME),
                "child_frame_id": robot,
                "transform": {
                    "translation": {"x": float(x), "y": float(y), "z": 0.0},
                    "rotation": {"x": q[0], "y": q[1], "z": q[2], "w": q[3]},
                },
            })
        self._write(c.TF_TOPIC, c.TF_MESSAGE, {"transforms": transforms}, t_ns)

    def finish(self) -> None:
        self._w.finish()  # type: ignore[no-untyped-call]

    def __enter__(self) -> LogWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.finish()


def json_text(obj: Any) -> str:
    """Canonical JSON (sorted keys, no spaces) so metadata bytes never vary."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"))
