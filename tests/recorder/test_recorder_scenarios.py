"""Scenarios: the paper's table exactly, seeded randomness, names from file names."""

from __future__ import annotations

import math
import subprocess
import sys

import cv2
import pytest

from dsp.errors import UsageError
from recorder.errors import UnknownScenarioError
from recorder.scenarios import (
    PAPER_SCENARIOS,
    SCENARIOS,
    make_scenario,
    scenario_from_path,
)

# docs/method.md, "The four scenes": robot 1, 2, 3 as (x, y, yaw deg), ball (x, y)
PAPER_TABLE = {
    "scenario1": ([(-8.5, 0, 0), (-2, 1, 0), (-2, -1, 0)], (0, 0)),
    "scenario2": ([(-8.5, 0, 0), (-2, 1, 0), (-2, -1, 0)], (0, 3)),
    "scenario3": ([(-8.5, 0, 0), (-2, 1, 0), (-2, -1, 0)], (0, -3)),
    "scenario4": ([(-8.5, 0, 0), (-2, 3, -90), (-5, -2, 45)], (0, 0)),
}


@pytest.mark.parametrize("name", PAPER_SCENARIOS)
def test_paper_scenarios_match_the_table(name: str) -> None:
    sc = make_scenario(name)
    poses, ball = PAPER_TABLE[name]
    assert [r.name for r in sc.robots] == ["robot1", "robot2", "robot3"]
    for track, (x, y, yaw_deg) in zip(sc.robots, poses, strict=True):
        assert track.pose_at(0.0) == pytest.approx((x, y, math.radians(yaw_deg)))
        assert not track.moving
    assert sc.ball_xy_m == ball and sc.ball_velocity_mps == (0.0, 0.0)
    assert sc.opponents == ()
    assert sc.default_duration_s * sc.default_rate_hz == 5  # a few frames: quick to record


def test_random_is_seeded_and_varied() -> None:
    assert make_scenario("random", 7) == make_scenario("random", 7)
    assert make_scenario("random", 7) != make_scenario("random", 8)
    cases = {make_scenario("random", s).notes["case"] for s in range(30)}
    assert cases == {"visible", "hidden", "out_of_range"}
    sc = make_scenario("random", 2, robots=5, field="22x14")
    assert len(sc.robots) == 5
    assert all(abs(r.x_m) < 11 and abs(r.y_m) < 7 for r in sc.robots)
    for a in sc.robots:
        for b in sc.robots:
            if a is not b:
                assert math.hypot(a.x_m - b.x_m, a.y_m - b.y_m) >= 1.2


def test_random_cases_mean_what_they_say() -> None:
    for seed in range(30):
        sc = make_scenario("random", seed)
        r1, (bx, by) = sc.robots[0], sc.ball_xy_m
        dist = math.hypot(bx - r1.x_m, by - r1.y_m)
        case = sc.notes["case"]
        if case == "out_of_range":
            assert dist >= 9.5
        if case == "hidden":
            (opp,) = sc.opponents
            assert opp.opponent
            # the opponent stands on robot 1's line of sight, just in front of the ball
            t = ((opp.x_m - r1.x_m) * (bx - r1.x_m) + (opp.y_m - r1.y_m) * (by - r1.y_m)) / dist
            assert dist - 0.5 < t < dist
        assert abs(bx) < 9 and abs(by) < 6


def test_hidden_ball_is_hidden_from_a_robot_height_camera() -> None:
    from estimator.camera import make_camera
    from recorder.omni import OmniRenderer
    from recorder.world import World, field_spec

    seed = next(s for s in range(30) if make_scenario("random", s).notes["case"] == "hidden")
    sc = make_scenario("random", seed)
    omni = OmniRenderer(make_camera("fisheye"), face_px=256)
    with World(field_spec(sc.field)) as world:
        for tr in (*sc.robots, *sc.opponents):
            world.add_robot(tr.name, opponent=tr.opponent)
            world.set_robot_pose(tr.name, *tr.pose_at(0.0))
        world.set_ball(*sc.ball_xy_m)
        r1 = sc.robots[0]
        img = omni.render(world, r1.name, *r1.pose_at(0.0))
        hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
        assert not cv2.inRange(hsv, (4, 120, 60), (24, 255, 255)).any()
        world.set_ball(sc.ball_xy_m[0] + 1.0, sc.ball_xy_m[1] + 1.0)  # out from behind it
        img = omni.render(world, r1.name, *r1.pose_at(0.0))
        hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
        assert cv2.inRange(hsv, (4, 120, 60), (24, 255, 255)).any()


def test_rolling_lasts_ten_seconds_and_moves() -> None:
    sc = make_scenario("rolling", 1)
    assert sc.default_duration_s >= 10 and sc.default_rate_hz >= 5
    assert math.hypot(*sc.ball_velocity_mps) > 2.0
    assert sum(r.moving for r in sc.robots) == len(sc.robots)
    for r in sc.robots:  # drivers stay on the field for the whole default duration
        x, y, _ = r.pose_at(sc.default_duration_s)
        assert abs(x) < 9 and abs(y) < 6


def test_names_and_errors() -> None:
    assert set(SCENARIOS) == {*PAPER_SCENARIOS, "random", "rolling", "match", "lobs"}
    assert scenario_from_path("lobs-seed2.mcap") == "lobs"
    assert scenario_from_path("logs/scenario1.mcap") == "scenario1"
    assert scenario_from_path("rolling-seed3.mcap") == "rolling"
    assert scenario_from_path("random_2.mcap") == "random"
    assert scenario_from_path("scenario1.partial.mcap") == "scenario1"
    assert scenario_from_path("match-seed2.mcap") == "match"
    assert scenario_from_path("friendly.mcap") is None
    with pytest.raises(UnknownScenarioError, match="scenario1, scenario2"):
        make_scenario("scenario5")
    with pytest.raises(UsageError, match="exactly 3"):
        make_scenario("scenario2", robots=2)
    with pytest.raises(UsageError, match="between 1 and 8"):
        make_scenario("random", robots=0)
    with pytest.raises(UsageError, match="unknown field"):
        make_scenario("random", field="30x20")


def test_no_pybullet_on_import() -> None:
    code = ("import recorder, recorder.scenarios, recorder.field, recorder.errors, sys; "
            "print('pybullet' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "False"
