"""A fit that starts from the robot's last correction: the same pose in fewer steps."""

from __future__ import annotations

import math

import numpy as np
import pytest
from field_images import field_lines, render_carpet

from dsp.field import FIELDS
from estimator.camera import CAMERA_MODELS, make_camera
from estimator.geometry import RobotPose, wrap_angle
from estimator.localisation import (
    CorrectionHold,
    DistanceGrid,
    FitStatus,
    GroundGrid,
    PoseCorrection,
    PoseFitParams,
    correct_pose,
    detect_line_points,
    pose_fit,
)

LINES = field_lines(FIELDS["18x12"])
GRID = DistanceGrid.build(LINES)
PRIOR_COV = np.diag([0.05**2, 0.05**2, math.radians(1.0) ** 2])


def _counted(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    calls = [0]
    inner = pose_fit._normal_equations

    def counting(*args: object) -> object:
        calls[0] += 1
        return inner(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(pose_fit, "_normal_equations", counting)
    return calls


@pytest.mark.parametrize("model", CAMERA_MODELS)
def test_a_warm_start_finds_the_same_pose_in_fewer_steps(
        model: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """From a start 1 cm and 0.3 deg off the minimum (the last frame's correction carried
    over, with the belief's white noise of two moments), only the last stage runs: the
    pose is the cold fit's to a fraction of a millimetre, in fewer steps."""
    truth = RobotPose(-4.3, 1.7, math.radians(35.0))
    prior = RobotPose(truth.x_m + 0.06, truth.y_m - 0.04, truth.yaw_rad + math.radians(1.2))
    pts = detect_line_points(render_carpet(make_camera(model), truth),
                             GroundGrid.build(make_camera(model)))
    calls = _counted(monkeypatch)
    cold = correct_pose(prior, PRIOR_COV, pts, GRID, LINES)
    cold_steps = calls[0]
    c = cold.pose
    start = RobotPose(c.x_m + 0.01, c.y_m - 0.01, c.yaw_rad + math.radians(0.3))
    calls[0] = 0
    warm = correct_pose(prior, PRIOR_COV, pts, GRID, LINES, start=start)
    assert cold.status is FitStatus.OK and warm.status is FitStatus.OK
    assert math.hypot(warm.pose.x_m - c.x_m, warm.pose.y_m - c.y_m) < 5e-4
    assert abs(math.degrees(wrap_angle(warm.pose.yaw_rad - c.yaw_rad))) < 0.01
    assert calls[0] < cold_steps
    # the prior is still the belief: the covariance and the jump test are the cold fit's
    np.testing.assert_allclose(warm.covariance, cold.covariance, rtol=0.05)


def test_a_warm_start_far_from_the_lines_still_fails_the_jump_test() -> None:
    """A start on the wrong line (0.75 m off) with a 5 cm prior: the minimum found there
    contradicts the prior and is refused, as from a cold start."""
    model, truth = CAMERA_MODELS[0], RobotPose(4.5, 1.0, math.radians(90.0))
    pts = detect_line_points(render_carpet(make_camera(model), truth),
                             GroundGrid.build(make_camera(model)))
    wrong = RobotPose(truth.x_m + 0.75, truth.y_m, truth.yaw_rad)
    result = correct_pose(truth, PRIOR_COV, pts, GRID, LINES, start=wrong)
    assert result.status is not FitStatus.OK or math.hypot(
        result.pose.x_m - truth.x_m, result.pose.y_m - truth.y_m) < 0.02


def test_the_warm_stages_are_checked() -> None:
    with pytest.raises(Exception, match="pose fit parameters"):
        PoseFitParams(warm_stages=0)
    with pytest.raises(Exception, match="pose fit parameters"):
        PoseFitParams(stages=(0.1, 0.05), warm_stages=3)


def test_the_hold_carries_the_last_correction_to_a_new_belief() -> None:
    hold = CorrectionHold()
    assert hold.carried("r1", 0, RobotPose(0.0, 0.0, 0.0), 10**9) is None  # none yet
    cov = np.diag([1e-6, 1e-6, 1e-8])
    hold.update("r1", 0, RobotPose(1.05, 2.0, 0.02), PRIOR_COV, PoseCorrection(
        RobotPose(1.0, 2.0, 0.0), cov, FitStatus.OK, 100, 100, np.zeros((3, 3))))
    moved = RobotPose(1.55, 2.5, 0.03)  # 0.5 s on: the same bias
    start = hold.carried("r1", 500_000_000, moved, 500_000_000)
    assert start is not None
    assert (start.x_m, start.y_m, start.yaw_rad) == pytest.approx((1.5, 2.5, 0.01))
    assert hold.carried("r1", 500_000_001, moved, 500_000_000) is None  # too old
    assert hold.carried("r1", -1, moved, 500_000_000) is None  # before it
    assert hold.carried("r2", 0, moved, 500_000_000) is None  # another robot's
