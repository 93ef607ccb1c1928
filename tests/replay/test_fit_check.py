"""A line fit's covariance is checked against what its robot's residuals show: a fit sure of
itself to millimetres while its robot's ball lies centimetres from the others' is given
what the residuals show (``FrameEstimator.fit_check``); a fit whose residuals agree keeps
its own, and the bias filter's covariance is not touched. What the check learnt is in the
summary's beliefs and the printed line."""

from __future__ import annotations

import math

import numpy as np
from synthetic import GREEN_BGR, ORANGE_BGR

from dsp.cameras import camera_spec_from_json
from estimator.detection import detect_ball
from estimator.estimates import covariance3_rows
from estimator.geometry import RobotPose
from estimator.tracking.pose_noise import PoseNoiseEstimator
from replay.cameras import Cameras
from replay.cli import describe_belief
from replay.estimation import Detected, FrameEstimator
from replay.records import Localisation
from replay.sync import PoseMatch

SPEC = camera_spec_from_json({"model": "ideal", "width_px": 512, "height_px": 512,
                              "cu_px": 256, "cv_px": 256, "max_radius_px": 256,
                              "height_m": 6.0, "k_m_per_px": 0.02}, "test")
ROBOT = RobotPose(-1.0, 0.5, 0.2)
FIT = np.diag([0.002**2, 0.002**2, math.radians(0.03) ** 2])
R = np.diag([0.02**2, 0.02**2])


def _detected() -> Detected:
    img = np.empty((512, 512, 3), np.uint8)
    img[:] = GREEN_BGR
    ys, xs = np.mgrid[0:512, 0:512]
    img[(xs - 256) ** 2 + (ys - 150) ** 2 <= 36] = ORANGE_BGR  # 2 m ahead
    det = detect_ball(img)
    assert det is not None
    return Detected(None, det)


def _estimator(spread_m: float, spread_deg: float) -> FrameEstimator:
    """The default's estimator whose check saw robot1's fitted poses off by the spread."""
    fe = FrameEstimator(method="corrected", fusion_method="track",
                        cameras=Cameras({"robot1": SPEC}, {"robot1": SPEC.range_calibration}),
                        pose_noise=PoseNoiseEstimator())
    assert fe.fit_check is not None
    rng = np.random.default_rng(5)
    for k in range(300):
        rho, phi = rng.uniform(1.0, 8.0), rng.uniform(-math.pi, math.pi)
        dx, dy = rho * math.cos(phi), rho * math.sin(phi)
        e = rng.normal(0.0, [spread_m, spread_m, math.radians(spread_deg)])
        r = np.array([[1.0, 0.0, -dy], [0.0, 1.0, dx]]) @ e + rng.multivariate_normal(
            [0.0, 0.0], R)
        fe.fit_check.observe("robot1", k * 33_000_000, (float(r[0]), float(r[1])), (dx, dy),
                             R, 3)
    return fe


def _pose_covariance(fe: FrameEstimator, source: str) -> np.ndarray:
    loc = Localisation(ROBOT, covariance3_rows(FIT), "ok", source, 500, 480)
    out = fe.estimate("robot1", None, lambda: PoseMatch(ROBOT, 0, False),
                      detected=_detected(), localisation=loc)
    assert out.estimate is not None and out.estimate.pose_covariance is not None
    return np.asarray(out.estimate.pose_covariance)


def test_a_fit_surer_than_its_residuals_is_given_what_they_show() -> None:
    wrong = _estimator(0.0, 1.5)
    raised = _pose_covariance(wrong, "lines")
    assert math.degrees(math.sqrt(raised[2, 2])) > 1.0  # the fit said 0.03 deg
    held = _pose_covariance(wrong, "held")  # a held fit is a fit too
    assert np.array_equal(held, raised)
    assert np.allclose(_pose_covariance(wrong, "ball"), FIT)  # the bias filter's: its own
    right = _estimator(0.0, 0.0)
    kept = _pose_covariance(right, "lines")
    assert math.degrees(math.sqrt(kept[2, 2])) < 0.2 and math.sqrt(kept[0, 0]) < 0.01


def test_what_the_check_learnt_is_in_the_beliefs_and_the_printed_line() -> None:
    b = _estimator(0.0, 1.5).beliefs()["robot1"]
    assert 250 < int(str(b["fit_residuals"])) <= 300  # (the gate leaves a few out)
    assert float(str(b["fit_sigma_deg"])) > 1.0
    assert "its line fits off by" in describe_belief(b)
    assert "fit_sigma_m" not in FrameEstimator(
        method="corrected", fusion_method="track",
        cameras=Cameras({"robot1": SPEC}, {"robot1": SPEC.range_calibration}),
        pose_noise=PoseNoiseEstimator()).beliefs().get("robot1", {})
