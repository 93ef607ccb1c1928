"""A tracker as a fusion: the robots' median, smoothed in time from step to step.

A fusion from outside keeps what it likes between calls: dsp-replay makes one instance per
replay. Having ``fuse_at(stamp_ns, estimates)`` (an ``estimator.fusion.TimedFusion``), this
one is called at every step, in time order, with the step's stamp, also when no robot saw
the ball: it moves its last output towards each step's median by 1 - exp(-dt / TAU_S) (an
exponential moving average in time: a tracker without a motion model) and holds it while
nothing is seen. ``fuse`` is its one-shot form: the median alone.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from estimator.estimates import BallEstimate, FusedEstimate

TAU_S = 0.5
"""The smoothing's time constant [s]: a step dt after the last moves the track
1 - exp(-dt / TAU_S) of the way to the step's median."""
SIGMA_M = 0.05


def _median(estimates: Sequence[BallEstimate]) -> tuple[float, float]:
    return (float(np.median([e.x_m for e in estimates])),
            float(np.median([e.y_m for e in estimates])))


def _fused(x: float, y: float, robots: tuple[str, ...]) -> FusedEstimate:
    v = SIGMA_M**2
    return FusedEstimate(x_m=x, y_m=y, covariance=((v, 0.0), (0.0, v)), robots=robots)


class SmoothingFusion:
    name = "example-smoothing"

    def __init__(self) -> None:
        self.track: tuple[float, float] | None = None
        self.stamp_ns = 0

    def fuse(self, estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        if not estimates:
            return None
        return _fused(*_median(estimates), tuple(e.robot for e in estimates))

    def fuse_at(self, stamp_ns: int,
                estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        if not estimates:  # nothing seen: the track held where it was
            return None if self.track is None else _fused(*self.track, ())
        x, y = _median(estimates)
        if self.track is not None:
            gain = 1.0 - math.exp(-(stamp_ns - self.stamp_ns) / 1e9 / TAU_S)
            x = self.track[0] + gain * (x - self.track[0])
            y = self.track[1] + gain * (y - self.track[1])
        self.track, self.stamp_ns = (x, y), stamp_ns
        return _fused(x, y, tuple(e.robot for e in estimates))
