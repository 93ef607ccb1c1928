"""The image centre and the mounting rotation, fitted to where the ball was seen."""

from __future__ import annotations

import math

import numpy as np
import pytest

from estimator.calibration import fit_centre_and_mount, fit_mount
from estimator.corrected import estimate_ball
from estimator.errors import FitError
from estimator.geometry import RobotPose


def _seen(cu: float, cv: float, psi: float, theta: np.ndarray, d: np.ndarray,
          noise_px: float, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Centroids of balls at robot-frame directions theta and ranges d, through a camera
    centred at (cu, cv) turned by psi (image up = robot direction psi), any radial law."""
    rng = np.random.default_rng(seed)
    r = 60.0 * d**0.8
    phi = theta - psi
    return (cu - r * np.sin(phi) + rng.normal(0.0, noise_px, d.size),
            cv - r * np.cos(phi) + rng.normal(0.0, noise_px, d.size))


@pytest.mark.parametrize("psi_deg", [0.0, 93.0, -170.0, 180.0])
def test_the_centre_and_mount_are_recovered(psi_deg: float) -> None:
    rng = np.random.default_rng(3)
    theta, d = rng.uniform(-math.pi, math.pi, 40), rng.uniform(0.5, 9.0, 40)
    u, v = _seen(640.3, 511.7, math.radians(psi_deg), theta, d, 0.5)
    fit = fit_centre_and_mount(u, v, theta)
    assert fit.centre_fitted and fit.n == 40
    assert abs(fit.cu_px - 640.3) < 0.5 and abs(fit.cv_px - 511.7) < 0.5
    assert abs(math.remainder(fit.mount_yaw_rad - math.radians(psi_deg), math.tau)) < 0.005
    assert 0.3 < fit.rms_px < 0.7  # the centroids' noise, seen across the lines


def test_one_direction_cannot_fix_a_centre() -> None:
    d = np.linspace(0.5, 9.0, 20)
    theta = np.zeros(20) + np.random.default_rng(0).normal(0.0, 0.01, 20)
    u, v = _seen(539.0, 539.0, 0.0, theta, d, 0.3)
    with pytest.raises(FitError, match="too narrow a spread"):
        fit_centre_and_mount(u, v, theta)
    fit = fit_mount(u, v, theta, (539.0, 539.0))  # a known centre: the mount alone
    assert not fit.centre_fitted and abs(fit.mount_yaw_rad) < 0.01


def test_fit_mount_about_a_known_centre() -> None:
    theta = np.radians([0.0, 45.0, 90.0, 180.0, -90.0])
    u, v = _seen(100.0, 80.0, math.radians(-30.0), theta, np.full(5, 3.0), 0.0)
    fit = fit_mount(u, v, theta, (100.0, 80.0))
    assert fit.mount_yaw_rad == pytest.approx(math.radians(-30.0), abs=1e-9)
    assert fit.rms_px == pytest.approx(0.0, abs=1e-9)
    with pytest.raises(FitError, match="at the image centre"):
        fit_mount([100.0], [80.0], [0.0], (100.0, 80.0))


def test_bad_samples_are_refused() -> None:
    with pytest.raises(FitError, match="one of each"):
        fit_centre_and_mount([1.0, 2.0, 3.0], [1.0, 2.0], [0.0, 1.0, 2.0])
    with pytest.raises(FitError, match="NaN"):
        fit_centre_and_mount([1.0, 2.0, math.nan], [1.0, 2.0, 3.0], [0.0, 1.0, 2.0])


def test_the_estimate_turns_with_the_mount() -> None:
    """A camera turned so image up shows the robot's left: a ball at image up is to the left."""
    pose = RobotPose(1.0, 2.0, 0.0)
    plain = estimate_ball(539.0, 239.0, pose, centre_px=(539.0, 539.0))
    turned = estimate_ball(539.0, 239.0, pose, centre_px=(539.0, 539.0),
                           mount_yaw_rad=math.pi / 2)
    assert plain.bearing_rad == 0.0 and turned.bearing_rad == pytest.approx(math.pi / 2)
    assert turned.range_m == plain.range_m
    assert turned.x_m == pytest.approx(1.0) and turned.y_m == pytest.approx(2.0 + plain.range_m)


def test_the_ranges_move_a_rough_centre_to_the_true_one() -> None:
    """Directions measured 0.3 deg off blur the lines; the radii against the ranges do not."""
    from estimator.calibration import fit_centre_to_ranges

    rng = np.random.default_rng(5)
    theta, d = rng.uniform(-math.pi, math.pi, 40), rng.uniform(0.5, 7.0, 40)
    r = np.arctan(d / 1.04) / 0.00286  # a mirror: d = a tan(b r)
    u = 640.0 - r * np.sin(theta) + rng.normal(0.0, 0.2, 40)
    v = 512.0 - r * np.cos(theta) + rng.normal(0.0, 0.2, 40)
    seen = theta + np.radians(rng.normal(0.0, 0.3, 40))
    lines = fit_centre_and_mount(u, v, seen)
    cu, cv, rms = fit_centre_to_ranges(u, v, d, (lines.cu_px + 1.5, lines.cv_px - 1.5))
    assert math.hypot(cu - 640.0, cv - 512.0) < 0.3
    assert math.hypot(cu - 640.0, cv - 512.0) < math.hypot(lines.cu_px + 1.5 - 640.0,
                                                           lines.cv_px - 1.5 - 512.0)
    assert rms < 0.05
