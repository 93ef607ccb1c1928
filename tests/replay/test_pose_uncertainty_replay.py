"""``--pose-uncertainty``: each robot's estimate carries its pose's covariance (the log's
PoseWithCovarianceStamped, the line fit's, else ``--pose-sigma``'s) and the fusion weighs it
so; ``dsp-eval --localise lines`` scores the believed and the corrected poses side by side."""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from synthetic import write_log

from dsp import contract
from replay import ReplayOptions, replay
from replay.cli import main
from replay.evaluate import cli as evaluate_cli
from replay.evaluate.match import (
    LINES_SUFFIX,
    MatchOptions,
    MatchSuite,
    MatchTask,
    score_match_log,
)
from replay.evaluate.scenes import Config, configs_for
from replay.evaluate.suites import PAPER_SCENARIOS, PAPER_TRUTH, PaperSuite, ScenarioScore
from replay.log import BadMessage, PoseMessage
from replay.log.messages import convert, pose_covariance
from replay.sinks import ResultsCollector
from replay.sync import History, interpolate_pose

# robot1 far from the ball, its heading 3 deg off: its estimate is ~0.3 m off across its
# bearing; robot2 and robot3 near and exact
ROBOTS = {"robot1": (-6.0, 0.5, 0.0), "robot2": (-1.5, -1.0, 1.0), "robot3": (1.0, 1.5, -2.0)}
BALL = (0.3, 0.2)
# on a carpet with lines: every robot's believed pose off, which the lines correct
CARPET_ROBOTS = {"robot1": (-4.0, 1.0, 0.3), "robot2": (-1.0, -2.5, 2.0),
                 "robot3": (2.5, 2.0, -2.4)}
CARPET_BALL = (0.2, 0.4)
BIAS_M = {"robot1": (0.07, -0.05), "robot2": (-0.06, 0.04), "robot3": (0.05, 0.06)}
BIAS_YAW = {"robot1": math.radians(1.2), "robot2": math.radians(-0.9), "robot3": 0.0}


def cov36(sigma_m: float, sigma_yaw_deg: float) -> list[float]:
    c = [0.0] * 36
    c[0] = c[7] = sigma_m**2
    c[35] = math.radians(sigma_yaw_deg) ** 2
    return c


def test_the_xy_yaw_block_of_a_ros_covariance() -> None:
    c = [float(i + 1) for i in range(36)]
    c[0] = c[7] = c[35] = 4.0
    assert pose_covariance(c) == (4.0, 2.0, 6.0, 7.0, 4.0, 12.0, 31.0, 32.0, 4.0)
    assert pose_covariance([0.0] * 36) is None  # ROS: unknown
    for bad, why in (([1.0] * 35, "35 values"), ([-1.0] + [0.0] * 35, "negative"),
                     ([math.inf] * 36, "non-finite")):
        with pytest.raises(BadMessage, match=why):
            pose_covariance(bad)
    msg = SimpleNamespace(header=SimpleNamespace(stamp=SimpleNamespace(sec=1, nanosec=0)),
                          pose=SimpleNamespace(covariance=cov36(0.1, 2.0), pose=SimpleNamespace(
                              position=SimpleNamespace(x=1.0, y=2.0, z=0.0),
                              orientation=SimpleNamespace(x=0.0, y=0.0, z=0.0, w=1.0))))
    pose = convert("pose", "robot1", msg, None)  # type: ignore[arg-type]
    assert isinstance(pose, PoseMessage) and pose.covariance is not None
    assert pose.covariance[0] == pytest.approx(0.01)
    assert pose.covariance[8] == pytest.approx(math.radians(2.0) ** 2)


def test_an_image_takes_the_nearer_poses_covariance() -> None:
    h: History[PoseMessage] = History(10**9)
    h.add(PoseMessage("r", 0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, (1.0,) * 9))
    h.add(PoseMessage("r", 100, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, (2.0,) * 9))
    early, late = interpolate_pose(h, 30, 50), interpolate_pose(h, 70, 50)
    assert early is not None and late is not None
    assert early.covariance == (1.0,) * 9 and late.covariance == (2.0,) * 9


@pytest.fixture(scope="module")
def amcl_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Poses as PoseWithCovarianceStamped: robot1's states the 3 deg its heading is off."""
    path = tmp_path_factory.mktemp("posecov") / "amcl.mcap"
    write_log(path, robots=ROBOTS, ball=BALL, duration_s=0.4, image_hz=5.0, pose_hz=20.0,
              pose_schema=contract.POSE_WITH_COVARIANCE_STAMPED,
              yaw_bias_rad={"robot1": math.radians(3.0)},
              pose_covariance={"robot1": cov36(0.02, 3.0), "robot2": cov36(0.02, 0.2),
                               "robot3": cov36(0.02, 0.2)})
    return path


def _fused(log: Path, **kw: Any) -> list[dict[str, Any]]:
    col = ResultsCollector()
    replay(log, ReplayOptions(progress=False, quiet=True, threads=1, **kw), sinks=[col])
    return [f for f in col.fused if f.get("error_m") is not None]


@pytest.mark.parametrize("fusion", ["weighted", "track"])
def test_the_logs_pose_covariance_weighs_the_far_robot_with_a_bad_yaw_less(
        amcl_log: Path, fusion: str) -> None:
    plain = _fused(amcl_log, fusion=fusion)
    weighed = _fused(amcl_log, fusion=fusion, pose_uncertainty=True)
    assert len(weighed) >= len(plain) > 0  # the tracker confirms no later with it
    before = max(f["error_m"] for f in plain)
    after = max(f["error_m"] for f in weighed)
    assert before > 0.05 and after < before / 2, (before, after)


@pytest.fixture(scope="module")
def carpet_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("posecov") / "carpet.mcap"
    write_log(path, robots=CARPET_ROBOTS, ball=CARPET_BALL, duration_s=0.2, image_hz=5.0,
              pose_hz=20.0, carpet=True, pose_bias_m=BIAS_M, yaw_bias_rad=BIAS_YAW)
    return path


def test_cli_options_and_the_fit_covariance_under_lines(carpet_log: Path,
                                                        tmp_path: Path) -> None:
    """The line fit's covariance (tighter than --pose-sigma's) gives a tighter fused
    covariance than the belief's; the option is stated in the results."""
    log = carpet_log
    outs = {}
    for name, extra in (("plain", ["--no-pose-uncertainty", "--localise", "none"]),
                        ("prior", ["--pose-uncertainty", "--localise", "none",
                                   "--pose-sigma", "0.05,1"]),
                        ("lines", ["--pose-uncertainty", "--localise", "lines"])):
        out = tmp_path / f"{name}.json"
        assert main([str(log), "--fusion", "weighted", "--out", str(out), "--threads", "1",
                     "-q", *extra]) == 0
        outs[name] = json.loads(out.read_text())
    assert "pose_uncertainty" not in outs["plain"]["options"]
    assert outs["prior"]["options"]["pose_uncertainty"] is True
    assert outs["prior"]["options"]["pose_sigma_deg"] == 1.0

    def spread(name: str) -> float:
        return float(np.mean([np.trace(f["covariance"]) for f in outs[name]["fused"]
                              if f.get("covariance")]))

    assert spread("prior") > 2 * spread("plain")  # 0.05 m and 1 deg on every robot
    assert spread("lines") < spread("prior") / 2  # the fit knows the pose far better


def test_match_task_scores_believed_and_corrected_poses(carpet_log: Path) -> None:
    score = score_match_log(MatchTask(1, "random", carpet_log, MatchOptions(localise="lines"),
                                     fusions=("weighted",)))
    assert set(score.fused) == {"weighted", "weighted" + LINES_SUFFIX}
    assert set(score.robots) == {r + s for r in CARPET_ROBOTS for s in ("", LINES_SUFFIX)}
    believed = max(score.fused["weighted"].errors)
    corrected = max(score.fused["weighted" + LINES_SUFFIX].errors)
    assert corrected < believed / 3, (believed, corrected)


def test_dsp_eval_passes_localise_and_pose_uncertainty_on(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    seen: dict[str, Any] = {}

    def fake_match(out: Path, options: MatchOptions, **kw: Any) -> MatchSuite:
        seen["match"] = options
        return MatchSuite(options, kw["count"], kw["seed"], ("track",))

    def fake_paper(record: Any, workdir: Path, **kw: Any) -> PaperSuite:
        seen["paper"] = kw
        nothing = [ScenarioScore(s, PAPER_TRUTH[s], None, 0, 0, 0) for s in PAPER_SCENARIOS]
        return PaperSuite("ideal", "camera metadata", {c.label: nothing for c in kw["configs"]})

    monkeypatch.setattr(evaluate_cli, "run_match_suite", fake_match)
    monkeypatch.setattr(evaluate_cli, "run_paper_suite", fake_paper)
    common = ["--realism", "field", "--localise", "lines", "--pose-uncertainty",
              "--out-dir", str(tmp_path), "--workers", "1", "-q"]
    assert evaluate_cli.main(["--suite", "match", "--count", "2", "--seed", "4", *common]) == 0
    o = seen["match"]
    assert (o.localise, o.pose_uncertainty, o.realism) == ("lines", True, "field")
    written = json.loads((tmp_path / "match-ideal-field-lines-posecov-2-seed4.json")
                         .read_text())
    assert written["options"]["localise"] == "lines"
    assert written["options"]["pose_uncertainty"] is True
    assert evaluate_cli.main(["--suite", "paper", *common]) == 0
    assert seen["paper"]["pose_uncertainty"] is True
    assert Config("corrected", "track", "lines") in seen["paper"]["configs"]
    assert seen["paper"]["configs"] == configs_for("lines")
    assert (tmp_path / "paper-ideal-field-lines-posecov.json").exists()


def test_dsp_eval_refuses_localise_for_lobs(capsys: pytest.CaptureFixture[str]) -> None:
    assert evaluate_cli.main(["--suite", "lobs", "--localise", "lines"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--suite lobs does not take them" in err[0]
