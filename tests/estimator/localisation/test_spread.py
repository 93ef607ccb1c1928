"""How far each robot's belief is off, learnt from its line fits (estimator.localisation.spread)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from estimator.geometry import RobotPose
from estimator.localisation import CorrectionSpread, FitStatus, PoseCorrection, SpreadParams

NS = 1_000_000_000
BELIEVED = RobotPose(1.0, -2.0, 0.5)


def _fit(dx: float, dy: float, dyaw: float, status: FitStatus = FitStatus.OK) -> PoseCorrection:
    """A fit that moved the belief by (dx, dy, dyaw) (or, refused, would have)."""
    moved = RobotPose(BELIEVED.x_m - dx, BELIEVED.y_m - dy, BELIEVED.yaw_rad - dyaw)
    ok = status is FitStatus.OK
    return PoseCorrection(moved if ok else BELIEVED, np.eye(3) * 1e-6, status, 500, 450,
                          np.zeros((3, 3)), None if ok else moved)


def _feed(spread: CorrectionSpread, sigma_m: float, sigma_deg: float, n: int = 600,
          seed: int = 3) -> None:
    rng = np.random.default_rng(seed)
    for k in range(n):  # 20 s of fits at 30 Hz
        dx, dy, dyaw = rng.normal(0.0, [sigma_m, sigma_m, math.radians(sigma_deg)])
        spread.observe("r1", k * NS // 30, BELIEVED, _fit(dx, dy, dyaw))


def _sigmas(spread: CorrectionSpread, robot: str = "r1") -> tuple[float, float]:
    cov = spread.covariance(robot)
    assert cov[0, 0] == cov[1, 1]
    return math.sqrt(cov[0, 0]), math.degrees(math.sqrt(cov[2, 2]))


def test_before_any_fit_the_start_and_then_what_the_fits_show() -> None:
    p = SpreadParams()
    spread = CorrectionSpread()
    assert _sigmas(spread) == pytest.approx((p.start_sigma_m, math.degrees(p.start_sigma_rad)))
    _feed(spread, 0.10, 2.0)
    s_m, s_deg = _sigmas(spread)
    assert s_m == pytest.approx(0.10, rel=0.15) and s_deg == pytest.approx(2.0, rel=0.15)
    assert spread.count("r1") == 600 and spread.count("r2") == 0
    assert _sigmas(spread, "r2") == pytest.approx((0.10, 2.0))  # another robot: the start


def test_exact_beliefs_narrow_it_to_the_floor() -> None:
    p = SpreadParams()
    spread = CorrectionSpread()
    _feed(spread, 0.0, 0.0)
    s_m, s_deg = _sigmas(spread)
    assert p.floor_sigma_m <= s_m < 1.5 * p.floor_sigma_m
    assert math.degrees(p.floor_sigma_rad) <= s_deg < 1.5 * math.degrees(p.floor_sigma_rad)


def test_millimetre_corrections_are_learnt_as_millimetres_once_the_start_has_faded() -> None:
    """Exact beliefs, the fits' own noise 3 mm and 0.1 deg, 10 s at 20 Hz: the spread is
    what the fits show, not the start's 10 cm (four fits' worth that did not fade kept it
    at 1.8 cm); a second after the first fit the start still counts."""
    spread = CorrectionSpread()
    rng = np.random.default_rng(5)
    for k in range(200):
        dx, dy, dyaw = rng.normal(0.0, [0.003, 0.003, math.radians(0.1)])
        spread.observe("r1", k * NS // 20, BELIEVED, _fit(dx, dy, dyaw))
        if k == 20:
            assert _sigmas(spread)[0] > 0.03
    s_m, s_deg = _sigmas(spread)
    assert s_m == pytest.approx(0.003, rel=0.2) and s_deg == pytest.approx(0.1, rel=0.2)


def test_a_refused_jump_widens_it_a_neighbouring_line_and_other_failures_do_not() -> None:
    narrow = CorrectionSpread()
    _feed(narrow, 0.01, 0.2)
    before = _sigmas(narrow)
    for k in range(5):  # refused as jumps: 4 cm and 1 deg, far beyond a 1 cm prior
        narrow.observe("r1", (30 + k) * NS, BELIEVED, _fit(0.04, 0.0, math.radians(1.0),
                                                            FitStatus.JUMP))
    widened = _sigmas(narrow)
    assert widened[0] > before[0] and widened[1] > before[1]
    for status, move in ((FitStatus.JUMP, (1.0, 0.0, 0.0)), (FitStatus.POOR_FIT, (0.05, 0, 0)),
                         (FitStatus.TOO_FEW_POINTS, (0.05, 0, 0))):
        narrow.observe("r1", 40 * NS, BELIEVED, _fit(*move, status))
    assert _sigmas(narrow) == widened and narrow.count("r1") == 605


def test_old_fits_fade() -> None:
    spread = CorrectionSpread()
    _feed(spread, 0.10, 2.0)
    for k in range(600):  # then 20 s of exact ones
        spread.observe("r1", 20 * NS + k * NS // 30, BELIEVED, _fit(0.0, 0.0, 0.0))
    s_m, s_deg = _sigmas(spread)
    assert s_m < 0.05 and s_deg < 1.0
