"""The log writer: ROS 2 MCAP (CDR, zstd chunks) exactly as ``dsp.contract`` says.

Every message's ``log_time`` and ``publish_time`` are its header stamp in sim nanoseconds
(mcap_ros2 would otherwise use the wall clock), so the same inputs give the same bytes.
"""

from __future__ import annotations

from typing import IO, Any

from mcap.writer import CompressionType
from mcap_ros2.writer import Writer

from dsp import contract as c
from estimator.geometry import quaternion_from_yaw

__all__ = ["LogWriter"]

DEFAULT_CHUNK_SIZE = 4 * 1024 * 1024


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
        """One metadata record (keys sorted, so the bytes never vary)."""
        self._w.add_metadata(name, {k: str(v) for k, v in sorted(data.items())})

    def write_image(self, robot: str, t_ns: int, data: bytes, fmt: str) -> None:
        msg = c.compressed_image(t_ns, c.camera_frame(robot), fmt, data)
        self._write(c.topic_for(c.IMAGE_TOPIC, robot), c.COMPRESSED_IMAGE, msg, t_ns)

    def write_pose(self, topic: str, t_ns: int, x: float, y: float, z: float,
                   yaw_rad: float) -> None:
        msg = c.pose_stamped(t_ns, x, y, z, quaternion_from_yaw(yaw_rad))
        self._write(topic, c.POSE_STAMPED, msg, t_ns)

    def write_odometry(self, topic: str, t_ns: int, child_frame_id: str, x: float, y: float,
                       z: float, vx: float, vy: float, vz: float) -> None:
        """nav_msgs/Odometry in frame ``field`` (position and velocity, no covariance). Its
        schema is registered at the first one, so logs without odometry stay as they were."""
        if c.ODOMETRY not in self._schemas:
            self._schemas[c.ODOMETRY] = self._w.register_msgdef(
                c.ODOMETRY, c.MESSAGE_DEFINITIONS[c.ODOMETRY])
        msg = c.odometry(t_ns, child_frame_id, x, y, vx, vy, z_m=z, vz_m_s=vz)
        self._write(topic, c.ODOMETRY, msg, t_ns)

    def write_tf(self, t_ns: int, poses: dict[str, tuple[float, float, float]]) -> None:
        """field -> robot transforms for every robot's (x, y, yaw)."""
        msg = c.tf_message([c.transform_stamped(t_ns, robot, x, y, 0.0, quaternion_from_yaw(yaw))
                            for robot, (x, y, yaw) in poses.items()])
        self._write(c.TF_TOPIC, c.TF_MESSAGE, msg, t_ns)

    def finish(self) -> None:
        self._w.finish()  # type: ignore[no-untyped-call]

    def __enter__(self) -> LogWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.finish()
