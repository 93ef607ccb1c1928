"""dsp-eval --suite match: captures as defined, scores pooled per fusion, a short suite end to
end (the same tables from the same logs, logs reused)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from replay.evaluate import cli as evaluate_cli
from replay.evaluate.match import (
    CLOCK_ROW,
    MATCH_FUSIONS,
    MatchOptions,
    MatchTask,
    Scores,
    captures,
    match_log_name,
    match_markdown,
    match_tasks,
    run_match_suite,
    score_match_log,
    score_rows,
)

DISTRACTOR = (9.7, 3.0)


def _step(x: float, y: float, truth: tuple[float, float] = (0.0, 0.0),
          **extra: Any) -> dict[str, Any]:
    err = ((x - truth[0]) ** 2 + (y - truth[1]) ** 2) ** 0.5
    return {"x_m": x, "y_m": y, "truth": {"x_m": truth[0], "y_m": truth[1]}, "error_m": err,
            **extra}


def test_a_capture_is_a_run_of_steps_on_a_distractor_far_from_the_ball() -> None:
    on = _step(9.6, 3.1)
    off = _step(0.01, 0.0)
    far_elsewhere = _step(5.0, 5.0)  # wrong, but not on a distractor
    assert captures([on, on, on], [DISTRACTOR]) == 1
    assert captures([on, on, off, on, on], [DISTRACTOR]) == 0  # runs of 2 only
    assert captures([on] * 3 + [off] + [on] * 4, [DISTRACTOR]) == 2
    assert captures([far_elsewhere] * 5, [DISTRACTOR]) == 0
    assert captures([on] * 5, []) == 0
    # the ball itself beside the distractor: on it, but not wrong
    near_ball = _step(9.6, 3.1, truth=(9.5, 3.0))
    assert captures([near_ball] * 5, [DISTRACTOR]) == 0


def test_scores_pool_errors_velocities_and_missing_steps() -> None:
    s = Scores(errors=[0.0, 0.03, 0.04], velocity_errors=[0.1, 0.2, 0.3], steps=4, missing=1)
    st = s.stats()
    assert st["rmse_m"] == pytest.approx(((0.03**2 + 0.04**2) / 3) ** 0.5)
    assert st["max_m"] == 0.04 and st["velocity_median_m_s"] == pytest.approx(0.2)
    assert (st["steps"], st["estimates"], st["missing"]) == (4, 3, 1)
    assert Scores().stats()["rmse_m"] is None


def test_log_names_carry_every_recording_option() -> None:
    o = MatchOptions()
    names = {match_log_name(1, "random", o), match_log_name(1, "sync", o),
             match_log_name(2, "random", o), match_log_name(1, "random", MatchOptions(rate_hz=10)),
             match_log_name(1, "random", MatchOptions(face_px=512)),
             match_log_name(1, "random", MatchOptions(distractors=0)),
             match_log_name(1, "random", MatchOptions(duration_s=5))}
    assert len(names) == 7
    tasks = match_tasks(Path("eval"), o, count=3, seed=5, sync_count=2)
    assert [(t.seed, t.phase) for t in tasks] == [(5, "random"), (6, "random"), (7, "random"),
                                                 (5, "sync"), (6, "sync")]


@pytest.fixture(scope="module")
def short_suite(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any], str]:
    """A 0.4 s match (4 frames per robot at 10 Hz), random and sync, small faces."""
    out = tmp_path_factory.mktemp("eval")
    options = MatchOptions(duration_s=0.4, rate_hz=10.0, face_px=256, renderer="tiny",
                           distractors=2)
    suite = run_match_suite(out, options, count=1, seed=2, sync_count=1)
    return out, suite.to_dict(), match_markdown(suite)


def test_short_suite_scores_every_fusion_both_phases_and_the_robots(
        short_suite: tuple[Path, dict[str, Any], str]) -> None:
    out, doc, text = short_suite
    assert sorted(p.name for p in out.glob("*.mcap")) == [
        "match-2-random-ideal-d2-0.4s-r10-f256.mcap", "match-2-sync-ideal-d2-0.4s-r10-f256.mcap"]
    assert set(doc["fused"]) == set(score_rows(MATCH_FUSIONS))
    assert list(score_rows(("track", "mean"))) == ["track", CLOCK_ROW, "mean"]
    for fusion, st in doc["fused"].items():
        assert st["estimates"] > 0 and st["rmse_m"] is not None, fusion
    assert set(doc["robots"]) == {"robot1", "robot2", "robot3"}
    assert doc["phase_comparison"]["seeds"] == [2]
    assert set(doc["phase_comparison"]["sync"]) == set(score_rows(MATCH_FUSIONS))
    assert "| mean |" in text and "random / sync" in text and f"| {CLOCK_ROW} |" in text
    # the clock's ticks: about 100 a second from the first image on, in either phase
    ticks = [doc["phase_comparison"][p][CLOCK_ROW]["steps"] for p in ("random", "sync")]
    assert all(30 <= n <= 40 for n in ticks) and abs(ticks[0] - ticks[1]) <= 5, ticks
    assert doc["fused"]["track"]["steps"] < ticks[0]  # the images' stamps: 12 of them


def test_cli_rewrites_the_same_tables_from_the_same_logs(
        short_suite: tuple[Path, dict[str, Any], str], capsys: pytest.CaptureFixture[str]
) -> None:
    out, doc, _ = short_suite
    before = {p: p.stat().st_mtime_ns for p in out.glob("*.mcap")}
    argv = ["--suite", "match", "--count", "1", "--seed", "2", "--duration", "0.4", "--rate",
            "10", "--face-px", "256", "--distractors", "2", "--renderer", "tiny",
            "--out-dir", str(out), "-q"]
    assert evaluate_cli.main(argv) == 0
    written = json.loads((out / "match-ideal-1-seed2.json").read_text())
    assert written == doc
    assert {p: p.stat().st_mtime_ns for p in out.glob("*.mcap")} == before  # reused


def test_cli_refuses_a_negative_sync_count(capsys: pytest.CaptureFixture[str]) -> None:
    assert evaluate_cli.main(["--suite", "match", "--sync-count", "-1"]) == 2
    assert "--sync-count -1" in capsys.readouterr().err


def test_the_match_suite_passes_hops_to_the_tracker_rows_only() -> None:
    lob = Path(__file__).resolve().parents[3] / "logs" / "golden" / "lobs.mcap"
    runs = {hops: score_match_log(MatchTask(1, "sync", lob, MatchOptions(hops=hops),
                                           fusions=("mean", "track")))
            for hops in (False, True)}
    assert runs[False].fused["mean"].errors == runs[True].fused["mean"].errors
    plain, hops = runs[False].fused["track"].errors, runs[True].fused["track"].errors
    assert max(hops) < max(plain) / 10, (max(plain), max(hops))  # the lob followed in 3-D


def test_dsp_eval_takes_hops_with_the_match_suite_only(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assert evaluate_cli.main(["--suite", "random", "--hops", "--out-dir", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "--hops" in err and "--suite match" in err and "Traceback" not in err
