"""The log writer: ROS 2 MCAP (CDR, zstd chunks) exactly as ``dsp.contract`` says.

Every message's ``log_time`` and ``publish_time`` are its header stamp in sim nanoseconds
(mcap_ros2 would otherwise use the wall clock), so the same inputs give the same bytes.

Crash safety: a chunk is closed and handed to the operating system at every whole sim
second (``chunk_duration_ns``: chunk k holds the messages stamped in [k s, k+1 s)) and when
it exceeds ``chunk_size`` bytes, whichever comes first. A recording killed outright (SIGKILL,
out of memory) therefore loses at most the chunk in progress, under one sim second; the
chunks before it replay with ``dsp-replay --recover``. :meth:`LogWriter.flush` does the same
on demand (the recorder calls it after the metadata, so a killed log still names its
scenario).
"""

from __future__ import annotations

from typing import IO, Any

from mcap.writer import CompressionType
from mcap_ros2.writer import Writer

from dsp import contract as c
from estimator.geometry import quaternion_from_yaw

__all__ = ["LogWriter"]

DEFAULT_CHUNK_SIZE = 4 * 1024 * 1024
"""A chunk closes once its uncompressed records exceed this [bytes]."""
CHUNK_DURATION_NS = 1_000_000_000
"""... and at every multiple of this in sim time [ns]: at most this much is lost to a kill."""


class LogWriter:
    """Writes one log to an open binary stream; use as a context manager or call finish().

    Messages must come in non-decreasing stamp order (the recorder's timeline)."""

    def __init__(self, stream: IO[bytes], *, chunk_size: int = DEFAULT_CHUNK_SIZE,
                 chunk_duration_ns: int = CHUNK_DURATION_NS) -> None:
        if chunk_duration_ns < 1:
            raise ValueError(f"chunk_duration_ns must be >= 1, got {chunk_duration_ns}")
        self._w = Writer(stream, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        # the mcap Writer under mcap_ros2's: its flush() closes the chunk in progress
        self._mcap: Any = self._w._writer
        self._chunk_ns = chunk_duration_ns
        self._chunk_end_ns: int | None = None
        self.chunks_closed = 0
        """Chunks closed by sim time or :meth:`flush` (not those closed by size)."""
        self._schemas = {
            name: self._w.register_msgdef(name, c.MESSAGE_DEFINITIONS[name])
            for name in (c.COMPRESSED_IMAGE, c.POSE_STAMPED, c.TF_MESSAGE)
        }
        self._seq: dict[str, int] = {}
        self.messages = 0

    def flush(self) -> None:
        """Close the chunk in progress (if any) and hand everything written so far to the
        operating system (no fsync: that survives a killed process, not a power cut)."""
        if self._chunk_end_ns is not None:
            self.chunks_closed += 1
        self._mcap.flush()
        self._chunk_end_ns = None

    def _write(self, topic: str, schema: str, msg: dict[str, Any], t_ns: int) -> None:
        if self._chunk_end_ns is not None and t_ns >= self._chunk_end_ns:
            self.flush()
        if self._chunk_end_ns is None:
            self._chunk_end_ns = (t_ns // self._chunk_ns + 1) * self._chunk_ns
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
