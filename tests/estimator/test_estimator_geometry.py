"""Yaw, quaternions, slerp and angle wrapping."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from estimator.errors import GeometryError
from estimator.geometry import (
    RobotPose,
    quaternion_from_yaw,
    slerp,
    wrap_angle,
    yaw_from_quaternion,
)

angles = st.floats(min_value=-math.pi + 1e-6, max_value=math.pi - 1e-6)


@given(angles)
def test_yaw_round_trip(yaw: float) -> None:
    assert yaw_from_quaternion(*quaternion_from_yaw(yaw)) == pytest.approx(yaw, abs=1e-9)


def test_yaw_formula_on_a_full_quaternion() -> None:
    # roll 0.3, pitch 0.2, yaw 1.1 (ZYX): the stated formula returns the yaw only.
    cr, sr = math.cos(0.15), math.sin(0.15)
    cp, sp = math.cos(0.1), math.sin(0.1)
    cy, sy = math.cos(0.55), math.sin(0.55)
    q = (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )
    assert yaw_from_quaternion(*q) == pytest.approx(1.1)
    assert yaw_from_quaternion(*(2.0 * c for c in q)) == pytest.approx(1.1)  # not unit


def test_zero_quaternion_is_an_error() -> None:
    with pytest.raises(GeometryError, match="non-zero"):
        yaw_from_quaternion(0.0, 0.0, 0.0, 0.0)


@given(angles, angles, st.floats(min_value=0.0, max_value=1.0))
def test_slerp_interpolates_yaw_the_short_way(a: float, b: float, t: float) -> None:
    q = slerp(quaternion_from_yaw(a), quaternion_from_yaw(b), t)
    expected = a + t * wrap_angle(b - a)
    assert wrap_angle(yaw_from_quaternion(*q) - expected) == pytest.approx(0.0, abs=1e-6)


def test_slerp_ends() -> None:
    q0, q1 = quaternion_from_yaw(0.2), quaternion_from_yaw(-2.5)
    assert slerp(q0, q1, 0.0) == pytest.approx(q0)
    assert yaw_from_quaternion(*slerp(q0, q1, 1.0)) == pytest.approx(-2.5)


@pytest.mark.parametrize(
    ("a", "wrapped"),
    [(0.0, 0.0), (math.pi, -math.pi), (3 * math.pi / 2, -math.pi / 2), (-7.0, -7.0 + 2 * math.pi)],
)
def test_wrap_angle(a: float, wrapped: float) -> None:
    assert wrap_angle(a) == pytest.approx(wrapped)


def test_robot_pose_is_frozen_and_built_from_a_quaternion() -> None:
    pose = RobotPose.from_quaternion(1.0, 2.0, quaternion_from_yaw(0.5))
    assert pose == RobotPose(1.0, 2.0, pytest.approx(0.5))  # type: ignore[arg-type]
    with pytest.raises(AttributeError):
        pose.x_m = 3.0  # type: ignore[misc]
