"""How far each robot's believed pose is off, as its own line fits show it: the prior of its
next fits.

A fit searches the lines around the believed pose with the pose's covariance as its prior
(:func:`~estimator.localisation.pose_fit.correct_pose`). Too tight a prior pulls a pose that
is 10 cm and 2 deg off back towards its belief, and refuses the true correction as a jump;
too wide a one lets a fit settle on a neighbouring line. No one value suits every team's
localiser, and a log that states no covariance says nothing of it. :class:`CorrectionSpread`
learns it per robot from the corrections its fits make (believed minus corrected: x and y
together, the yaw apart) as the log replays: fading second moments (time constant
``tau_s``) from a start of ``start_sigma_m`` / ``start_sigma_rad`` worth ``start_weight``
corrections, the start itself fading from the robot's first fit (time constant
``start_tau_s``: a start that never faded, ten centimetres worth four fits, kept a belief
the fits showed exact to 3 mm at 1.8 cm after 200 fits), kept above ``floor_sigma_m`` /
``floor_sigma_rad``. A fit refused as a jump
teaches too (a pose that moved further than the prior allows would otherwise never widen
it) unless it moved the pose further than ``max_m`` / ``max_rad`` (a neighbouring line, not
the pose). Stateful per replay, frames in order; deterministic.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from estimator.geometry import RobotPose, wrap_angle
from estimator.localisation.pose_fit import FitStatus, PoseCorrection

__all__ = ["CorrectionSpread", "SpreadParams"]

FloatArray = NDArray[np.float64]
NS = 1_000_000_000


@dataclass(frozen=True)
class SpreadParams:
    """How a robot's pose spread is learnt from its fits."""

    start_sigma_m: float = 0.10
    start_sigma_rad: float = math.radians(2.0)
    start_weight: float = 4.0
    """The start counts as this many corrections at the robot's first fit."""
    start_tau_s: float = 2.0
    """The start's weight fades with this time constant from the robot's first fit."""
    tau_s: float = 10.0
    floor_sigma_m: float = 0.002
    floor_sigma_rad: float = math.radians(0.05)
    max_m: float = 0.5
    max_rad: float = math.radians(10.0)


@dataclass
class _Moments:
    stamp_ns: int
    first_ns: int
    weight: float = 0.0
    xy2: float = 0.0
    yaw2: float = 0.0
    count: int = 0


@dataclass
class CorrectionSpread:
    """Per robot, the learnt spread of its believed pose (module docstring)."""

    params: SpreadParams = field(default_factory=SpreadParams)
    _robots: dict[str, _Moments] = field(default_factory=dict)

    def covariance(self, robot: str) -> FloatArray:
        """The prior covariance (x, y, yaw) of the robot's next fit."""
        p, m = self.params, self._robots.get(robot)
        w, xy2, yaw2 = (0.0, 0.0, 0.0) if m is None else (m.weight, m.xy2, m.yaw2)
        w0 = p.start_weight if m is None else p.start_weight * math.exp(
            -(m.stamp_ns - m.first_ns) / NS / p.start_tau_s)
        s_m2 = (w0 * p.start_sigma_m**2 + xy2) / (w0 + w)
        s_t2 = (w0 * p.start_sigma_rad**2 + yaw2) / (w0 + w)
        s_m2, s_t2 = max(s_m2, p.floor_sigma_m**2), max(s_t2, p.floor_sigma_rad**2)
        return np.diag([s_m2, s_m2, s_t2])

    def count(self, robot: str) -> int:
        """The robot's fits taken in."""
        m = self._robots.get(robot)
        return 0 if m is None else m.count

    def observe(self, robot: str, stamp_ns: int, believed: RobotPose,
                correction: PoseCorrection) -> None:
        """Take in the robot's fit of the frame at ``stamp_ns`` (accepted, or refused as a
        jump within ``max_m`` / ``max_rad``; other failures say nothing of the pose)."""
        c = correction.pose if correction.ok else (
            correction.found if correction.status is FitStatus.JUMP else None)
        if c is None:
            return
        dx, dy = believed.x_m - c.x_m, believed.y_m - c.y_m
        dyaw = wrap_angle(believed.yaw_rad - c.yaw_rad)
        p = self.params
        if math.hypot(dx, dy) > p.max_m or abs(dyaw) > p.max_rad:
            return
        m = self._robots.setdefault(robot, _Moments(stamp_ns, stamp_ns))
        if stamp_ns > m.stamp_ns:
            a = math.exp(-(stamp_ns - m.stamp_ns) / NS / p.tau_s)
            m.weight, m.xy2, m.yaw2 = a * m.weight, a * m.xy2, a * m.yaw2
            m.stamp_ns = stamp_ns
        m.weight += 1.0
        m.count += 1
        m.xy2 += 0.5 * (dx * dx + dy * dy)
        m.yaw2 += dyaw * dyaw
