"""Paper mode reproduces the paper's worked example and Table 3 (eq. 3-14)."""

from __future__ import annotations

import math

import pytest

from estimator.geometry import quaternion_from_yaw, yaw_from_quaternion
from estimator.paper import locate_ball, rpy_from_quaternion


def test_worked_example_robot_1() -> None:
    # Section IV prints (-0.095, 0.278): it rounds dtr = 0.0174, pi = 3.14 and cos(0.001).
    # With exact radians the same equations give (-0.0877, 0.2786) (docs/method.md, errata).
    x, y = locate_ball(539, 40, -8.5, 0.0, 0.0)
    assert x == pytest.approx(-0.0877, abs=1e-4)
    assert y == pytest.approx(0.2786, abs=1e-4)


@pytest.mark.parametrize(
    ("pixel", "pose", "expected"),
    [
        # Table 3 prints x = 0.234 for robot 2: a typo, the equations give 0.2183.
        ((600, 420), (-2.0, 1.0), (0.2183, 0.2843)),
        # Table 3 prints x = -0.139 for robot 3: digits swapped, the equations give -0.3196.
        ((475, 453), (-2.0, -1.0), (-0.3196, 0.3218)),
    ],
)
@pytest.mark.parametrize("yaw_rad", [0.0, math.radians(360.0)])  # Table 2: heading 360 deg
def test_table_3_from_table_2(
    pixel: tuple[int, int],
    pose: tuple[float, float],
    expected: tuple[float, float],
    yaw_rad: float,
) -> None:
    x, y = locate_ball(pixel[0], pixel[1], pose[0], pose[1], yaw_rad)
    assert (x, y) == pytest.approx(expected, abs=1e-4)


def test_per_axis_offset_erratum_is_kept() -> None:
    # A ball straight ahead at r px: eq. 11-12 add b to BOTH axes, so y = robot_y + b.
    x, y = locate_ball(539, 539 - 100, 0.0, 0.0, 0.0)
    assert x == pytest.approx(0.0163 * 100 + 0.2786)
    assert y == pytest.approx(0.2786)


def test_lower_half_uses_the_2pi_branch() -> None:
    # Ball straight behind (Cy > 539): alpha = 2 pi - pi/2, Cx1 = -r, Cy1 = 0.
    x, y = locate_ball(539, 639, 0.0, 0.0, 0.0)
    assert x == pytest.approx(-0.0163 * 100 + 0.2786)
    assert y == pytest.approx(0.2786)


def test_yaw_rotates_the_offset() -> None:
    # Facing +y (yaw 90 deg), a ball ahead lies along +y.
    x, y = locate_ball(539, 439, 1.0, 2.0, math.pi / 2)
    assert x == pytest.approx(1.0 + 0.2786)
    assert y == pytest.approx(2.0 + 0.0163 * 100 + 0.2786)


def test_ball_at_image_centre_is_defined() -> None:
    assert locate_ball(539, 539, 1.0, -1.0, 0.7) == pytest.approx((1.2786, -0.7214))


def test_parameters_are_used() -> None:
    x, y = locate_ball(10, 0, 0.0, 0.0, 0.0, k_m_per_px=0.01, b_m=0.0, centre_px=(10.0, 10.0))
    assert (x, y) == pytest.approx((0.1, 0.0), abs=1e-12)


@pytest.mark.parametrize("yaw", [-3.0, -1.0, 0.0, 0.5, 2.0, 3.1])
def test_rpy_from_quaternion_matches_yaw(yaw: float) -> None:
    roll, pitch, got = rpy_from_quaternion(*quaternion_from_yaw(yaw))
    assert (roll, pitch) == pytest.approx((0.0, 0.0), abs=1e-12)
    assert got == pytest.approx(yaw_from_quaternion(*quaternion_from_yaw(yaw)))
    assert got == pytest.approx(yaw)


def test_rpy_from_quaternion_roll_pitch_and_gimbal_lock() -> None:
    s = math.sin(0.25)
    roll, pitch, yaw = rpy_from_quaternion(s, 0.0, 0.0, math.cos(0.25))  # roll 0.5 rad
    assert (roll, pitch, yaw) == pytest.approx((0.5, 0.0, 0.0), abs=1e-12)
    h = math.sqrt(0.5)
    roll, pitch, yaw = rpy_from_quaternion(0.0, h, 0.0, h)  # pitch +90 deg: locked
    assert pitch == pytest.approx(math.pi / 2)
    assert yaw == 0.0
