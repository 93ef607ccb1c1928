"""The pose uncertainty learnt from residuals (estimator.tracking.pose_noise)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from estimator.tracking.bias import BiasEstimator
from estimator.tracking.pose_noise import PoseNoiseEstimator, PoseNoiseParams

NS = 1_000_000_000
R = np.diag([0.02**2, 0.02**2])  # the estimates' own noise the residuals state


def _feed(est: PoseNoiseEstimator, sigma_m: float, sigma_deg: float, n: int = 3000,
          seed: int = 1, supporters: int = 1000) -> None:
    """Residuals of a robot whose pose is off by white noise of (sigma_m, sigma_deg), its
    ball 1-8 m away in every direction, on top of the noise R."""
    rng = np.random.default_rng(seed)
    for k in range(n):
        rho, phi = rng.uniform(1.0, 8.0), rng.uniform(-math.pi, math.pi)
        dx, dy = rho * math.cos(phi), rho * math.sin(phi)
        e = rng.normal(0.0, [sigma_m, sigma_m, math.radians(sigma_deg)])
        j = np.array([[1.0, 0.0, -dy], [0.0, 1.0, dx]])
        r = j @ e + rng.multivariate_normal([0.0, 0.0], R)
        est.observe("r1", k * NS // 30, (float(r[0]), float(r[1])), (dx, dy), R, supporters)


@pytest.mark.parametrize(("sigma_m", "sigma_deg"), [(0.0, 0.0), (0.05, 1.0), (0.10, 2.0),
                                                    (0.02, 0.5)])
def test_the_pose_spread_the_residuals_show_is_learnt(sigma_m: float, sigma_deg: float) -> None:
    est = PoseNoiseEstimator()
    _feed(est, sigma_m, sigma_deg)
    s_m, s_t = est.sigma("r1")
    # within a centimetre and a fifth of a degree (100 s of residuals, fading over 10 s)
    assert s_m == pytest.approx(sigma_m, abs=0.01)
    assert math.degrees(s_t) == pytest.approx(sigma_deg, abs=0.2)


def test_exact_poses_cost_nothing_and_an_unseen_robot_keeps_the_prior() -> None:
    est = PoseNoiseEstimator()
    _feed(est, 0.0, 0.0)
    cov = np.asarray(est.covariance("r1"))
    assert cov[0, 0] < 0.005**2 and cov[2, 2] < math.radians(0.1) ** 2
    p = PoseNoiseParams()
    assert est.sigma("r2") == pytest.approx((p.prior_sigma_m, p.prior_sigma_rad))
    assert est.count("r2") == 0 and est.count("r1") >= 2990  # the gate's four sigma: a few


def test_a_robot_alone_and_a_far_residual_teach_nothing() -> None:
    est = PoseNoiseEstimator()
    assert not est.observe("r1", 0, (0.1, 0.0), (3.0, 0.0), R, supporters=1)
    assert not est.observe("r1", 0, (2.0, 0.0), (3.0, 0.0), R, supporters=3)  # a false blob
    assert not est.observe("r1", 0, (0.1, 0.0), (0.0, 0.0), R, supporters=3)  # no range
    assert est.residuals == 0


def test_residuals_far_beyond_what_is_learnt_are_left_out() -> None:
    """A ball in the air placed on the ground, a false blob: 30-60 cm off a robot whose
    poses are exact, one residual in ten, teach nothing."""
    est, clean = PoseNoiseEstimator(), PoseNoiseEstimator()
    _feed(clean, 0.0, 0.0, n=600)
    _feed(est, 0.0, 0.0, n=600)
    rng = np.random.default_rng(3)
    for k in range(600, 660):
        r = rng.uniform(0.3, 0.6) * np.array([math.cos(k), math.sin(k)])
        assert not est.observe("r1", k * NS // 30, (float(r[0]), float(r[1])), (4.0, 0.0), R,
                               1000)
    assert est.sigma("r1") == pytest.approx(clean.sigma("r1"), abs=1e-3)


def test_the_robots_own_share_of_the_track_is_scaled_back() -> None:
    """With two robots the track is half the robot's own: its residual shows half its
    error's variance, which the estimator doubles back."""
    two, many = PoseNoiseEstimator(), PoseNoiseEstimator()
    _feed(two, 0.05 / math.sqrt(2), 0.0, supporters=2)
    _feed(many, 0.05 / math.sqrt(2), 0.0, supporters=1000)
    assert two.sigma("r1")[0] == pytest.approx(math.sqrt(2) * many.sigma("r1")[0], rel=0.01)


def test_old_residuals_fade() -> None:
    """A robot whose poses were 10 cm off and are exact now is believed again."""
    est = PoseNoiseEstimator()
    _feed(est, 0.10, 0.0, n=900)
    assert est.sigma("r1")[0] > 0.07
    rng = np.random.default_rng(2)
    for k in range(900, 2400):  # 50 s of exact poses
        r = rng.multivariate_normal([0.0, 0.0], R)
        est.observe("r1", k * NS // 30, (float(r[0]), float(r[1])), (3.0, 1.0), R, 1000)
    assert est.sigma("r1")[0] < 0.02


def test_the_bias_filter_takes_the_learnt_spread_per_robot() -> None:
    learnt = PoseNoiseEstimator()
    _feed(learnt, 0.10, 2.0)
    bias = BiasEstimator(learnt=learnt)
    prior = np.diag(bias.stationary("r1"))
    assert math.sqrt(prior[0]) == pytest.approx(0.10, abs=0.01)
    assert math.degrees(math.sqrt(prior[2])) == pytest.approx(2.0, abs=0.2)
    # a robot whose poses are exact: no yaw noise beyond what it shows (the params' own
    # 0.3 deg of frame-to-frame noise is not added to it)
    exact = PoseNoiseEstimator()
    _feed(exact, 0.0, 0.0)
    _, cov = BiasEstimator(learnt=exact).corrected("r1", 0.0, 0.0, 0.0)
    assert math.degrees(math.sqrt(cov[2][2])) < 0.15
    _, cov = BiasEstimator().corrected("r1", 0.0, 0.0, 0.0)  # a fixed spread: as before
    assert math.degrees(math.sqrt(cov[2][2])) == pytest.approx(math.hypot(1.0, 0.3))


def test_a_stated_covariance_is_the_bias_spread_in_place_of_the_learnt() -> None:
    learnt = PoseNoiseEstimator()
    _feed(learnt, 0.10, 2.0)
    bias = BiasEstimator(learnt=learnt)
    stated = np.diag([0.02**2, 0.02**2, math.radians(0.1) ** 2])
    bias.state("r1", stated)
    assert np.allclose(bias.stationary("r1"), stated)
    assert math.sqrt(bias.stationary("r2")[0, 0]) == pytest.approx(0.03, abs=0.005)  # learnt's
    _, cov = bias.corrected("r1", 0.0, 0.0, 0.0)  # no yaw noise beyond what it states
    assert math.degrees(math.sqrt(cov[2][2])) == pytest.approx(0.1 * math.sqrt(2), rel=0.01)
