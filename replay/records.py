"""The records that flow from the runner to every sink: one per image, one per fusion step.

A :class:`FrameResult` is what replay made of one image (how far it got, its detection,
pose and estimate, the truth and the error); a :class:`StepResult` one fusion step (its
frames, the fused estimate, velocity and truth). Both are frozen and fully typed; the
results file's form of them is :mod:`replay.sinks.results_json`.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from estimator.constants import PAPER_CENTRE_PX
from estimator.detection import Detection
from estimator.estimates import Covariance, FusedEstimate
from estimator.geometry import RobotPose

__all__ = ["FRAME_STATUSES", "FrameResult", "FrameStatus", "RobotEstimate", "StepResult"]


class FrameStatus(str, enum.Enum):
    """How far an image got through the estimator (the results file's ``status``)."""

    OK = "ok"
    NO_DETECTION = "no_detection"
    NO_POSE = "no_pose"
    BAD_IMAGE = "bad_image"
    DETECT_ERROR = "detect_error"
    OUT_OF_RANGE = "out_of_range"

    @property
    def skipped(self) -> bool:
        """True when the frame counts as skipped (a frame without a ball is not)."""
        return self not in (FrameStatus.OK, FrameStatus.NO_DETECTION)


FRAME_STATUSES = tuple(s.value for s in FrameStatus)


@dataclass(frozen=True)
class RobotEstimate:
    """One robot's ball estimate in the field frame [m]; bearing in the robot frame [rad]."""

    robot: str
    x_m: float
    y_m: float
    range_m: float
    bearing_rad: float
    robot_x_m: float
    robot_y_m: float
    robot_yaw_rad: float
    visibility: float = 1.0
    """Detected blob area / a whole ball's expected area at this range (1: unknown)."""


@dataclass(frozen=True)
class FrameResult:
    """What replay made of one image."""

    frame: int
    robot: str
    stamp_ns: int
    status: FrameStatus
    detection: Detection | None = None
    r_px: float | None = None
    centre_px: tuple[float, float] = PAPER_CENTRE_PX
    pose: RobotPose | None = None
    pose_gap_ns: int | None = None
    pose_interpolated: bool = False
    estimate: RobotEstimate | None = None
    truth: tuple[float, float] | None = None
    error_m: float | None = None
    estimator_s: float = 0.0
    """Wall time of detection + estimation [s]: for display only, never in results files."""


@dataclass(frozen=True)
class StepResult:
    """One fusion step: the robots' frames within the window and their fused estimate."""

    step: int
    stamp_ns: int
    frames: tuple[FrameResult, ...]
    fused: FusedEstimate | None = None
    truth: tuple[float, float] | None = None
    error_m: float | None = None
    velocity_m_s: tuple[float, float] | None = None
    """The fused velocity [m/s] (field frame), when the fusion estimates one (``track``)."""
    velocity_covariance: Covariance | None = None
    """Its 2 x 2 covariance [m^2/s^2]."""
    truth_velocity_m_s: tuple[float, float] | None = None
    """The ball's true velocity at the step's stamp, when the log holds it."""
    truth_z_m: float | None = None
    """The true height of the ball's centre at the step's stamp, when the log holds it."""

    @property
    def z_error_m(self) -> float | None:
        """z - z_true [m] when a 3-D fusion gave a height and the truth has one."""
        if self.fused is None or self.fused.z_m is None or self.truth_z_m is None:
            return None
        return self.fused.z_m - self.truth_z_m

    @property
    def error_3d_m(self) -> float | None:
        """The 3-D distance to the truth [m] when both are 3-D."""
        dz = self.z_error_m
        if dz is None or self.error_m is None:
            return None
        return math.hypot(self.error_m, dz)

    @property
    def velocity_error_m_s(self) -> float | None:
        """|v - v_true| [m/s] when both are known."""
        if self.velocity_m_s is None or self.truth_velocity_m_s is None:
            return None
        return math.hypot(self.velocity_m_s[0] - self.truth_velocity_m_s[0],
                          self.velocity_m_s[1] - self.truth_velocity_m_s[1])
