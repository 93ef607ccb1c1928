"""Locators: a robot's blob and pose -> its field estimate, by the paper's equations or the
corrected estimator (:mod:`replay.estimation` chooses one per replay)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Protocol

from estimator import corrected, paper
from estimator.detection import Detection
from estimator.estimates import BallEstimate
from estimator.geometry import RobotPose
from estimator.noise import CalibratedNoise
from estimator.width import combine_ranges, width_range
from replay.cameras import Cameras
from replay.records import RobotEstimate

__all__ = ["CorrectedLocator", "Locator", "PaperLocator", "ball_estimate"]


class Locator(Protocol):
    """Turns a robot's blob and pose into its field estimate (paper or corrected mode)."""

    def locate(self, robot: str, det: Detection, pose: RobotPose) -> RobotEstimate: ...


@dataclass(frozen=True)
class PaperLocator:
    """Eq. 3-14 exactly, the paper's calibration folded in."""

    cameras: Cameras

    def locate(self, robot: str, det: Detection, pose: RobotPose) -> RobotEstimate:
        # a turned camera: the paper's alpha0 = 90 deg - yaw takes the image's own yaw
        image_yaw = pose.yaw_rad + self.cameras.mount_yaw_rad(robot)
        x, y = paper.locate_ball(float(det.cx_px), float(det.cy_px), pose.x_m, pose.y_m,
                                 image_yaw, centre_px=self.cameras.centres[robot])
        dx, dy = x - pose.x_m, y - pose.y_m
        bearing = math.atan2(dy, dx) - pose.yaw_rad
        bearing = (bearing + math.pi) % (2 * math.pi) - math.pi
        rng = math.hypot(dx, dy)
        return RobotEstimate(robot, x, y, rng, bearing, pose.x_m, pose.y_m, pose.yaw_rad,
                             self.cameras.visibility(robot, det, rng))


@dataclass(frozen=True)
class CorrectedLocator:
    """The corrected estimator: calibration on the range, yaw from the full quaternion;
    with ``noise``, a blob of one of ``width_robots`` (None: every robot) whose width shows
    a ball in the air is placed under it, its ray kept (:mod:`estimator.width`,
    :mod:`replay.aloft`)."""

    cameras: Cameras
    noise: CalibratedNoise | None = None
    width_robots: frozenset[str] | None = None

    def locate(self, robot: str, det: Detection, pose: RobotPose) -> RobotEstimate:
        centre = self.cameras.centres[robot]
        e = corrected.estimate_ball(float(det.cx_px), float(det.cy_px), pose,
                                    self.cameras.calibrations[robot],
                                    centre_px=centre, robot=robot,
                                    mount_yaw_rad=self.cameras.mount_yaw_rad(robot))
        estimate = RobotEstimate(robot, e.x_m, e.y_m, e.range_m, e.bearing_rad, pose.x_m,
                                 pose.y_m, pose.yaw_rad,
                                 self.cameras.visibility(robot, det, e.range_m))
        if self.noise is None or e.r_px is None or (
                self.width_robots is not None and robot not in self.width_robots):
            return estimate
        width = width_range(det.outline_px, centre, (float(det.cx_px), float(det.cy_px)))
        if width is None:
            return estimate
        sigma = self.noise.calibrated_range_sigma_m(robot, e.r_px)
        choice = combine_ranges(e.range_m, sigma, width)
        if not choice.lifted:  # on the ground: the estimate as without the width
            return estimate
        phi = pose.yaw_rad + e.bearing_rad
        return replace(estimate, x_m=pose.x_m + choice.range_m * math.cos(phi),
                       y_m=pose.y_m + choice.range_m * math.sin(phi), range_m=choice.range_m,
                       range_sigma_m=choice.sigma_m, ray_range_m=e.range_m)


def ball_estimate(e: RobotEstimate, r_px: float | None = None,
                  camera_height_m: float | None = None) -> BallEstimate:
    """A robot's estimate as the fusions and noise models take it."""
    return BallEstimate(robot=e.robot, robot_x_m=e.robot_x_m, robot_y_m=e.robot_y_m,
                        range_m=e.range_m, bearing_rad=e.bearing_rad, x_m=e.x_m, y_m=e.y_m,
                        visibility=e.visibility, r_px=r_px, camera_height_m=camera_height_m,
                        pose_covariance=e.pose_covariance, range_sigma_m=e.range_sigma_m,
                        ray_range_m=e.ray_range_m)
