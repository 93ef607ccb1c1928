"""``--smooth``: the steps held back until the log is read, then sent on smoothed.

The tracker's fixed-interval (RTS) smoother (:mod:`estimator.tracking.smoother`) needs the
whole log; :class:`SmoothedSteps` stands between the runner and the sinks, passes frames on
at once and keeps the steps until :meth:`SmoothedSteps.flush`, when each goes on with the
smoothed track in place of the causal one (:func:`smoothed_step`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from estimator.estimates import FusedEstimate, covariance_rows
from estimator.tracking import BallTracker, SmoothedTrack
from replay.records import FrameResult, StepResult
from replay.sink import Sink, SinkBase

__all__ = ["SmoothedSteps", "smoothed_step"]


def smoothed_step(step: StepResult, smooth: SmoothedTrack) -> StepResult:
    """``step`` with the smoothed track in place of the causal one (where there was one)."""
    if step.fused is None:
        return step
    g = smooth.state_at(step.stamp_ns)
    if g is None:
        return step
    x, p = g
    fused = FusedEstimate(float(x[0]), float(x[1]), covariance_rows(p[:2, :2]),
                          step.fused.robots)
    err = None if step.truth is None else math.hypot(fused.x_m - step.truth[0],
                                                     fused.y_m - step.truth[1])
    return replace(step, fused=fused, error_m=err, velocity_m_s=(float(x[2]), float(x[3])),
                   velocity_covariance=covariance_rows(p[2:, 2:]))


class SmoothedSteps(SinkBase):
    """Sinks behind the offline smoother: frames pass at once, steps wait for the whole
    log (:meth:`flush`), then go on with the smoothed track."""

    def __init__(self, tracker: BallTracker, sinks: list[Sink]) -> None:
        self.tracker = tracker
        self.sinks = sinks
        self._steps: list[StepResult] = []

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        for sink in self.sinks:
            sink.frame(result, image_bgr)

    def step(self, result: StepResult) -> None:
        self._steps.append(result)

    def flush(self) -> None:
        self.tracker.finish()
        smooth = self.tracker.smoothed()
        for step in self._steps:
            smoothed = smoothed_step(step, smooth)
            for sink in self.sinks:
                sink.step(smoothed)
        self._steps.clear()
