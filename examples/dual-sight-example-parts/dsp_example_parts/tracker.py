"""A tracker as a fusion: the robots' median, smoothed from step to step.

A fusion from outside keeps what it likes between calls: dsp-replay makes one instance per
replay and calls ``fuse`` once per step that has estimates, in time order. This one keeps
its last output and moves it a fixed fraction of the way to each step's median (an
exponential moving average: a tracker without a motion model).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from estimator.estimates import BallEstimate, FusedEstimate

GAIN = 0.5
"""How far each step moves the track towards the step's median (1: no smoothing)."""
SIGMA_M = 0.05


class SmoothingFusion:
    name = "example-smoothing"

    def __init__(self) -> None:
        self.track: tuple[float, float] | None = None

    def fuse(self, estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        if not estimates:
            return None
        x = float(np.median([e.x_m for e in estimates]))
        y = float(np.median([e.y_m for e in estimates]))
        if self.track is not None:
            x = self.track[0] + GAIN * (x - self.track[0])
            y = self.track[1] + GAIN * (y - self.track[1])
        self.track = (x, y)
        v = SIGMA_M**2
        return FusedEstimate(x_m=x, y_m=y, covariance=((v, 0.0), (0.0, v)),
                             robots=tuple(e.robot for e in estimates))
