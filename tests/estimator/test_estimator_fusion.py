"""Fusion methods: mean, nearest, weighted and robust."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from estimator.errors import FusionError, UnknownFusionError
from estimator.estimates import BallEstimate
from estimator.fusion import (
    FUSION_METHODS,
    RANGE_TIE_M,
    Fusion,
    MeanFusion,
    NearestFusion,
    RobustFusion,
    WeightedFusion,
    get_fusion,
)
from estimator.noise import NoiseModel, range_sigma_m


def est(robot: str, rx: float, ry: float, bx: float, by: float) -> BallEstimate:
    d = math.hypot(bx - rx, by - ry)
    return BallEstimate(robot, rx, ry, d, math.atan2(by - ry, bx - rx), bx, by)


# Scenario 1 of the paper, with small errors.
SCENE = [
    est("robot1", -8.5, 0.0, 0.10, 0.05),
    est("robot2", -2.0, 1.0, 0.02, -0.01),
    est("robot3", -2.0, -1.0, -0.03, 0.02),
]


def test_range_sigma_is_cambada() -> None:
    assert range_sigma_m(0.0) == pytest.approx(0.039)
    assert range_sigma_m(5.0) == pytest.approx(0.25 - 0.05 + 0.039)


def test_get_fusion_names() -> None:
    for name in FUSION_METHODS:
        method = get_fusion(name)
        assert isinstance(method, Fusion)
        assert method.name == name
    with pytest.raises(UnknownFusionError, match="'median' is unknown; use one of mean, nearest"):
        get_fusion("median")


@pytest.mark.parametrize("name", FUSION_METHODS)
def test_no_estimates_and_one_estimate(name: str) -> None:
    method = get_fusion(name)
    assert method.fuse([]) is None
    fused = method.fuse(SCENE[:1])
    assert fused is not None
    assert (fused.x_m, fused.y_m) == pytest.approx((0.10, 0.05))
    assert fused.robots == ("robot1",)
    # a single estimate's covariance comes from the noise model: positive definite
    assert np.all(np.linalg.eigvalsh(np.array(fused.covariance)) > 0)


def test_mean_is_eq_20_21_with_the_covariance_of_the_mean() -> None:
    fused = MeanFusion().fuse(SCENE)
    assert fused is not None
    points = np.array([[e.x_m, e.y_m] for e in SCENE])
    assert (fused.x_m, fused.y_m) == pytest.approx(tuple(points.mean(axis=0)))
    assert np.array(fused.covariance) == pytest.approx(np.cov(points.T) / 3)
    assert fused.robots == ("robot1", "robot2", "robot3")


def test_nearest_picks_the_smallest_range() -> None:
    fused = NearestFusion().fuse(SCENE)
    assert fused is not None
    assert fused.robots == ("robot3",)  # 2.218 m, robot2 2.258 m, robot1 8.6 m
    assert (fused.x_m, fused.y_m) == (-0.03, 0.02)


def test_nearest_ties_go_to_the_robot_name_that_sorts_first() -> None:
    """The tie rule of ``nearest``: ranges within RANGE_TIE_M of the smallest tie, and the
    robot name that sorts first wins, whatever the order given; a gap of twice RANGE_TIE_M
    is no tie."""
    def at(robot: str, d: float) -> BallEstimate:
        return BallEstimate(robot, 0.0, 0.0, d, 0.0, d, 0.0)

    for gap, winner in ((0.0, "robot1"), (0.5 * RANGE_TIE_M, "robot1"),
                        (-0.5 * RANGE_TIE_M, "robot1"), (2 * RANGE_TIE_M, "robot2"),
                        (-2 * RANGE_TIE_M, "robot1")):
        scene = [at("robot2", 3.0), at("robot3", 3.0 + 2 * RANGE_TIE_M), at("robot1", 3.0 + gap)]
        for order in (scene, scene[::-1]):
            fused = NearestFusion().fuse(order)
            assert fused is not None and fused.robots == (winner,), (gap, order)


def test_noise_model_orients_the_covariance_along_the_bearing() -> None:
    noise = NoiseModel(bearing_sigma_rad=0.01)
    sigma = noise.covariance(est("r", 0.0, 0.0, 5.0, 0.0))  # ball along +x at 5 m
    assert sigma[0, 0] == pytest.approx(range_sigma_m(5.0) ** 2)
    assert sigma[1, 1] == pytest.approx((5.0 * 0.01) ** 2)
    assert sigma[0, 1] == pytest.approx(0.0, abs=1e-15)
    with pytest.raises(FusionError, match="min_sigma_m"):
        NoiseModel(min_sigma_m=0.0)


def test_weighted_trusts_the_near_robots() -> None:
    fused = WeightedFusion().fuse(SCENE)
    assert fused is not None
    # robot1 is 8.5 m away (sigma_r ~0.68 m): the result lies near robots 2 and 3
    assert abs(fused.x_m - (0.02 - 0.03) / 2) < 0.02
    cov = np.array(fused.covariance)
    assert np.all(np.linalg.eigvalsh(cov) > 0)
    assert cov[0, 0] < range_sigma_m(2.2) ** 2  # fusing shrinks the uncertainty


def test_robust_drops_an_outlier_and_keeps_at_least_one() -> None:
    scene = [*SCENE, est("robot4", -5.0, -2.0, 1.5, 1.5)]  # 2 m off
    fused = RobustFusion().fuse(scene)
    assert fused is not None
    assert "robot4" not in fused.robots
    weighted = WeightedFusion().fuse(SCENE)
    assert weighted is not None
    assert (fused.x_m, fused.y_m) == pytest.approx((weighted.x_m, weighted.y_m))
    two = RobustFusion().fuse([est("a", 0.0, 0.0, 1.0, 0.0), est("b", 0.0, 0.0, -1.0, 0.0)])
    assert two is not None and len(two.robots) == 1
    with pytest.raises(FusionError, match="n_sigma"):
        RobustFusion(n_sigma=0.0)


@pytest.mark.parametrize("name", ["mean", "weighted"])
def test_identical_robots_do_not_change_the_position(name: str) -> None:
    method = get_fusion(name)
    once = method.fuse(SCENE)
    twice = method.fuse(SCENE + SCENE)
    assert once is not None and twice is not None
    assert (twice.x_m, twice.y_m) == pytest.approx((once.x_m, once.y_m), abs=1e-12)


@pytest.mark.parametrize("name", FUSION_METHODS)
def test_deterministic(name: str) -> None:
    assert get_fusion(name).fuse(SCENE) == get_fusion(name).fuse(list(SCENE))


coord = st.floats(min_value=-6.0, max_value=6.0)
estimates = st.lists(st.tuples(coord, coord, coord, coord), min_size=1, max_size=5)


@settings(max_examples=40, deadline=None, derandomize=True)
# a tie: both ranges are exactly 5 m; turned by -2 rad, robot r1's comes out 1e-15 m shorter
@example(raw=[(0.0, 0.0, 3.0, 4.0), (1.0, 1.0, 6.0, 1.0)], rot=-2.0)
@given(estimates, st.floats(min_value=-math.pi, max_value=math.pi))
def test_rotating_everything_rotates_the_fused_estimate(
    raw: list[tuple[float, float, float, float]], rot: float
) -> None:
    """Every fusion is invariant under rotating the whole scene, ``nearest`` included when
    two robots are at the same range (its tie rule, not rounding, picks the robot).
    Derandomized, with the tie as an explicit example, so every run tries the same cases."""
    # a ball can't be inside its robot (0.245 m half side + 0.11 m radius); at range 0
    # the bearing, and so the orientation of the range noise, is undefined
    assume(all(math.hypot(bx - rx, by - ry) >= 0.35 for rx, ry, bx, by in raw))
    c, s = math.cos(rot), math.sin(rot)

    def turn(x: float, y: float) -> tuple[float, float]:
        return (c * x - s * y, s * x + c * y)

    before = [est(f"r{i}", rx, ry, bx, by) for i, (rx, ry, bx, by) in enumerate(raw)]
    after = [est(f"r{i}", *turn(rx, ry), *turn(bx, by)) for i, (rx, ry, bx, by) in enumerate(raw)]
    rotation = np.array([[c, -s], [s, c]])
    # only a gap in range within rounding (1e-12 m) of the tie threshold itself may tie in
    # one frame and not in the other
    nearest = min(e.range_m for e in before)
    on_the_edge = any(abs(e.range_m - nearest - RANGE_TIE_M) < 1e-12 for e in before)
    for name in FUSION_METHODS:
        if name == "nearest" and on_the_edge:
            continue
        f0 = get_fusion(name).fuse(before)
        f1 = get_fusion(name).fuse(after)
        assert f0 is not None and f1 is not None
        assert f1.robots == f0.robots
        assert (f1.x_m, f1.y_m) == pytest.approx(turn(f0.x_m, f0.y_m), abs=1e-6)
        expected_cov = rotation @ np.array(f0.covariance) @ rotation.T
        assert np.array(f1.covariance) == pytest.approx(expected_cov, abs=1e-9)
