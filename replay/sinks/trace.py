"""What the replay figure shows, kept while replaying: a few numbers per frame and step."""

from __future__ import annotations

import math

import numpy as np

from dsp.field import FieldSpec
from estimator.constants import NS_PER_S
from replay.records import FrameResult, StepResult
from replay.sink import SinkBase

__all__ = ["ReplayTrace"]


class ReplayTrace(SinkBase):
    """Sink keeping what the replay figure shows: per frame (t, robot, error, estimate,
    pose), per step (t, fused position, truth, error). A few numbers per frame."""

    def __init__(self, robots: tuple[str, ...], field: FieldSpec, title: str) -> None:
        self.robots = robots
        self.field = field
        self.title = title
        self.frames: dict[str, list[tuple[float, float, float, float]]] = {r: [] for r in robots}
        """robot -> [(t_s, error_m, x_m, y_m)], NaN where there is none."""
        self.poses: dict[str, list[tuple[float, float, float]]] = {r: [] for r in robots}
        self.fused: list[tuple[float, float, float, float]] = []
        """[(t_s, error_m, x_m, y_m)], NaN where there is no estimate."""
        self.truth: list[tuple[float, float]] = []

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        est, nan = result.estimate, math.nan
        err = nan if result.error_m is None else result.error_m
        xy = (nan, nan) if est is None else (est.x_m, est.y_m)
        self.frames.setdefault(result.robot, []).append((result.stamp_ns / NS_PER_S, err, *xy))
        if result.pose is not None:
            self.poses.setdefault(result.robot, []).append(
                (result.pose.x_m, result.pose.y_m, result.pose.yaw_rad))

    def step(self, result: StepResult) -> None:
        fused, nan = result.fused, math.nan
        err = nan if result.error_m is None else result.error_m
        xy = (nan, nan) if fused is None else (fused.x_m, fused.y_m)
        self.fused.append((result.stamp_ns / NS_PER_S, err, *xy))
        if result.truth is not None:
            self.truth.append(result.truth)
