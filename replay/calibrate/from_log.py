"""Calibration samples from a log: the ball at a known place (or on a truth topic), robots
seeing it from where their poses say they are.

The log is read by the replay itself (:func:`replay.replay`: the same bounded reader, pose
interpolation and detection), with the paper's camera standing in, since only the
centroids and the poses are kept: a sink takes, from every frame where the ball was
detected and the robot's pose is known, the centroid and the ball's true range and
direction from the robot, the ball being at ``ball_at`` (field frame) or where the truth
topic says at that stamp. Poses in another frame are first moved into the field frame by
``map_to_field`` (x, y, yaw in degrees), as the camera file will say.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from dsp.cameras import FieldTransform
from dsp.errors import InputError
from replay.calibrate.measurements import Measurements, Sample
from replay.options import ReplayOptions
from replay.records import FrameResult
from replay.runner import replay
from replay.sink import SinkBase

__all__ = ["samples_from_log"]


class _Sightings(SinkBase):
    """The samples, per robot, and each robot's image size."""

    def __init__(self, ball_at: tuple[float, float] | None,
                 transform: FieldTransform | None) -> None:
        self.ball_at = ball_at
        self.transform = transform
        self.samples: dict[str, list[Sample]] = {}
        self.sizes: dict[str, tuple[int, int]] = {}

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        if image_bgr is not None:
            self.sizes.setdefault(result.robot, (int(image_bgr.shape[1]),
                                                 int(image_bgr.shape[0])))
        det, pose = result.detection, result.pose
        ball = self.ball_at or result.truth
        if det is None or pose is None or ball is None:
            return
        x, y, yaw = pose.x_m, pose.y_m, pose.yaw_rad
        if self.transform is not None:
            x, y, yaw = self.transform.apply(x, y, yaw)
        dx, dy = ball[0] - x, ball[1] - y
        d = math.hypot(dx, dy)
        if d <= 0.0:
            return
        theta = math.remainder(math.atan2(dy, dx) - yaw, math.tau)
        self.samples.setdefault(result.robot, []).append(
            Sample(d, theta, u_px=float(det.cx_px), v_px=float(det.cy_px)))


def samples_from_log(log: Path, *, ball_at: tuple[float, float] | None,
                     truth_topic: str | None, image_topic: str, pose_topic: str,
                     map_to_field: tuple[float, float, float] | None = None,
                     robots: tuple[str, ...] | None = None
                     ) -> tuple[Measurements, dict[str, tuple[int, int]]]:
    """The samples of every robot of ``log`` and each robot's image size (width, height)."""
    if (ball_at is None) == (truth_topic is None):
        raise InputError(f"{log}: say where the ball was: --ball-at X,Y or --truth-topic TOPIC")
    transform = None if map_to_field is None else FieldTransform(
        map_to_field[0], map_to_field[1], math.radians(map_to_field[2]))
    sink = _Sightings(ball_at, transform)
    replay(log, ReplayOptions(cameras="paper", fusion="mean", image_topic=image_topic,
                              pose_topic=pose_topic, truth_topic=truth_topic, robots=robots,
                              progress=False), sinks=[sink])
    if not sink.samples:
        raise InputError(f"{log}: no image shows the ball where a robot's pose is known")
    return Measurements(sink.samples, True, str(log)), sink.sizes
