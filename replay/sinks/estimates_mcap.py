"""Sink writing the estimates as a ROS 2 MCAP log.

- ``/estimate/{robot}/ball``: geometry_msgs/msg/PointStamped, one per robot estimate;
- ``/estimate/ball``: geometry_msgs/msg/PoseWithCovarianceStamped, the fused estimate, with
  the 2x2 position covariance in the x/y block of the 6x6 row-major matrix (other entries 0);
- ``/estimate/ball/odometry``: nav_msgs/msg/Odometry (frame ``field``, child ``ball``), the
  tracked ball's position and velocity with both 2x2 covariances, when the fusion estimates
  a velocity (``track``). Its schema is registered with its first message, so a window
  fusion's file is as it was.

Schemas and messages come from ``dsp.contract``; ``log_time`` = ``publish_time``
= the estimate's stamp (sim time), never the wall clock. Written to a temporary name and
renamed on success; a failing write (a full disk) is one error naming the output, and the
temporary file is removed.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

import numpy as np
from mcap.records import Schema
from mcap_ros2.writer import Writer

from dsp import contract
from dsp.atomic import AtomicFile
from replay.records import FrameResult, StepResult
from replay.sink import SinkBase

__all__ = ["BALL_FRAME", "FUSED_TOPIC", "ODOMETRY_TOPIC", "ROBOT_TOPIC", "McapSink"]

ROBOT_TOPIC = "/estimate/{robot}/ball"
FUSED_TOPIC = contract.ESTIMATE_TOPIC
ODOMETRY_TOPIC = contract.ESTIMATE_ODOMETRY_TOPIC
BALL_FRAME = "ball"
"""The Odometry's child_frame_id."""


class McapSink(SinkBase):
    """Writes estimates to ``path`` (refuses an existing file unless ``force``)."""

    def __init__(self, path: Path, *, force: bool = False) -> None:
        self._out = AtomicFile(path, force=force)
        self._file = self._out.stream()
        self._writer = Writer(self._file)
        self._schemas: dict[str, Schema] = {}
        for name in (contract.POINT_STAMPED, contract.POSE_WITH_COVARIANCE_STAMPED):
            self._schemas[name] = self._writer.register_msgdef(
                name, contract.MESSAGE_DEFINITIONS[name]
            )

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        est = result.estimate
        if est is None or self._writer is None:
            return
        t = result.stamp_ns
        with self._out.guard():  # a chunk is written when full: a full disk names the output
            self._writer.write_message(
                contract.topic_for(ROBOT_TOPIC, result.robot),
                self._schemas[contract.POINT_STAMPED],
                contract.point_stamped(t, est.x_m, est.y_m, 0.0),
                log_time=t,
                publish_time=t,
            )

    def step(self, result: StepResult) -> None:
        if result.fused is not None and self._writer is not None:
            with self._out.guard():
                self._step(result)

    def _step(self, result: StepResult) -> None:
        fused = result.fused
        assert fused is not None
        t = result.stamp_ns
        self._writer.write_message(
            FUSED_TOPIC,
            self._schemas[contract.POSE_WITH_COVARIANCE_STAMPED],
            contract.pose_with_covariance_stamped(t, fused.x_m, fused.y_m, fused.covariance),
            log_time=t,
            publish_time=t,
        )
        if result.velocity_m_s is None:
            return
        if contract.ODOMETRY not in self._schemas:
            self._schemas[contract.ODOMETRY] = self._writer.register_msgdef(
                contract.ODOMETRY, contract.MESSAGE_DEFINITIONS[contract.ODOMETRY])
        vx, vy = result.velocity_m_s
        self._writer.write_message(
            ODOMETRY_TOPIC,
            self._schemas[contract.ODOMETRY],
            contract.odometry(t, BALL_FRAME, fused.x_m, fused.y_m, vx, vy,
                              position_covariance=fused.covariance,
                              velocity_covariance=result.velocity_covariance),
            log_time=t,
            publish_time=t,
        )

    def close(self, ok: bool) -> None:
        try:
            if ok:
                with self._out.guard():
                    self._writer.finish()  # type: ignore[no-untyped-call]
                    self._file.close()
                self._out.commit()
        finally:
            with contextlib.suppress(OSError):  # the write that failed said so already
                self._file.close()
            self._out.discard()
