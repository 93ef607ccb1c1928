"""The records that flow from the runner to every sink: one per image, one per fusion step.

A :class:`FrameResult` is what replay made of one image (how far it got, its detection,
pose and estimate, the truth and the error); a :class:`StepResult` one fusion step (its
frames, the fused estimate, velocity and truth). Both are frozen and fully typed; the
results file's form of them is :mod:`replay.sinks.results_json`.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from estimator.constants import PAPER_CENTRE_PX
from estimator.detection import Detection
from estimator.detection.real import Candidate
from estimator.estimates import Covariance, FusedEstimate
from estimator.estimates import Covariance3 as PoseCovariance
from estimator.geometry import RobotPose
from estimator.tracking.ballistic import Landing

__all__ = ["FRAME_STATUSES", "FrameResult", "FrameStatus", "Localisation", "RobotEstimate",
           "StepResult"]


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
    pose_covariance: PoseCovariance | None = None
    """With ``--pose-uncertainty``: the covariance over (x, y, yaw) of the pose the estimate
    was located from, which the fusion adds the ball's share of (:mod:`estimator.noise`)."""
    range_sigma_m: float | None = None
    """With ``--width-range``, for a ball the width shows in the air: the sigma of
    ``range_m`` [m], the width's (:mod:`estimator.width`); None otherwise."""
    ray_range_m: float | None = None
    """With ``--width-range``, for a ball the width shows in the air: where its ray meets
    the ground-plane [m] (the estimate itself is placed under the ball); None otherwise."""


class LinePixels(Protocol):
    """Line points that know where they are in their image
    (:class:`replay.localise.LocalisedPoints`)."""

    @property
    def pixels(self) -> np.ndarray:
        """(N, 2) float32 (u, v)."""


Covariance3 = tuple[tuple[float, float, float], ...]
"""A 3 x 3 covariance over (x_m, y_m, yaw_rad), row by row."""


@dataclass(frozen=True)
class Localisation:
    """A frame's pose corrected from the field lines in its image (``--localise lines``):
    the pose the ball is located with, beside the believed one (:attr:`FrameResult.pose`)."""

    pose: RobotPose
    covariance: Covariance3
    """Of ``pose`` [m^2, m rad, rad^2]: the fit's, a held fit's grown with its age, or the
    belief's (``--pose-sigma``) when the prior stays."""
    status: str
    """The fit's: "ok", "too_few_points", "poor_fit", "jump", or "no_camera" (the log
    names no camera model for the robot)."""
    source: str
    """Where ``pose`` comes from: "lines" (this frame's fit), "held" (the robot's last fit,
    recent, applied to this belief) or "prior" (the believed pose itself)."""
    points: int
    """Line points on the field under the believed pose."""
    inliers: int
    """Of them, within the fit's inlier distance of a line at the result."""
    line_points: LinePixels | None = field(default=None, compare=False, repr=False)
    """The frame's line points, whose place in the image the viewer shows (:attr:`pixels`)."""

    @property
    def pixels(self) -> np.ndarray | None:
        """(N, 2) float32 (u, v) of the line points in the image, for the viewer: worked
        out when first asked for (a replay with no viewer never pays for it)."""
        return None if self.line_points is None else self.line_points.pixels


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
    localisation: Localisation | None = None
    """The pose from the field lines (``--localise lines``); None when not localising.
    With it, ``estimate`` is located from ``localisation.pose``; ``pose`` stays the
    believed one."""
    estimator_s: float = 0.0
    """Wall time of detection + estimation [s]: for display only, never in results files."""
    candidates: tuple[Candidate, ...] = ()
    """The real detector's checked candidates, the winner first (none from the paper's
    chain): for the viewer, not in results files."""


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
    vz_m_s: float | None = None
    """The fused vertical velocity [m/s], when the fusion estimates one (``ballistic``)."""
    landing: Landing | None = None
    """Where and when the ball is predicted to land (``ballistic``, while it flies)."""

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
