"""A recorder for the evaluation and batch tests: synthetic logs of the paper's scenes and of
seeded random scenes (the paper's ideal camera, no pybullet)."""

from __future__ import annotations

import math
import random
from pathlib import Path

from synthetic import write_log

from replay.evaluate import PAPER_TRUTH

# docs/method.md: the paper's four scenarios (robot x, y, yaw; ball)
PAPER_ROBOTS = {
    "scenario1": {"robot1": (-8.5, 0.0, 0.0), "robot2": (-2.0, 1.0, 0.0),
                  "robot3": (-2.0, -1.0, 0.0)},
    "scenario4": {"robot1": (-8.5, 0.0, 0.0), "robot2": (-2.0, 3.0, -math.pi / 2),
                  "robot3": (-5.0, -2.0, math.pi / 4)},
}
PAPER_ROBOTS["scenario2"] = PAPER_ROBOTS["scenario3"] = PAPER_ROBOTS["scenario1"]


class FakeRecorder:
    """Writes synthetic logs (the paper's ideal camera, no pybullet) and counts calls."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, int]] = []

    def __call__(self, path: Path, scenario: str, seed: int) -> None:
        self.calls.append((scenario, seed))
        if scenario == "random":
            rng = random.Random(seed)
            ball = (rng.uniform(-4, 4), rng.uniform(-3, 3))
            robots = {f"robot{i}": (ball[0] + rng.uniform(-6, 6), ball[1] + rng.uniform(-5, 5),
                                    rng.uniform(-math.pi, math.pi)) for i in (1, 2, 3)}
            if seed % 2:  # odd seeds: only robot1 near enough for "dual sight"
                robots["robot2"] = (ball[0] - 9.5, ball[1], 0.0)
                robots["robot3"] = (ball[0], ball[1] - 9.8, math.pi / 2)
        else:
            robots, ball = PAPER_ROBOTS[scenario], PAPER_TRUTH[scenario]
        write_log(path, robots=robots, ball=ball, duration_s=0.3, image_hz=10.0,
                  scenario=(scenario, seed))
