"""A team's ``lookup`` camera (what the template and dsp-calibrate write) that gives the
camera's height gets the default's line fit: its calibration and height make the
projection; without the height the pipeline says what is missing."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from synthetic import write_log

from dsp import contract
from dsp.camera_file import camera_file_text
from estimator.calibration import CameraCalibration
from estimator.camera import make_camera
from replay import replay
from replay.cli import main
from replay.profiles import options_for

TEAM = {"image_topic": "/{robot}/camera/image_raw", "pose_topic": "/{robot}/amcl_pose"}
ROBOTS = {"robot1": (-4.0, 1.0, 0.3), "robot2": (-1.0, -2.5, 2.0), "robot3": (2.5, 2.0, -2.4)}
IDEAL = make_camera("ideal", cu_px=539.0, cv_px=539.0)
"""The camera the synthetic carpet is drawn with."""


def _lookup(**extra: object) -> dict[str, object]:
    """The ideal camera as a team describes it: a lookup table of its ball ranges."""
    cal = CameraCalibration(IDEAL)
    radii = np.arange(20.0, 531.0, 10.0)
    return {"model": "lookup", "width_px": IDEAL.width_px, "height_px": IDEAL.height_px,
            "cu_px": 539.0, "cv_px": 539.0, "usable_radius_px": 530.0,
            "calibration": {"model": "lookup", "r_px": radii.tolist(),
                            "d_m": [cal.range_m(float(r)) for r in radii]}, **extra}


@pytest.fixture(scope="module")
def team_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("team") / "team.mcap"
    write_log(path, robots=ROBOTS, duration_s=0.6, image_hz=5.0, pose_hz=20.0, carpet=True,
              metadata=False, pose_schema=contract.POSE_WITH_COVARIANCE_STAMPED,
              pose_bias_m={"robot1": (0.06, -0.04)}, **TEAM)
    return path


def _replay(log: Path, folder: Path, entry: dict[str, object]) -> dict[str, object]:
    cams = folder / "cams.yaml"
    cams.write_text(camera_file_text({"default": entry}, ".yaml", field="18x12"))
    out = folder / "r.json"
    replay(log, options_for(cameras=cams, out=out, progress=False, quiet=True, threads=1,
                            force=True, **TEAM))
    doc: dict[str, object] = json.loads(out.read_text())
    return doc


def test_a_lookup_camera_with_its_height_gets_the_line_fit(team_log: Path,
                                                            tmp_path: Path) -> None:
    with_height = _replay(team_log, tmp_path, _lookup(height_m=IDEAL.height_m))
    assert with_height["pipeline"]["poses"] == "lines"  # type: ignore[index]
    frames = with_height["frames"]
    assert {f["localisation"]["source"] for f in frames} == {"lines"}  # type: ignore[attr-defined]
    for f in frames:  # type: ignore[attr-defined]
        x, y, _ = ROBOTS[f["robot"]]  # robot1 believes itself 7 cm off: the lines put it right
        assert math.hypot(f["localisation"]["x_m"] - x, f["localisation"]["y_m"] - y) < 0.01
    without = _replay(team_log, tmp_path, _lookup())
    assert without["pipeline"]["poses"] != "lines"  # type: ignore[index]
    assert any("a lookup entry with height_m" in n
               for n in without["pipeline"]["notes"])  # type: ignore[index]


def test_a_height_no_ball_can_be_seen_from_is_one_line(team_log: Path, tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]
                                                       ) -> None:
    cams = tmp_path / "low.yaml"
    cams.write_text(camera_file_text({"default": _lookup(height_m=0.05)}, ".yaml"))
    assert main([str(team_log), "--cameras", str(cams), "--image-topic", TEAM["image_topic"],
                 "--pose-topic", TEAM["pose_topic"]]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(cams) in err[0] and "height_m" in err[0]
    assert "above the ball's centre" in err[0] and "Traceback" not in err[0]


def test_a_lookup_entry_with_its_height_is_described_as_a_projection_model() -> None:
    from dsp.cameras import camera_spec_from_json
    from estimator.table_camera import TableCamera

    spec = camera_spec_from_json(_lookup(height_m=0.85), "cams.yaml: default")
    assert isinstance(spec.camera, TableCamera) and spec.camera.height_m == 0.85
    assert "height 0.85 m (a projection model)" in spec.describe()
    plain = camera_spec_from_json(_lookup(), "cams.yaml: default")
    assert plain.camera is None and "height" not in plain.describe()
