"""Scenarios: who stands where, where the ball is and how everything moves.

``scenario1`` .. ``scenario4`` are the paper's (Section II.J, docs/method.md),
ball at rest. ``random`` draws robot poses and a ball from the seed, sometimes with the ball
hidden behind an opponent or out of robot 1's range. ``rolling`` rolls the ball across the
field while the robots drive. ``match`` is match play (:mod:`recorder.match`): robots driving
loops, the ball kicked and passed at 2-8 m/s, bouncing and slowing, some kicks lobs with
``lob_fraction``; ``lobs`` is the same play with every kick a lob (:mod:`recorder.flight`).
Any scene may have people, robot covers and light pools (:mod:`recorder.scenery`). Pure
data and arithmetic: no pybullet here.
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import asdict, dataclass
from dataclasses import field as dc_field
from pathlib import Path
from typing import Any

import numpy as np

from dsp.checks import MAX_DISTRACTORS, check_int
from dsp.contract import robot_name
from dsp.errors import UsageError
from recorder.errors import UnknownScenarioError
from recorder.field import field_spec
from recorder.flight import LOB_FLIGHT, FlightParams
from recorder.match import MATCH_POSE_RATE_HZ, LobKick, MatchPlay, PathTrack, match_parts
from recorder.scenery import Scenery, make_scenery

__all__ = [
    "PAPER_SCENARIOS",
    "SCENARIOS",
    "RobotTrack",
    "Scenario",
    "Track",
    "make_scenario",
    "scenario_from_path",
]

PAPER_SCENARIOS = ("scenario1", "scenario2", "scenario3", "scenario4")
SCENARIOS = (*PAPER_SCENARIOS, "random", "rolling", "match", "lobs")
"""Every scenario name ``make_scenario`` knows."""

_DEG = math.pi / 180.0
# (robot 1, robot 2, robot 3) as (x, y, yaw_rad), ball (x, y): docs/method.md's table
_PAPER: dict[str, tuple[tuple[tuple[float, float, float], ...], tuple[float, float]]] = {
    "scenario1": (((-8.5, 0.0, 0.0), (-2.0, 1.0, 0.0), (-2.0, -1.0, 0.0)), (0.0, 0.0)),
    "scenario2": (((-8.5, 0.0, 0.0), (-2.0, 1.0, 0.0), (-2.0, -1.0, 0.0)), (0.0, 3.0)),
    "scenario3": (((-8.5, 0.0, 0.0), (-2.0, 1.0, 0.0), (-2.0, -1.0, 0.0)), (0.0, -3.0)),
    "scenario4": (((-8.5, 0.0, 0.0), (-2.0, 3.0, -90 * _DEG), (-5.0, -2.0, 45 * _DEG)),
                  (0.0, 0.0)),
}


@dataclass(frozen=True)
class RobotTrack:
    """A robot's motion: start pose plus constant field-frame velocity and yaw rate."""

    name: str
    x_m: float
    y_m: float
    yaw_rad: float
    vx_mps: float = 0.0
    vy_mps: float = 0.0
    yaw_rate_radps: float = 0.0
    opponent: bool = False

    def pose_at(self, t_s: float) -> tuple[float, float, float]:
        """(x_m, y_m, yaw_rad) at sim time ``t_s``; yaw wrapped to (-pi, pi]."""
        yaw = self.yaw_rad + self.yaw_rate_radps * t_s
        yaw = math.atan2(math.sin(yaw), math.cos(yaw))
        return (self.x_m + self.vx_mps * t_s, self.y_m + self.vy_mps * t_s, yaw)

    @property
    def moving(self) -> bool:
        return bool(self.vx_mps or self.vy_mps or self.yaw_rate_radps)


Track = RobotTrack | PathTrack
"""A robot's motion: ``name``, ``opponent``, ``moving`` and ``pose_at(t_s)``."""
_OPTIONAL = ("play", "default_pose_rate_hz", "scenery", "flight")
"""Scenario fields left out of ``params()`` while None (the scenes before match play, lobs
and scenery)."""
MAX_PEOPLE = 30
MAX_LIGHT_POOLS = 8


@dataclass(frozen=True)
class Scenario:
    """A scene: our robots (with cameras), opponents (obstacles), the ball and defaults."""

    name: str
    seed: int
    field: str
    robots: tuple[Track, ...]
    ball_xy_m: tuple[float, float]
    ball_velocity_mps: tuple[float, float] = (0.0, 0.0)
    opponents: tuple[RobotTrack, ...] = ()
    default_duration_s: float = 1.0
    default_rate_hz: float = 5.0
    notes: dict[str, Any] = dc_field(default_factory=dict)
    play: MatchPlay | None = None
    """Kicks, distractors and walls (match play); None: the ball only rolls."""
    default_pose_rate_hz: float | None = None
    """Poses, /tf and truth per second; None: twice the camera rate."""
    scenery: Scenery | None = None
    """People, robot covers and light pools; None: none of them."""
    flight: FlightParams | None = None
    """The ball's physics in the air when some kick is a lob; None: no lobs."""

    def params(self) -> dict[str, Any]:
        """JSON-able parameters (for the log's dsp.scenario metadata)."""
        d = asdict(self)
        del d["name"], d["seed"]
        for key in _OPTIONAL:
            if d[key] is None:
                del d[key]
        return d


def _check_robots(name: str, robots: int | None, fixed: int | None = None) -> int:
    if fixed is not None:
        if robots not in (None, fixed):
            raise UsageError(f"{name} has exactly {fixed} robots; drop --robot-count {robots}")
        return fixed
    n = 3 if robots is None else robots
    if not 1 <= n <= 8:
        raise UsageError(f"--robot-count must be between 1 and 8, got {n}")
    return n


def make_scenario(name: str, seed: int = 0, *, robots: int | None = None,
                  field: str = "18x12", distractors: int = 0, lob_fraction: float = 0.0,
                  people: int = 0, covers: int = 0, light_pools: int = 0) -> Scenario:
    """The scenario ``name`` (one of ``SCENARIOS``) for a seed, robot count and field;
    ``distractors`` boxes of the ball's colour beside the field (match and lobs),
    ``lob_fraction`` of the kicks lobs (match); ``people`` in the ball's colour beside the
    field, ``covers`` robots dressed in it and ``light_pools`` (any scene)."""
    _check_extras(name, distractors, lob_fraction, people, light_pools)
    sc = _scene(name, seed, robots, field, distractors, lob_fraction)
    if sc.play is not None and any(isinstance(k, LobKick) for k in sc.play.kicks):
        sc = dataclasses.replace(sc, flight=LOB_FLIGHT)
    everyone = tuple(tr.name for tr in (*sc.robots, *sc.opponents))
    if not 0 <= covers <= len(everyone):
        raise UsageError(f"--covers {covers}: give a whole number in [0, {len(everyone)}] "
                         f"(the robots in {name})")
    if people or covers or light_pools:
        spec = field_spec(field)
        sc = dataclasses.replace(sc, scenery=make_scenery(
            seed, people=people, covers=covers, light_pools=light_pools, robots=everyone,
            hl=spec.half_length_m, hw=spec.half_width_m, border=spec.border_m))
    return sc


def _check_extras(name: str, distractors: int, lob_fraction: float, people: int,
                  light_pools: int) -> None:
    if distractors and name not in ("match", "lobs"):
        raise UsageError(f"--distractors is for the match scenario (and lobs), not {name}")
    check_int("--distractors", distractors, low=0, high=MAX_DISTRACTORS)
    if lob_fraction and name != "match":
        raise UsageError(f"--lob-fraction is for the match scenario (lobs kicks only lobs), "
                         f"not {name}")
    if not (math.isfinite(lob_fraction) and 0 <= lob_fraction <= 1):
        raise UsageError(f"--lob-fraction {lob_fraction}: give a finite number in [0, 1]")
    if not 0 <= people <= MAX_PEOPLE:
        raise UsageError(f"--people {people}: give a whole number in [0, {MAX_PEOPLE}]")
    if not 0 <= light_pools <= MAX_LIGHT_POOLS:
        raise UsageError(f"--light-pools {light_pools}: give a whole number in "
                         f"[0, {MAX_LIGHT_POOLS}]")


def _scene(name: str, seed: int, robots: int | None, field: str, distractors: int,
           lob_fraction: float) -> Scenario:
    spec = field_spec(field)
    if name in ("match", "lobs"):
        paths, ball, play = match_parts(seed, _check_robots(name, robots), spec.half_length_m,
                                        spec.half_width_m, spec.border_m, distractors,
                                        lob_fraction=lob_fraction, lobs_only=name == "lobs")
        return Scenario(name, seed, field, tuple(paths), ball, play=play,
                        default_duration_s=10.0 if name == "match" else 8.0,
                        default_rate_hz=20.0, default_pose_rate_hz=MATCH_POSE_RATE_HZ)
    if name in _PAPER:
        _check_robots(name, robots, 3)
        poses, ball = _PAPER[name]
        tracks = tuple(RobotTrack(robot_name(i + 1), *pose) for i, pose in enumerate(poses))
        return Scenario(name, seed, field, tracks, ball)
    if name == "random":
        return _random(seed, _check_robots(name, robots), field, spec.half_length_m,
                       spec.half_width_m)
    if name == "rolling":
        return _rolling(seed, _check_robots(name, robots), field, spec.half_length_m,
                        spec.half_width_m)
    raise UnknownScenarioError(
        f"unknown scenario {name!r}; choose one of: {', '.join(SCENARIOS)}"
    )


def _free_spot(rng: np.random.Generator, hl: float, hw: float, taken: list[tuple[float, float]],
               clearance_m: float) -> tuple[float, float]:
    for _ in range(1000):
        x = float(rng.uniform(-hl + 0.5, hl - 0.5))
        y = float(rng.uniform(-hw + 0.5, hw - 0.5))
        if all(math.hypot(x - a, y - b) >= clearance_m for a, b in taken):
            return (round(x, 3), round(y, 3))
    raise UsageError("could not place every robot apart on this field; use a smaller --robot-count")


def _random(seed: int, n: int, field: str, hl: float, hw: float) -> Scenario:
    rng = np.random.default_rng(seed)
    taken: list[tuple[float, float]] = []
    tracks = []
    for i in range(n):
        x, y = _free_spot(rng, hl, hw, taken, 1.2)
        taken.append((x, y))
        tracks.append(RobotTrack(robot_name(i + 1), x, y, round(float(rng.uniform(-math.pi,
                                                                                     math.pi)), 4)))
    case = str(rng.choice(["visible", "visible", "hidden", "out_of_range"]))
    r1 = tracks[0]
    opponents: list[RobotTrack] = []
    ball = (0.0, 0.0)
    for _ in range(1000):
        if case == "hidden":
            # ball 3-6 m from robot 1, an opponent just in front of it on robot 1's line
            d, a = float(rng.uniform(3.0, 6.0)), float(rng.uniform(-math.pi, math.pi))
            ball = (r1.x_m + d * math.cos(a), r1.y_m + d * math.sin(a))
            blocker = (r1.x_m + (d - 0.45) * math.cos(a), r1.y_m + (d - 0.45) * math.sin(a))
            spots = [ball, blocker]
        elif case == "out_of_range":
            ball = (float(rng.uniform(-hl + 0.3, hl - 0.3)), float(rng.uniform(-hw + 0.3,
                                                                             hw - 0.3)))
            spots = [ball]
            if math.hypot(ball[0] - r1.x_m, ball[1] - r1.y_m) < 9.5:
                continue
        else:
            ball = (float(rng.uniform(-hl + 0.3, hl - 0.3)), float(rng.uniform(-hw + 0.3,
                                                                             hw - 0.3)))
            spots = [ball]
        inside = all(abs(x) <= hl - 0.3 and abs(y) <= hw - 0.3 for x, y in spots)
        clear = all(math.hypot(x - a, y - b) >= 0.7 for x, y in spots for a, b in taken)
        if inside and clear:
            break
    else:
        case = "visible"
        ball = _free_spot(rng, hl, hw, taken, 0.7)
    ball = (round(ball[0], 3), round(ball[1], 3))
    if case == "hidden":
        ang = math.atan2(ball[1] - r1.y_m, ball[0] - r1.x_m)
        bx, by = ball[0] - 0.45 * math.cos(ang), ball[1] - 0.45 * math.sin(ang)
        opponents.append(RobotTrack("opponent1", round(bx, 3), round(by, 3), round(ang, 4),
                                    opponent=True))
    return Scenario("random", seed, field, tuple(tracks), ball, opponents=tuple(opponents),
                    notes={"case": case, "about": "case refers to robot1's view"})


def _rolling(seed: int, n: int, field: str, hl: float, hw: float) -> Scenario:
    rng = np.random.default_rng(seed)
    starts = [(-hl + 0.5, 0.0, 0.0), (-2.0, 1.0, 0.0), (-2.0, -1.0, 0.0),
              (-5.0, 2.0, 0.0), (-5.0, -2.0, 0.0), (2.0, 3.0, math.pi),
              (2.0, -3.0, math.pi), (4.0, 0.0, math.pi)]
    tracks = []
    for i in range(n):
        x, y, yaw = starts[i]
        if i == 0:  # the goalkeeper shuffles along its line and turns a little
            tracks.append(RobotTrack(robot_name(1), x, y, yaw, vy_mps=0.15,
                                     yaw_rate_radps=0.05))
            continue
        speed = float(rng.uniform(0.3, 0.6))
        head = yaw + float(rng.uniform(-0.4, 0.4))
        tracks.append(RobotTrack(robot_name(i + 1), x, y, round(head, 4),
                                 round(speed * math.cos(head), 4),
                                 round(speed * math.sin(head), 4),
                                 round(float(rng.uniform(-0.15, 0.15)), 4)))
    # the ball enters from the far half, rolls diagonally across the centre
    bx, by = round(float(rng.uniform(3.0, 5.0)), 3), round(float(rng.uniform(-hw + 1.0,
                                                                             -hw + 2.5)), 3)
    speed = float(rng.uniform(2.5, 3.5))
    ang = math.atan2(1.0 - by, -2.0 - bx) + float(rng.uniform(-0.15, 0.15))
    vel = (round(speed * math.cos(ang), 4), round(speed * math.sin(ang), 4))
    return Scenario("rolling", seed, field, tuple(tracks), (bx, by), ball_velocity_mps=vel,
                    default_duration_s=12.0, default_rate_hz=10.0)


def scenario_from_path(path: str | Path) -> str | None:
    """The scenario a log's file name names: ``scenario1.mcap`` or ``rolling-seed3.mcap``."""
    stem = Path(path).name
    for suffix in (".mcap", ".partial"):
        if stem.endswith(suffix):
            stem = stem[: -len(suffix)]
    if stem in SCENARIOS:
        return stem
    head = re.split(r"[-_.]", stem, maxsplit=1)[0]
    return head if head in SCENARIOS else None
