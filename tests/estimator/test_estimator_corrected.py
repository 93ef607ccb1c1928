"""The corrected estimator: range from the calibration, bearing by atan2."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from estimator.calibration import LinearCalibration, MirrorCalibration
from estimator.corrected import estimate_ball
from estimator.geometry import RobotPose, wrap_angle

UNIT = LinearCalibration(0.01, 0.0)  # 1 px = 1 cm, no offset


@pytest.mark.parametrize(
    ("pixel", "bearing", "offset"),
    [
        ((539.0, 439.0), 0.0, (1.0, 0.0)),  # image up = robot forward
        ((439.0, 539.0), math.pi / 2, (0.0, 1.0)),  # image left = robot left
        ((639.0, 539.0), -math.pi / 2, (0.0, -1.0)),  # image right = robot right
        ((539.0, 639.0), math.pi, (-1.0, 0.0)),  # image down = behind
    ],
)
def test_bearing_convention(
    pixel: tuple[float, float], bearing: float, offset: tuple[float, float]
) -> None:
    e = estimate_ball(*pixel, RobotPose(2.0, -1.0, 0.0), UNIT, robot="robot1")
    assert wrap_angle(e.bearing_rad - bearing) == pytest.approx(0.0)  # +-pi behind
    assert e.range_m == pytest.approx(1.0)
    assert (e.x_m, e.y_m) == pytest.approx((2.0 + offset[0], -1.0 + offset[1]))
    assert (e.robot, e.robot_x_m, e.robot_y_m) == ("robot1", 2.0, -1.0)


def test_paper_calibration_applied_to_the_range_not_per_axis() -> None:
    # Table 2, robot 1: ball at (539, 40), robot at (-8.5, 0), yaw 0. The paper's y bias
    # (+0.2786) is gone: the ball is straight ahead, d(499) in front.
    e = estimate_ball(539.0, 40.0, RobotPose(-8.5, 0.0, 0.0))
    assert e.range_m == pytest.approx(0.0163 * 499 + 0.2786)
    assert (e.x_m, e.y_m) == pytest.approx((-8.5 + 8.4123, 0.0), abs=1e-9)


def test_centre_and_yaw_are_parameters() -> None:
    e = estimate_ball(50.0, 40.0, RobotPose(0.0, 0.0, math.pi / 2), UNIT, centre_px=(50.0, 50.0))
    assert (e.x_m, e.y_m) == pytest.approx((0.0, 0.1))  # forward is +y when yaw = 90 deg


def test_ball_at_centre_is_forward() -> None:
    e = estimate_ball(539.0, 539.0, RobotPose(1.0, 1.0, 0.0))
    assert e.bearing_rad == 0.0
    assert (e.x_m, e.y_m) == pytest.approx((1.2786, 1.0))


coord = st.floats(min_value=-8.0, max_value=8.0)
angle = st.floats(min_value=-math.pi, max_value=math.pi)


@settings(max_examples=60, deadline=None)
@given(coord, coord, angle, st.floats(0.0, 400.0), angle, angle)
def test_rotating_robot_and_ball_about_the_origin_rotates_the_estimate(
    x: float, y: float, yaw: float, r: float, theta: float, rot: float
) -> None:
    # The ball is seen at the same pixel (same r and robot-frame bearing) when robot and
    # ball rotate together; the field estimate must rotate by the same angle.
    u = 539.0 - r * math.sin(theta)
    v = 539.0 - r * math.cos(theta)
    calibration = MirrorCalibration(1.569, 0.003)
    before = estimate_ball(u, v, RobotPose(x, y, yaw), calibration)
    c, s = math.cos(rot), math.sin(rot)
    after = estimate_ball(u, v, RobotPose(c * x - s * y, s * x + c * y, yaw + rot), calibration)
    expected = (c * before.x_m - s * before.y_m, s * before.x_m + c * before.y_m)
    assert (after.x_m, after.y_m) == pytest.approx(expected, abs=1e-9)
    assert after.range_m == pytest.approx(before.range_m)
