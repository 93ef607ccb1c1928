"""A robot's own pose uncertainty in its estimate's covariance: the position's as it is, the
yaw's across the bearing growing with range (sigma_perp = range sigma_yaw), so a far robot
with a doubtful heading weighs less in every fusion."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from estimator.errors import FusionError
from estimator.estimates import BallEstimate, Covariance3
from estimator.fusion import RobustFusion, WeightedFusion
from estimator.noise import CalibratedNoise, NoiseModel, localisation_covariance
from estimator.tracking.one_shot import TrackFusion

YAW_SIGMA = math.radians(3.0)


def pose_cov(sigma_m: float, sigma_yaw_rad: float) -> Covariance3:
    return ((sigma_m**2, 0.0, 0.0), (0.0, sigma_m**2, 0.0), (0.0, 0.0, sigma_yaw_rad**2))


def est(robot: str, rx: float, ry: float, bx: float, by: float,
        cov: Covariance3 | None = None) -> BallEstimate:
    d = math.hypot(bx - rx, by - ry)
    return BallEstimate(robot, rx, ry, d, math.atan2(by - ry, bx - rx), bx, by,
                        pose_covariance=cov)


def across(sigma: np.ndarray, e: BallEstimate) -> float:
    """The standard deviation across the robot's bearing to the ball [m]."""
    phi = math.atan2(e.y_m - e.robot_y_m, e.x_m - e.robot_x_m)
    n = np.array([-math.sin(phi), math.cos(phi)])
    return math.sqrt(float(n @ sigma @ n))


def along(sigma: np.ndarray, e: BallEstimate) -> float:
    phi = math.atan2(e.y_m - e.robot_y_m, e.x_m - e.robot_x_m)
    u = np.array([math.cos(phi), math.sin(phi)])
    return math.sqrt(float(u @ sigma @ u))


def test_the_yaw_spreads_across_the_bearing_as_range_times_sigma() -> None:
    # a robot 6 m from the ball at 30 deg: 0.02 m of position, 3 deg of yaw
    e = est("r", 1.0, 2.0, 1.0 + 6 * math.cos(0.5), 2.0 + 6 * math.sin(0.5),
            pose_cov(0.02, YAW_SIGMA))
    s = localisation_covariance(e)
    assert across(s, e) == pytest.approx(math.hypot(0.02, 6 * YAW_SIGMA))
    assert along(s, e) == pytest.approx(0.02)
    assert np.allclose(localisation_covariance(replace(e, pose_covariance=None)), 0.0)
    # a position-yaw correlation moves the ball's spread as J P J^T says, not by the diagonal
    corr = ((0.02**2, 0.0, 0.0), (0.0, 0.02**2, 1e-4), (0.0, 1e-4, YAW_SIGMA**2))
    j = np.array([[1.0, 0.0, -(e.y_m - 2.0)], [0.0, 1.0, e.x_m - 1.0]])
    assert np.allclose(localisation_covariance(replace(e, pose_covariance=corr)),
                       j @ np.array(corr) @ j.T)
    with pytest.raises(FusionError, match="3 x 3 and finite"):
        localisation_covariance(replace(e, pose_covariance=((math.nan, 0, 0),) * 3))  # type: ignore[arg-type]


@pytest.mark.parametrize("noise", [NoiseModel(), CalibratedNoise()], ids=["cambada", "calibrated"])
def test_a_far_robot_with_a_yaw_sigma_is_wider_across_and_weighs_less(
        noise: NoiseModel | CalibratedNoise) -> None:
    near = est("near", -1.0, 0.0, 0.0, 0.0, pose_cov(0.02, YAW_SIGMA))
    far = est("far", -7.0, 0.0, 0.0, 0.0, pose_cov(0.02, YAW_SIGMA))
    for e in (near, far):
        with_pose = noise.covariance(e)
        without = noise.covariance(replace(e, pose_covariance=None))
        assert across(with_pose, e) > across(without, e)
    growth = across(noise.covariance(far), far) ** 2 - across(
        noise.covariance(replace(far, pose_covariance=None)), far) ** 2
    assert growth >= (7 * YAW_SIGMA) ** 2 * 0.9  # the yaw's share, at 7 m
    # the weight (information across the bearing) of the far robot falls far more
    assert across(noise.covariance(far), far) > 3 * across(noise.covariance(near), near)


def test_calibrated_noise_takes_the_pose_covariance_instead_of_its_fixed_sigmas() -> None:
    noise = CalibratedNoise(yaw_sigma_rad=0.05, position_sigma_m=0.3)
    e = est("r", -5.0, 0.0, 0.0, 0.0)
    exact = noise.covariance(replace(e, pose_covariance=pose_cov(0.0, 0.0)))
    fixed = noise.covariance(e)
    assert across(exact, e) < across(fixed, e) / 10  # the fixed 0.05 rad is gone
    assert along(exact, e) < along(fixed, e) / 5  # and the fixed 0.3 m


@pytest.mark.parametrize("fusion", [WeightedFusion(NoiseModel()), RobustFusion(NoiseModel()),
                                    WeightedFusion(CalibratedNoise()),
                                    TrackFusion(noise=CalibratedNoise())],
                         ids=["weighted", "robust", "weighted-calibrated", "track"])
def test_two_robots_one_unsure_of_its_yaw_lands_nearer_the_good_one(
        fusion: WeightedFusion | RobustFusion | TrackFusion) -> None:
    # the ball at (0, 0) between two robots 5 m either side, both off across their bearing:
    # "good" knows its yaw to 0.2 deg and is 0.02 m off, "bad" to 5 deg and is 0.05 m off
    # (without the term all four take both and land between them)
    good = est("good", -5.0, 0.0, 0.0, 0.02, pose_cov(0.01, math.radians(0.2)))
    bad = est("bad", 5.0, 0.0, 0.0, -0.05, pose_cov(0.01, math.radians(5.0)))
    plain = fusion.fuse([replace(good, pose_covariance=None), replace(bad, pose_covariance=None)])
    assert plain is not None and plain.robots == ("good", "bad")
    fused = fusion.fuse([good, bad])
    assert plain is not None and fused is not None
    to_good = math.hypot(fused.x_m - good.x_m, fused.y_m - good.y_m)
    to_bad = math.hypot(fused.x_m - bad.x_m, fused.y_m - bad.y_m)
    assert to_good < 0.2 * to_bad
    plain_to_good = math.hypot(plain.x_m - good.x_m, plain.y_m - good.y_m)
    assert to_good < 0.5 * plain_to_good  # nearer the good robot than without the term
