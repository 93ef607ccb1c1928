"""The per-robot bias filter (``--localise ball``): relative biases are learned from the
residuals against a shared track, position and yaw told apart as the ball moves, and a
robot that stops being compared relaxes to its prior."""

from __future__ import annotations

import math

import numpy as np

from estimator.tracking.bias import BiasEstimator, BiasParams

NS = 1_000_000_000
SIGMA = 0.01  # the estimates' own noise [m]


def _seen(robot_xy: tuple[float, float], ball: np.ndarray, b: np.ndarray
          ) -> tuple[np.ndarray, tuple[float, float]]:
    """Where a robot whose pose is off by b = (bx, by, bt) puts the ball, exactly (not the
    filter's first-order model), and the offset from its believed position."""
    true_robot = np.asarray(robot_xy) + b[:2]
    d_true = ball - true_robot
    c, s = math.cos(-b[2]), math.sin(-b[2])  # the believed heading is off by -bt
    d = np.array([c * d_true[0] - s * d_true[1], s * d_true[0] + c * d_true[1]])
    return np.asarray(robot_xy) + d, (float(d[0]), float(d[1]))


def _run(est: BiasEstimator, biases: dict[str, np.ndarray], seconds: float,
         rng: np.random.Generator, t0: float = 0.0) -> None:
    """Robots around a ball rolling in a circle; the track is the truth, each robot's
    estimate located with its current corrected pose."""
    robots = {"a": (-4.0, 0.0), "b": (3.0, 2.5), "c": (1.0, -4.0)}
    for k in range(int(seconds * 30)):
        t = t0 + k / 30
        ball = np.array([2.5 * math.cos(0.6 * t), 2.0 * math.sin(0.6 * t)])
        for name, b in biases.items():
            used, _ = est.bias(name)
            z, d = _seen(robots[name], ball, b - used)  # located from believed + used
            z = z + rng.normal(0.0, SIGMA, 2)
            cov = ((2 * SIGMA**2, 0.0), (0.0, 2 * SIGMA**2))
            est.update(name, round(t * NS), (float(ball[0] - z[0]), float(ball[1] - z[1])),
                       d, cov, (float(used[0]), float(used[1]), float(used[2])))


def test_a_robot_whose_pose_is_off_is_corrected_position_and_yaw() -> None:
    rng = np.random.default_rng(3)
    # positions' mean zero: a shift all robots share is not seen (the track would move
    # with it), and the estimator holds the robots' mean shift at zero
    truth = {"a": np.array([-0.03, -0.01, 0.0]),
             "b": np.array([0.06, -0.04, math.radians(1.2)]),
             "c": np.array([-0.03, 0.05, math.radians(-0.8)])}
    est = BiasEstimator(BiasParams(tau_s=60.0))  # a bias that holds for the whole run
    _run(est, truth, 12.0, rng)
    for name, b in truth.items():
        got, p = est.bias(name)
        assert np.hypot(*(got[:2] - b[:2])) < 0.015, (name, got, b)
        assert abs(got[2] - b[2]) < math.radians(0.25), (name, got, b)
        assert np.all(np.diag(p) < np.diag(est.params.stationary()))  # it learned
    assert est.updates == 3 * 12 * 30


def test_corrected_pose_adds_the_bias() -> None:
    est = BiasEstimator()
    pose, cov = est.corrected("a", 1.0, 2.0, math.pi - 0.001)
    assert pose == (1.0, 2.0, math.pi - 0.001)  # nothing learned: the believed pose
    # the prior's, plus the yaw's own frame-to-frame noise
    assert cov[0][0] == 0.05**2
    assert cov[2][2] == math.radians(1.0) ** 2 + math.radians(0.3) ** 2
    tight = ((1e-6, 0.0), (0.0, 1e-6))
    for k in range(5):  # robot a puts the ball 5 cm off the track across its bearing
        est.update("a", k, (0.0, 0.05), (3.0, 0.0), tight, tuple(est.bias("a")[0]))
        est.update("b", k, (0.0, 0.0), (0.0, 3.0), tight, tuple(est.bias("b")[0]))
    (x, y, yaw), _ = est.corrected("a", 1.0, 2.0, math.pi - 0.001)
    b, _ = est.bias("a")
    assert (x, y) == (1.0 + b[0], 2.0 + b[1])
    assert yaw == math.remainder(math.pi - 0.001 + b[2], math.tau)  # wrapped
    assert b[1] > 0.01 and b[2] > math.radians(0.2)  # a shift and a turn towards it
    # the shift the two robots share is held at zero
    assert abs(b[:2] + est.bias("b")[0][:2]).max() < 1e-12


def test_a_learnt_bias_leaves_the_yaws_frame_noise_in_its_covariance() -> None:
    """b can be learnt to a millimetre and a hundredth of a degree; the heading it corrects
    still has its own noise, which the fusion must weigh (else that noise goes into the
    track's velocity)."""
    est = BiasEstimator(BiasParams(tau_s=1e6))
    tight = ((1e-8, 0.0), (0.0, 1e-8))
    for k in range(200):  # the ball rolls round, so yaw and position are told apart
        for name, phase in (("a", 0.0), ("b", 2.0), ("c", 4.0)):
            d = (3.0 * math.cos(k / 20 + phase), 3.0 * math.sin(k / 20 + phase))
            est.update(name, k, (0.0, 0.0), d, tight, tuple(est.bias(name)[0]))
    _, p = est.bias("a")
    assert p[0, 0] < 1e-6 and p[2, 2] < math.radians(0.05) ** 2  # b is known
    _, cov = est.corrected("a", 0.0, 0.0, 0.0)
    assert cov[0][0] < 1e-6  # the position's own noise is the camera's estimate's
    assert math.radians(0.3) ** 2 <= cov[2][2] < math.radians(0.31) ** 2


def test_a_lone_robots_shift_is_not_seen() -> None:
    est = BiasEstimator()
    for k in range(10):
        est.update("a", k, (0.05, 0.05), (3.0, 0.0), ((1e-6, 0.0), (0.0, 1e-6)),
                   tuple(est.bias("a")[0]))
    b, _ = est.bias("a")
    assert b[0] == 0.0 and b[1] == 0.0  # against a track made of its own estimates


def test_an_unseen_robot_relaxes_to_its_prior() -> None:
    est = BiasEstimator(BiasParams(tau_s=2.0))
    cov = ((1e-4, 0.0), (0.0, 1e-4))
    for k in range(20):
        est.update("a", k * NS // 10, (0.08, 0.0), (2.0, 1.0), cov, tuple(est.bias("a")[0]))
        est.update("b", k * NS // 10, (0.0, 0.0), (-2.0, 1.0), cov, tuple(est.bias("b")[0]))
    before, _ = est.bias("a")
    assert before[0] > 0.02
    # ten time constants later a residual that says nothing (its covariance huge) finds
    # the filter back at its prior
    vague = ((1e6, 0.0), (0.0, 1e6))
    est.update("a", 22 * NS, (0.0, 0.0), (2.0, 1.0), vague, (0.0, 0.0, 0.0))
    est.update("b", 22 * NS, (0.0, 0.0), (-2.0, 1.0), vague, (0.0, 0.0, 0.0))
    after, p = est.bias("a")
    assert abs(after[0]) < 0.001 * before[0] + 1e-6
    assert np.allclose(p, est.params.stationary(), rtol=1e-3)
