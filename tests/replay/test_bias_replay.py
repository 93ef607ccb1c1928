"""``--localise ball`` in a replay: robots whose believed poses are off are corrected by the
biases the tracker's residuals give, so their estimates come to agree; the corrected pose is
reported beside the believed one; same bytes whatever the thread count; only with the
tracker."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from synthetic import write_log

from dsp.errors import UsageError
from replay import ReplayOptions, ReplaySummary, replay
from replay.evaluate.match import CLOCK_ROW, score_rows
from replay.evaluate.scenes import configs_for
from replay.sinks import ResultsCollector

ROBOTS = {"robot1": (-4.0, 1.0, 0.3), "robot2": (-1.0, -2.5, 2.0), "robot3": (2.5, 2.0, -2.4)}
BALL = (0.2, 0.4)
BIAS_M = {"robot1": (0.12, -0.05), "robot2": (-0.06, 0.04), "robot3": (0.0, 0.0)}


@pytest.fixture(scope="module")
def biased_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("bias") / "biased.mcap"
    write_log(path, robots=ROBOTS, ball=BALL, duration_s=3.0, image_hz=10.0, pose_hz=20.0,
              pose_bias_m=BIAS_M)
    return path


def _replay(log: Path, **kw: object) -> tuple[ResultsCollector, ReplaySummary]:
    col = ResultsCollector()
    summary = replay(log, ReplayOptions(progress=False, quiet=True, **kw),  # type: ignore[arg-type]
                     sinks=[col])
    return col, summary


def _spread(frames: list[dict[str, object]], robot: str) -> float:
    """How far the robot's last estimate is from robot3's (whose pose is exact)."""
    last = {f["robot"]: f["estimate"] for f in frames if f.get("estimate")}
    a, b = last[robot], last["robot3"]
    return math.hypot(a["x_m"] - b["x_m"], a["y_m"] - b["y_m"])  # type: ignore[index]


def test_the_robots_come_to_agree_and_the_correction_is_reported(biased_log: Path) -> None:
    believed, believed_summary = _replay(biased_log, threads=1)
    ball, ball_summary = _replay(biased_log, localise="ball", threads=1)
    assert len(ball.frames) == len(believed.frames) == 93
    for robot in ("robot1", "robot2"):
        before, after = _spread(believed.frames, robot), _spread(ball.frames, robot)
        assert before > 0.06 and after < before / 3, (robot, before, after)
    last = [f for f in ball.frames if f["robot"] == "robot1"][-1]
    loc, pose = last["localisation"], last["pose"]
    assert loc["source"] == "ball" and loc["status"] == "ok"
    # what the ball shows of robot1's pose: its bias relative to the others', seen along
    # the line to the ball (a still ball cannot tell a shift from a turn)
    assert math.hypot(loc["x_m"] - pose["x_m"], loc["y_m"] - pose["y_m"]) > 0.02
    first = next(f for f in ball.frames if f["robot"] == "robot1")
    assert first["localisation"]["x_m"] == first["pose"]["x_m"]  # nothing learned yet
    # the tracker keeps all three robots (the biases' uncertainty widens its gate while
    # they are learned), so the fused ball is the robots' agreed one
    assert ball_summary.fused.rmse_m < 0.1 < believed_summary.fused.rmse_m
    assert set(ball.fused[-1]["fused_robots"]) == {"robot1", "robot2", "robot3"}


def test_same_bytes_whatever_the_thread_count(biased_log: Path, tmp_path: Path) -> None:
    outs = []
    for threads in (1, 3):
        out = tmp_path / f"r{threads}.json"
        replay(biased_log, ReplayOptions(localise="ball", threads=threads, out=out,
                                         progress=False, quiet=True))
        outs.append(out.read_bytes())
    assert outs[0] == outs[1]


def test_only_with_the_tracker() -> None:
    with pytest.raises(UsageError, match=r"--localise ball .* needs --fusion track"):
        ReplayOptions(localise="ball", fusion="mean")


def test_suites_replay_only_the_tracker_with_it() -> None:
    assert score_rows(("mean", "track"), "ball") == (
        "mean", "track", CLOCK_ROW, "track + ball", f"{CLOCK_ROW} + ball")
    assert score_rows(("mean", "track"), "lines")[-3:] == (
        "mean + lines", "track + lines", f"{CLOCK_ROW} + lines")
    extra = configs_for("ball")[len(configs_for()):]
    assert [c.label for c in extra] == ["corrected/track + ball"]

