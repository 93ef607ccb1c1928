"""scripts/shared_error.py: the part of the robots' pose errors they share, which the ball
cannot show."""

from __future__ import annotations

import importlib.util
import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "scripts" / "shared_error.py"
_spec = importlib.util.spec_from_file_location("shared_error", SCRIPT)
assert _spec is not None and _spec.loader is not None
shared_error = importlib.util.module_from_spec(_spec)
sys.modules["shared_error"] = shared_error  # dataclasses look their module up by name
_spec.loader.exec_module(shared_error)

MS = 1_000_000
BALL = {"x_m": 0.0, "y_m": 0.0}
TRUE = {"robot1": (-4.0, 0.0, 0.0), "robot2": (4.0, 0.0, math.pi), "robot3": (0.0, -8.0, 1.0)}


def _pose(x: float, y: float, yaw: float) -> dict[str, float]:
    return {"x_m": x, "y_m": y, "yaw_rad": yaw}


def _docs(believed: dict[str, tuple[float, float, float]],
          corrected: dict[str, tuple[float, float, float]] | None = None
          ) -> tuple[dict[str, Any], dict[str, Any]]:
    """Each robot's image in turn every 10 ms for 0.3 s, each a fused step that took it."""
    frames, truth_frames, fused = [], [], []
    robots = sorted(believed)
    for k in range(30):
        robot, stamp = robots[k % len(robots)], k * 10 * MS
        frame: dict[str, Any] = {"robot": robot, "stamp_ns": stamp,
                                 "pose": _pose(*believed[robot]), "truth": BALL}
        if corrected is not None:
            frame["localisation"] = {"source": "lines", **_pose(*corrected[robot])}
        frames.append(frame)
        truth_frames.append({"robot": robot, "stamp_ns": stamp, "pose": _pose(*TRUE[robot]),
                             "truth": BALL})
        fused.append({"stamp_ns": stamp, "error_m": 0.02, "fused_robots": [robot]})
    doc = {"format": "dsp-replay-results", "frames": frames, "fused": fused}
    return doc, {"format": "dsp-replay-results", "frames": truth_frames, "fused": fused}


def _shares(believed: dict[str, tuple[float, float, float]],
            corrected: dict[str, tuple[float, float, float]] | None = None) -> Any:
    doc, truth = _docs(believed, corrected)
    return shared_error.shares(doc, truth, window_ns=150 * MS, sigma_m=0.05,
                               sigma_rad=math.radians(1.0))


def _rms(values: list[float]) -> float:
    return math.sqrt(sum(v * v for v in values) / len(values))


def test_a_yaw_error_moves_the_ball_by_its_range() -> None:
    # 1 deg of yaw at 4 m: 4 sin(1 deg) across, 4 (1 - cos(1 deg)) along
    d = shared_error.offset(_pose(-4.0, 0.0, math.radians(1.0)), _pose(-4.0, 0.0, 0.0), BALL)
    assert (d.dx, d.dy) == pytest.approx((4.0 * (math.cos(math.radians(1)) - 1),
                                          4.0 * math.sin(math.radians(1.0))))
    assert d.range_m == pytest.approx(4.0)
    moved = shared_error.offset(_pose(-3.9, 0.05, 0.0), _pose(-4.0, 0.0, 0.0), BALL)
    assert (moved.dx, moved.dy) == pytest.approx((0.1, 0.05))


def test_what_every_robot_gets_wrong_is_shared_what_differs_is_not() -> None:
    same = {r: (x + 0.05, y, yaw) for r, (x, y, yaw) in TRUE.items()}
    s = _shares(same)
    assert _rms(s.own["believed"]) == pytest.approx(0.05)
    assert _rms(s.shared["believed"]) == pytest.approx(0.05)
    # two robots opposite each other off by +-0.05 m: each 0.05 m, shared nothing
    apart = {"robot1": (-3.95, 0.0, 0.0), "robot2": (3.95, 0.0, math.pi)}
    s = _shares(apart)
    assert _rms(s.own["believed"]) == pytest.approx(0.05)
    assert max(s.shared["believed"][1:]) == pytest.approx(0.0, abs=1e-12)
    assert s.own["corrected"] == [] and s.shared["corrected"] == []


def test_the_shared_part_is_weighted_by_the_prior_and_the_corrected_poses_are_scored() -> None:
    # robot3 8 m away is off by 1 deg (0.14 m of ball), the two at 4 m are right: its share
    # is its weight, 1 / (0.05^2 + (8 sigma_yaw)^2) against 1 / (0.05^2 + (4 sigma_yaw)^2)
    believed = dict(TRUE)
    believed["robot3"] = (0.0, -8.0, 1.0 + math.radians(1.0))
    corrected = dict(TRUE)
    s = _shares(believed, corrected)
    w3 = 1.0 / (0.05 ** 2 + (8 * math.radians(1.0)) ** 2)
    w1 = 1.0 / (0.05 ** 2 + (4 * math.radians(1.0)) ** 2)
    off = 8.0 * 2.0 * math.sin(math.radians(0.5))  # the chord of 1 deg at 8 m
    assert s.shared["believed"][-1] == pytest.approx(off * w3 / (w3 + 2 * w1))
    assert max(s.own["corrected"]) == pytest.approx(0.0, abs=1e-12)
    assert s.row("x").startswith("| x | 30 | 0.0200 | ")


def test_bad_input_is_one_line(tmp_path: Path) -> None:
    doc, truth = _docs(dict(TRUE))
    good, other = tmp_path / "r.json", tmp_path / "t.json"
    good.write_text(json.dumps(doc), encoding="utf-8")
    other.write_text(json.dumps(truth), encoding="utf-8")
    ok = subprocess.run([sys.executable, str(SCRIPT), str(good), str(other)],
                        capture_output=True, text=True, check=False)
    assert ok.returncode == 0 and ok.stdout.count("\n") == 3, ok.stderr
    (tmp_path / "bad.json").write_text("{}", encoding="utf-8")
    (tmp_path / "text.json").write_text("not json", encoding="utf-8")
    broken = dict(doc, frames=[{"robot": "robot1", "stamp_ns": "soon", "pose": {}}])
    (tmp_path / "broken.json").write_text(json.dumps(broken), encoding="utf-8")
    for args, says in (([str(tmp_path / "missing.json"), str(other)], "missing.json"),
                       ([str(tmp_path / "bad.json"), str(other)], "not a dsp-replay results"),
                       ([str(tmp_path / "text.json"), str(other)], "not JSON"),
                       ([str(tmp_path / "broken.json"), str(other)], "lacks a field"),
                       ([str(tmp_path), str(other)], "is a folder"),
                       ([str(good)], "give each results file")):
        run = subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True,
                             text=True, check=False)
        assert run.returncode in (1, 2) and "Traceback" not in run.stderr
        assert says in run.stderr and run.stderr.count("\n") <= 3, run.stderr
        assert run.stdout == ""  # no table begun before the error


def _ring(turn: float = 0.0) -> dict[str, tuple[float, float, float]]:
    """Three robots 4 m round the ball at (0, 0), 120 deg apart, each facing it."""
    out = {}
    for i, a in enumerate((90.0, 210.0, 330.0)):
        r = math.radians(a)
        out[f"robot{i + 1}"] = (4.0 * math.cos(r), 4.0 * math.sin(r), r + math.pi + turn)
    return out


def _gauge_of(believed: dict[str, tuple[float, float, float]],
              true: dict[str, tuple[float, float, float]],
              true_replay_error: tuple[float, float] | None = None) -> Any:
    doc, truth = _docs(believed)
    for f in truth["frames"]:
        f["pose"] = _pose(*true[f["robot"]])
    if true_replay_error is not None:
        truth["fused"] = [dict(s, x_m=BALL["x_m"] + true_replay_error[0], truth=BALL,
                               y_m=BALL["y_m"] + true_replay_error[1]) for s in doc["fused"]]
    for s in doc["fused"]:
        s["truth"] = BALL
    return shared_error.shares(doc, truth, window_ns=150 * MS, sigma_m=0.05,
                               sigma_rad=math.radians(1.0))


def test_one_robot_turned_alone_is_shared_in_the_mean_but_not_in_the_gauge() -> None:
    # robot1 off by 1 deg, the others right: as the ball moves round it its yaw shows, so
    # nothing of it is the floor, while the weighted mean keeps a third of its 7 cm
    true = _ring()
    believed = dict(true)
    x, y, yaw = true["robot1"]
    believed["robot1"] = (x, y, yaw + math.radians(1.0))
    s = _gauge_of(believed, true)
    chord = 4.0 * 2.0 * math.sin(math.radians(0.5))
    assert s.shared["believed"][-1] == pytest.approx(chord / 3.0)
    assert s.gauge["believed"][-1] == pytest.approx(0.0, abs=1e-12)
    # robot1 alone at the first step: all of it (to first order in the turn)
    assert s.gauge["believed"][0] == pytest.approx(4.0 * math.radians(1.0))


def test_the_whole_picture_moved_together_is_all_floor() -> None:
    # every robot's pose turned 1 deg about (1, 2) and shifted by (3, -2) cm: each robot's
    # ball moves as the picture does, which no comparison of them shows
    phi, q, c = math.radians(1.0), (1.0, 2.0), (0.03, -0.02)

    def moved(x: float, y: float) -> tuple[float, float]:
        dx, dy = x - q[0], y - q[1]
        return (q[0] + math.cos(phi) * dx - math.sin(phi) * dy + c[0],
                q[1] + math.sin(phi) * dx + math.cos(phi) * dy + c[1])

    true = _ring()
    believed = {r: (*moved(x, y), yaw + phi) for r, (x, y, yaw) in true.items()}
    bx, by = moved(BALL["x_m"], BALL["y_m"])
    s = _gauge_of(believed, true, true_replay_error=(0.01, 0.0))
    # first order in phi
    assert s.gauge["believed"][-1] == pytest.approx(math.hypot(bx, by), abs=2e-4)
    assert s.shared["believed"][-1] == pytest.approx(math.hypot(bx, by), abs=1e-9)
    # the floor: the true-pose replay's error moved by the gauge
    assert s.floor[-1] == pytest.approx(math.hypot(bx + 0.01, by), abs=2e-4)
    assert "| 0.0200 |" in s.row("x") and s.row("x").endswith("(30) |")


def test_the_robots_spread_pins_part_of_a_turn_they_share() -> None:
    # all three turned by 1 deg, none moved: a turn of the whole picture would have moved
    # them 7 cm each, which their positions' prior (5 cm) makes unlikely; so the gauge
    # keeps a part of the turn, not all, and none of it reaches the ball at their centre
    true = _ring()
    s = _gauge_of(_ring(math.radians(1.0)), true)
    assert s.gauge["believed"][-1] == pytest.approx(0.0, abs=1e-12)
    assert s.shared["believed"][-1] == pytest.approx(0.0, abs=1e-12)
    # seen from a ball off their centre, part of it stays: less than a whole turn gives
    off = shared_error.gauge([shared_error.PoseError(0.0, 0.0, math.radians(1.0), x, y)
                              for x, y, _ in true.values()], (2.0, 0.0), sigma_m=0.05,
                             sigma_rad=math.radians(1.0))
    whole = 2.0 * math.radians(1.0)  # the ball 2 m from the turn's centre
    assert 0.1 * whole < math.hypot(*off) < 0.9 * whole
