"""``dsp-replay --width-range``: a blob as wide as a ball at 4 m but as far out as a ball
2 m up puts its ray on the ground 0.76 m beyond the ball; with the width the estimate is
under the ball, its ray kept, and one robot alone gives the ball's height; a ball on the
ground is located as without the option; the paper's method refuses it; a golden replay
of a ball on the ground gives the same estimates."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from synthetic import GREEN_BGR, ORANGE_BGR

from dsp.cameras import camera_spec_from_json
from dsp.errors import UsageError
from estimator.constants import BALL_RADIUS_M, NS_PER_S
from estimator.detection import detect_ball
from estimator.geometry import RobotPose
from replay.cameras import Cameras
from replay.estimation import CorrectedLocator, FrameEstimator
from replay.options import ReplayOptions
from replay.records import FrameResult, FrameStatus
from replay.runner import replay
from replay.stats import ReplayStats

GOLDEN = Path(__file__).resolve().parents[2] / "logs" / "golden"
R = BALL_RADIUS_M
HEIGHT_M = 12.0
SPEC = camera_spec_from_json({"model": "ideal", "width_px": 1024, "height_px": 1024,
                              "cu_px": 512, "cv_px": 512, "max_radius_px": 512,
                              "height_m": HEIGHT_M, "k_m_per_px": 0.02}, "test")
M_PER_PX = SPEC.range_calibration.range_m(100.0) / 100.0
ROBOT = RobotPose(-4.0, 1.0, 0.3)
BALL = (-0.2, 2.2, 2.0)
"""4.0 m from the robot, 2 m up."""


def _cameras() -> Cameras:
    return Cameras({"robot1": SPEC}, {"robot1": SPEC.range_calibration})


def _image(ball: tuple[float, float, float]) -> np.ndarray:
    """What the robot's ideal camera (12 m above it) sees: a disc where the ball's ray
    meets the ground, as wide across the bearing as the ball at its horizontal range."""
    dx, dy = ball[0] - ROBOT.x_m, ball[1] - ROBOT.y_m
    rho = math.hypot(dx, dy)
    r = rho * (HEIGHT_M - R) / (HEIGHT_M - ball[2]) / M_PER_PX
    theta = math.atan2(dy, dx) - ROBOT.yaw_rad
    u, v = 512.0 - r * math.sin(theta), 512.0 - r * math.cos(theta)
    ys, xs = np.mgrid[0:1024, 0:1024]
    img = np.empty((1024, 1024, 3), np.uint8)
    img[:] = GREEN_BGR
    img[(xs - u) ** 2 + (ys - v) ** 2 <= (r * R / rho) ** 2] = ORANGE_BGR
    return img


def _located(ball: tuple[float, float, float], width: bool):
    det = detect_ball(_image(ball))
    assert det is not None
    est = FrameEstimator(method="corrected", fusion_method="track", cameras=_cameras(),
                         width_robots=frozenset({"robot1"} if width else ()))
    return est.locator.locate("robot1", det, ROBOT)


def test_a_ball_in_the_air_is_placed_under_itself_with_its_ray_kept() -> None:
    without = _located(BALL, width=False)
    assert math.hypot(without.x_m - BALL[0], without.y_m - BALL[1]) > 0.6
    assert without.ray_range_m is None and without.range_sigma_m is None
    e = _located(BALL, width=True)
    assert math.hypot(e.x_m - BALL[0], e.y_m - BALL[1]) < 2.5 * e.range_sigma_m
    assert e.range_sigma_m < 0.2
    assert e.ray_range_m == without.range_m
    assert e.bearing_rad == without.bearing_rad


def test_a_ball_on_the_ground_is_located_as_without_the_width() -> None:
    ground = (BALL[0], BALL[1], R)
    assert _located(ground, width=True) == _located(ground, width=False)


def test_one_robot_alone_gives_the_ball_s_height_from_its_width() -> None:
    """The ballistic fusion's one-robot point: z = R and the height unknown (sigma of
    metres) from the ground estimate; on the ray at the width's range, the ball's height
    within its sigma, with the width."""
    heights = {}
    for width in (False, True):
        est = FrameEstimator(method="corrected", fusion_method="ballistic", cameras=_cameras(),
                             width_robots=frozenset({"robot1"} if width else ()))
        e = _located(BALL, width)
        frame = FrameResult(0, "robot1", NS_PER_S, FrameStatus.OK, estimate=e)
        step = est.step(0, NS_PER_S, (frame,), (BALL[0], BALL[1]), truth_z=BALL[2])
        assert step.fused is not None and step.fused.z_m is not None
        assert step.fused.covariance_3d is not None
        heights[width] = step.fused.z_m, math.sqrt(step.fused.covariance_3d[2][2])
    assert heights[False][0] == R and heights[False][1] > 1.0  # the height unknown
    z, sigma = heights[True]
    assert abs(z - BALL[2]) < 2.5 * sigma and sigma < 0.4  # (from 12 m up: 2.5 m a metre)


def test_the_paper_s_method_has_no_width_to_use() -> None:
    with pytest.raises(UsageError, match="--width-range"):
        ReplayOptions(method="paper", width_range=True)
    # without a noise model the locator has no width to weigh: the ground-plane estimate
    assert CorrectedLocator(_cameras()).locate(
        "robot1", detect_ball(_image(BALL)), ROBOT) == _located(BALL, width=False)


def test_a_golden_ball_on_the_ground_gives_the_same_estimates(tmp_path: Path) -> None:
    runs = {}
    for width in (False, True):
        out = tmp_path / f"{width}.json"
        replay(GOLDEN / "scenario2.mcap", ReplayOptions(out=out, width_range=width or None,
                                                        progress=False))
        runs[width] = json.loads(out.read_text())
    assert runs[True]["options"].pop("width_range") is True
    assert runs[True]["options"] == runs[False]["options"]
    assert runs[True]["frames"] == runs[False]["frames"]
    assert runs[True]["fused"] == runs[False]["fused"]
    assert runs[True]["summary"].pop("width") == {"lifted": 0}  # counted, none in the air
    assert "width" not in runs[False]["summary"]


def test_the_summary_counts_the_estimates_placed_in_the_air() -> None:
    lifted, ground = _located(BALL, width=True), _located((BALL[0], BALL[1], R), width=True)
    for width in (False, True):
        stats = ReplayStats(("robot1",), width_range=width)
        for i, e in enumerate((lifted, ground, lifted)):
            stats.frame(FrameResult(i, "robot1", i, FrameStatus.OK, estimate=e), None)
        assert stats.summary_dict().get("width") == ({"lifted": 2} if width else None)
