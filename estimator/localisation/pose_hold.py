"""Frames whose line fit failed: the last correction held, while it is recent.

A robot's localisation error drifts slowly (seconds), so when one image shows too few lines
(a robot in front of the camera, the robot at a corner looking out) the offset the lines
gave a moment ago is still most of it. :class:`CorrectionHold` keeps, per robot, the last
accepted correction as an offset in the field frame (believed minus corrected: x, y, yaw)
and its stamp; a failed frame within ``max_age_ns`` of it gets ``believed - offset``, its
covariance that of the correction grown by a random walk of ``drift_sigma`` per sqrt(s)
(the prior's when that is smaller). Older than that, the prior stays. A held pose carries
the believed pose's white noise of both moments (the offset removed the bias, not that).

Stateful per replay (one object, frames in stamp order per robot); deterministic.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from estimator.geometry import RobotPose, wrap_angle
from estimator.localisation.pose_fit import PoseCorrection

__all__ = ["CorrectionHold", "HeldPose"]

FloatArray = NDArray[np.float64]
NS = 1_000_000_000


@dataclass(frozen=True, eq=False)
class HeldPose:
    """The pose a frame goes on with, its covariance and where it came from."""

    pose: RobotPose
    covariance: FloatArray
    source: str
    """"lines" (this frame's fit), "held" (an earlier fit's offset) or "prior"."""


@dataclass
class _Last:
    stamp_ns: int
    offset: FloatArray
    covariance: FloatArray


@dataclass
class CorrectionHold:
    """Per robot, the last accepted correction, applied to failed frames while recent."""

    max_age_ns: int = 2 * NS
    drift_sigma: tuple[float, float, float] = (0.02, 0.02, 0.004)
    """Random-walk growth of a held offset per sqrt(second): x [m], y [m], yaw [rad]."""
    _last: dict[str, _Last] = field(default_factory=dict)

    def carried(self, robot: str, stamp_ns: int, believed: RobotPose,
                max_age_ns: int) -> RobotPose | None:
        """The last accepted correction's offset applied to ``believed``, when it is at most
        ``max_age_ns`` old at ``stamp_ns`` (where a fit of this frame may start), else None."""
        last = self._last.get(robot)
        if last is None or not 0 <= stamp_ns - last.stamp_ns <= max_age_ns:
            return None
        return RobotPose(believed.x_m - float(last.offset[0]), believed.y_m - float(last.offset[1]),
                         wrap_angle(believed.yaw_rad - float(last.offset[2])))

    def update(self, robot: str, stamp_ns: int, believed: RobotPose,
               prior_covariance: FloatArray, correction: PoseCorrection) -> HeldPose:
        """The frame's pose: the correction when it is accepted (and remembered), else the
        held offset applied to ``believed`` when recent, else ``believed`` itself."""
        if correction.ok:
            c = correction.pose
            offset = np.array([believed.x_m - c.x_m, believed.y_m - c.y_m,
                               wrap_angle(believed.yaw_rad - c.yaw_rad)])
            self._last[robot] = _Last(stamp_ns, offset, correction.covariance.copy())
            return HeldPose(c, correction.covariance, "lines")
        last = self._last.get(robot)
        age_ns = None if last is None else stamp_ns - last.stamp_ns
        if last is None or age_ns is None or not 0 <= age_ns <= self.max_age_ns:
            return HeldPose(believed, np.asarray(prior_covariance, np.float64), "prior")
        grown = last.covariance + np.diag(np.square(self.drift_sigma)) * (age_ns / NS)
        prior = np.asarray(prior_covariance, np.float64)
        cov = grown if np.trace(grown) < np.trace(prior) else prior
        pose = RobotPose(believed.x_m - float(last.offset[0]),
                         believed.y_m - float(last.offset[1]),
                         wrap_angle(believed.yaw_rad - float(last.offset[2])))
        return HeldPose(pose, cov, "held")
