"""Sink writing the estimates as a ROS 2 MCAP log.

- ``/estimate/{robot}/ball``: geometry_msgs/msg/PointStamped, one per robot estimate;
- ``/estimate/ball``: geometry_msgs/msg/PoseWithCovarianceStamped, the fused estimate, with
  the 2x2 position covariance in the x/y block of the 6x6 row-major matrix (other entries 0);
  a 3-D fusion's (``triangulate``, ``ballistic``) at its height z with the 3x3 covariance in
  the x/y/z block;
- ``/estimate/ball/odometry``: nav_msgs/msg/Odometry (frame ``field``, child ``ball``), the
  tracked ball's position and velocity with both 2x2 covariances, when the fusion estimates
  a velocity (``track``); ``ballistic``'s with z, vz and the 3x3 position covariance (the
  velocity's is its level 2x2 block). Its schema is registered with its first message, so a
  window fusion's file is as it was;
- ``/estimate/ball/landing``: geometry_msgs/msg/PointStamped, ``ballistic``'s predicted
  landing while the ball flies: the ball's centre where it meets the ground (z = the ball's
  radius), ``header.stamp`` the predicted landing time and ``log_time`` the step that
  predicted it (so a viewer shows the prediction when it was made).

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
from estimator.constants import BALL_RADIUS_M
from replay.records import FrameResult, StepResult
from replay.sink import SinkBase

__all__ = ["BALL_FRAME", "FUSED_TOPIC", "LANDING_TOPIC", "ODOMETRY_TOPIC", "ROBOT_TOPIC",
           "McapSink"]

ROBOT_TOPIC = "/estimate/{robot}/ball"
FUSED_TOPIC = contract.ESTIMATE_TOPIC
ODOMETRY_TOPIC = contract.ESTIMATE_ODOMETRY_TOPIC
LANDING_TOPIC = contract.ESTIMATE_LANDING_TOPIC
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
        z = 0.0 if fused.z_m is None else fused.z_m
        cov = fused.covariance if fused.covariance_3d is None else fused.covariance_3d
        self._write(FUSED_TOPIC, contract.POSE_WITH_COVARIANCE_STAMPED, t,
                    contract.pose_with_covariance_stamped(t, fused.x_m, fused.y_m, cov, z_m=z))
        if result.velocity_m_s is None:
            return
        vx, vy = result.velocity_m_s
        self._write(ODOMETRY_TOPIC, contract.ODOMETRY, t, contract.odometry(
            t, BALL_FRAME, fused.x_m, fused.y_m, vx, vy, z_m=z,
            vz_m_s=0.0 if result.vz_m_s is None else result.vz_m_s,
            position_covariance=cov, velocity_covariance=result.velocity_covariance))
        landing = result.landing
        if landing is not None:
            self._write(LANDING_TOPIC, contract.POINT_STAMPED, t, contract.point_stamped(
                landing.stamp_ns, landing.x_m, landing.y_m, BALL_RADIUS_M))

    def _write(self, topic: str, schema: str, log_time: int, message: dict[str, object]
               ) -> None:
        """One message; a schema not yet in the file is registered with its first one."""
        if schema not in self._schemas:
            self._schemas[schema] = self._writer.register_msgdef(
                schema, contract.MESSAGE_DEFINITIONS[schema])
        self._writer.write_message(topic, self._schemas[schema], message, log_time=log_time,
                                   publish_time=log_time)

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
