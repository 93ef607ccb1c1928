"""dsp-eval --suite lobs --camera-phase: the phase reaches the recorder (free-running by
default, a set of logs at 20 Hz and one at 40 Hz), and free-running lobs are scored by
their own rule (the ballistic fusion's steps that two or more robots saw within 0.1 s),
said in the tables."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest

from estimator.constants import BALL_RADIUS_M
from replay.evaluate import cli as evaluate_cli
from replay.evaluate import lobs
from replay.evaluate.lobs import FLIGHT_ABOVE_M, LobsOptions
from replay.evaluate.lobs_free import SEEN_WITHIN_NS, score_free_running

GOLDEN_LOBS = Path(__file__).resolve().parents[3] / "logs" / "golden" / "lobs.mcap"
MS = 1_000_000


def _step(t_ms: int, z_true: float | None, z: float, err: float) -> dict[str, Any]:
    return {"stamp_ns": t_ms * MS, "z_m": z, "truth_z_m": z_true, "error_3d_m": err,
            "landing": None}


def _frame(t_ms: int, robot: str, status: str = "ok") -> dict[str, Any]:
    return {"stamp_ns": t_ms * MS, "robot": robot, "status": status}


def test_free_running_steps_count_when_two_robots_saw_within_a_camera_period() -> None:
    frames = [_frame(0, "r1"), _frame(50, "r2"), _frame(140, "r1"),
              _frame(200, "r2", status="none"), _frame(300, "r1"), _frame(330, "r1")]
    steps = [
        _step(50, 1.5, 1.56, 0.07),   # r1 at 0, r2 at 50: counted
        _step(100, 1.8, 1.7, 0.2),    # r1 at 0 is exactly 0.1 s before: r2 alone
        _step(140, 2.0, 2.03, 0.05),  # r2 at 50, r1 at 140: counted
        _step(200, 1.9, 1.0, 1.0),    # r2's frame at 200 saw nothing: r1 alone
        _step(330, 1.0, 1.2, 0.3),    # r1 twice: one robot
        _step(400, BALL_RADIUS_M, BALL_RADIUS_M, 0.01),  # on the ground: not in flight
        _step(410, None, 1.0, 0.5),   # no truth
    ]
    s = score_free_running(steps, frames, [], FLIGHT_ABOVE_M)
    assert SEEN_WITHIN_NS == 100 * MS
    assert s.flight_steps == 5
    assert s.flight_3d == [0.07, 0.05]
    assert s.flight_z == [pytest.approx(0.06), pytest.approx(0.03)]
    assert s.landings == 0 and s.landing_errors == []


class _StandIn:
    """Records nothing: copies the golden lob in and notes the options it was asked for."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, int, LobsOptions]] = []

    def __call__(self, path: Path, seed: int, options: LobsOptions) -> None:
        self.calls.append((path.name, seed, options))
        shutil.copyfile(GOLDEN_LOBS, path)


def _run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, *extra: str) -> _StandIn:
    stand_in = _StandIn()
    monkeypatch.setattr(lobs, "_record", stand_in)
    argv = ["--suite", "lobs", "--count", "1", "--seed", "5", "--out-dir", str(tmp_path),
            "-q", *extra]
    assert evaluate_cli.main(argv) == 0
    return stand_in


def test_camera_phase_random_reaches_the_recorder_and_names_its_rule(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    stand_in = _run(tmp_path, monkeypatch, "--camera-phase", "random", "--rate", "10")
    [(name, seed, options)] = stand_in.calls
    assert options.camera_phase == "random" and seed == 5
    assert name == "lobs-5-random-ideal-4s-r10.mcap"
    doc = json.loads((tmp_path / "lobs-ideal-random-1-seed5.json").read_text())
    assert doc["camera_phase"] == "random"
    assert "two or more robots saw within the last 0.1 s" in doc["rule"]
    assert "never give two rays of one instant" in doc["triangulate"]
    flight = doc["pooled"]["flight"]
    assert set(flight) == {"steps", "seen_by_two", "rmse_3d_m", "median_3d_error_m",
                           "median_abs_z_error_m"}
    assert "ground" not in doc["pooled"]  # no triangulate or ground-plane rows
    table = (tmp_path / "lobs-ideal-random-1-seed5.md").read_text()
    assert "free-running cameras (`--camera-phase random`" in table
    assert "No `triangulate` rows" in table and "crossed" not in table


def test_the_default_is_free_running_at_20_and_40_hz(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """No phase nor rate asked: free-running cameras, a set of logs at each rate, each
    scored by the free-running rule under its rate."""
    stand_in = _run(tmp_path, monkeypatch)
    assert [(name, o.camera_phase, o.rate_hz) for name, _, o in stand_in.calls] == [
        ("lobs-5-random-ideal-4s-r20.mcap", "random", 20.0),
        ("lobs-5-random-ideal-4s-r40.mcap", "random", 40.0)]
    doc = json.loads((tmp_path / "lobs-ideal-random-1-seed5.json").read_text())
    assert [(s["rate_hz"], s["camera_phase"]) for s in doc["sets"]] == [
        (20.0, "random"), (40.0, "random")]
    assert all("seen_by_two" in s["pooled"]["flight"] for s in doc["sets"])
    table = (tmp_path / "lobs-ideal-random-1-seed5.md").read_text()
    assert table.index("### 20 Hz") < table.index("### 40 Hz")
    assert table.count("free-running cameras (`--camera-phase random`") == 2


def test_the_sync_phase_records_in_sync_and_keeps_its_tables(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    stand_in = _run(tmp_path, monkeypatch, "--camera-phase", "sync")
    [(name, _, options)] = stand_in.calls
    assert options.camera_phase == "sync" and name == "lobs-5-sync-ideal-4s-r10.mcap"
    doc = json.loads((tmp_path / "lobs-ideal-1-seed5.json").read_text())
    assert "rule" not in doc and "camera_phase" not in doc
    assert set(doc["pooled"]) == {"flight", "ground", "robots_flight_rmse_3d_m", "track"}
    assert "cameras in sync" in (tmp_path / "lobs-ideal-1-seed5.md").read_text()


def test_camera_phase_goes_with_the_lobs_suite_only(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert evaluate_cli.main(["--suite", "match", "--camera-phase", "random"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--camera-phase goes with --suite lobs" in err


def test_width_range_reaches_every_replay_and_names_the_tables(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The same log (its name says no width), every replay asked for the width, the
    tables named and noted after it."""
    asked: list[tuple[str, bool]] = []
    real_replay = lobs.replay

    def spy(log: Path, options: Any, **kwargs: Any) -> Any:
        asked.append((options.fusion_method, options.width_range))
        return real_replay(log, options, **kwargs)

    monkeypatch.setattr(lobs, "replay", spy)
    stand_in = _run(tmp_path, monkeypatch, "--width-range", "--camera-phase", "sync")
    [(name, _, options)] = stand_in.calls
    assert name == "lobs-5-sync-ideal-4s-r10.mcap" and options.width_range
    assert sorted(asked) == [("ballistic", True), ("robust", True), ("triangulate", True)]
    doc = json.loads((tmp_path / "lobs-ideal-width-1-seed5.json").read_text())
    assert doc["width_range"] is True
    assert "`--width-range`" in (tmp_path / "lobs-ideal-width-1-seed5.md").read_text()


def test_width_range_goes_with_the_lobs_suite_only(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert evaluate_cli.main(["--suite", "match", "--width-range"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--width-range goes with --suite lobs" in err
