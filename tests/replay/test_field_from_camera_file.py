"""A camera file names the field (``field: 18x12``): a team's own log, which names none,
gets its poses corrected from the field lines by the default pipeline; without it the
pipeline says how to name it; a bad field is one line naming the file and key, exit 2."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from synthetic import write_log

from dsp import contract
from dsp.camera_file import camera_file_text
from estimator.camera import make_camera
from replay import replay
from replay.cli import main
from replay.profiles import options_for

TEAM = {"image_topic": "/{robot}/camera/image_raw", "pose_topic": "/{robot}/amcl_pose"}
ROBOTS = {"robot1": (-4.0, 1.0, 0.3), "robot2": (-1.0, -2.5, 2.0), "robot3": (2.5, 2.0, -2.4)}
CAMERA = make_camera("ideal", cu_px=539.0, cv_px=539.0).to_dict()
"""The camera the synthetic carpet is drawn with."""


@pytest.fixture(scope="module")
def team_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A team's layout: no dsp metadata (no field, no cameras), AMCL poses, the field's
    lines in every image."""
    path = tmp_path_factory.mktemp("team") / "team.mcap"
    write_log(path, robots=ROBOTS, duration_s=0.6, image_hz=5.0, pose_hz=20.0, carpet=True,
              metadata=False, pose_schema=contract.POSE_WITH_COVARIANCE_STAMPED,
              pose_bias_m={"robot1": (0.06, -0.04)}, **TEAM)
    return path


def _cameras(folder: Path, name: str = "cams.yaml", **field: object) -> Path:
    path = folder / name
    path.write_text(camera_file_text({"default": CAMERA}, path.suffix, **field))  # type: ignore[arg-type]
    return path


def _pipeline(log: Path, cameras: Path, out: Path) -> dict[str, object]:
    replay(log, options_for(cameras=cameras, out=out, progress=False, quiet=True, threads=1,
                            **TEAM))
    pipeline: dict[str, object] = json.loads(out.read_text())["pipeline"]
    return pipeline


def test_a_camera_file_naming_the_field_lets_the_default_fit_the_lines(
        team_log: Path, tmp_path: Path) -> None:
    named = _pipeline(team_log, _cameras(tmp_path, field="18x12"), tmp_path / "a.json")
    assert named["poses"] == "lines" and named["notes"] == []
    unnamed = _pipeline(team_log, _cameras(tmp_path, "none.yaml"), tmp_path / "b.json")
    assert unnamed["poses"] == "ball"  # no lines: each robot's bias from the balls
    assert unnamed["notes"] == ["no line fit: the log names no field (dsp.scenario metadata); "
                                "name it in the camera file: field: 18x12"]
    frames = json.loads((tmp_path / "a.json").read_text())["frames"]
    assert {f["localisation"]["source"] for f in frames} == {"lines"}
    for f in frames:  # robot1 believes itself 7 cm off; the lines put every robot right
        x, y, _ = ROBOTS[f["robot"]]
        assert math.hypot(f["localisation"]["x_m"] - x, f["localisation"]["y_m"] - y) < 0.01


def test_the_camera_files_field_wins_over_the_logs_and_says_so(tmp_path: Path) -> None:
    log = tmp_path / "recorded.mcap"  # dsp metadata: the 18x12 field and the cameras
    write_log(log, robots=ROBOTS, duration_s=0.2, image_hz=5.0, pose_hz=20.0, carpet=True)
    cams = tmp_path / "field.yaml"
    cams.write_text(camera_file_text({}, ".yaml", field="msl"))
    out = tmp_path / "r.json"
    replay(log, options_for(cameras=cams, out=out, progress=False, quiet=True, threads=1))
    pipeline = json.loads(out.read_text())["pipeline"]
    assert pipeline["poses"] == "lines"
    assert pipeline["notes"] == [f"field 22x14 from {cams} (the log's dsp.scenario names "
                                 "18x12)"]
    cams.write_text(camera_file_text({}, ".yaml", field="18x12"))  # the same: nothing said
    replay(log, options_for(cameras=cams, out=out, progress=False, quiet=True, threads=1,
                            force=True))
    assert json.loads(out.read_text())["pipeline"]["notes"] == []


def test_localise_lines_without_a_field_says_how_to_name_it(
        team_log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cams = _cameras(tmp_path)
    code = main([str(team_log), "--cameras", str(cams), "--localise", "lines", "--image-topic",
                 TEAM["image_topic"], "--pose-topic", TEAM["pose_topic"], "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "name it in the camera file (field: 18x12)" in err


@pytest.mark.parametrize(("field", "message"), [
    ('{"length_m": -3, "width_m": 12}', "field.length_m = -3 must be > 0"),
    ('"19x13"', "field = '19x13' is not a field's name"),
    ('{"length_m": 1000000.0, "width_m": 12}', "field.length_m = 1e+06 is out of range"),
    ('{"length_m": 18, "width_m": 12, "depth": 1}', "field.depth is not a key of a field"),
])
def test_a_bad_field_stops_the_replay_in_one_line(
        team_log: Path, tmp_path: Path, field: str, message: str,
        capsys: pytest.CaptureFixture[str]) -> None:
    cams = _cameras(tmp_path)
    cams.write_text(cams.read_text() + f"field: {field}\n")
    code = main([str(team_log), "--cameras", str(cams), "--image-topic", TEAM["image_topic"],
                 "--pose-topic", TEAM["pose_topic"], "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err  # a field is a statement, as an option is
    assert err.strip().splitlines() == [f"dsp-replay: error: {cams}: {message}" +
                                        err.strip().split(message, 1)[1]]
