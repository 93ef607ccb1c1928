"""scripts/team_example.py: a recorded log in a team's own layout, and its camera measured.

The golden rolling log (1080 x 1080, centred at (539, 539)) converted into a 1280 x 1024
image centred at (640, 512), the camera turned by 90 deg, poses in a map frame, Unix
stamps: without a camera description it fails with one line saying what to give; with the
camera file that describes it, it replays as the recorded log does."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from dsp.camera_file import read_camera_file
from dsp.field import FIELDS
from replay import ReplayOptions, replay
from replay.calibrate import read_measurements
from replay.cli import main as replay_main
from replay.profiles import options_for, without_reason

ROOT = Path(__file__).resolve().parents[2]
ROLLING = ROOT / "logs" / "golden" / "rolling.mcap"
_spec = importlib.util.spec_from_file_location("team_example", ROOT / "scripts" / "team_example.py")
assert _spec is not None and _spec.loader is not None
team = importlib.util.module_from_spec(_spec)
sys.modules["team_example"] = team
_spec.loader.exec_module(team)

LAYOUT = ["--pad", "1280x1024", "--centre", "640,512", "--mount-deg", "90"]
TOPICS = {"image_topic": team.IMAGE_TOPIC, "pose_topic": team.POSE_TOPIC,
          "truth_topic": team.TRUTH_TOPIC}


@pytest.fixture(scope="module")
def converted(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("team")
    log, cams = d / "team.mcap", d / "exact.yaml"
    assert team.main(["convert", str(ROLLING), str(log), *LAYOUT, "--encoding", "png",
                      "--exact-cameras", str(cams)]) == 0
    return log, cams


def test_a_quarter_turn_about_whole_pixels_copies_pixels_exactly() -> None:
    img = np.random.default_rng(0).integers(0, 255, (1080, 1080, 3), dtype=np.uint8)
    m = team.warp_matrix((539.0, 539.0), (640.0, 512.0), 90.0)
    out = team.transform_image(img, m, (1280, 1024))
    u, v = 300, 700  # robot bearing theta shows at image bearing theta - 90 deg
    assert np.array_equal(out[512 + (u - 539), 640 - (v - 539)], img[v, u])


def test_the_converted_log_without_a_camera_description_says_what_to_give(
        converted: tuple[Path, Path], capsys: pytest.CaptureFixture[str]) -> None:
    log, _ = converted
    code = replay_main([str(log), "--image-topic", team.IMAGE_TOPIC, "--pose-topic",
                        team.POSE_TOPIC, "--no-progress"])
    err = capsys.readouterr().err.strip()
    assert code == 1 and len(err.splitlines()) == 1
    assert "no camera description for robot1, robot2, robot3" in err and "--cameras" in err


def test_the_off_centre_wide_camera_replays_as_the_recorded_one(
        converted: tuple[Path, Path]) -> None:
    log, cams = converted
    recorded = replay(ROLLING, ReplayOptions(progress=False))
    described = replay(log, ReplayOptions(cameras=cams, progress=False, **TOPICS))
    assert recorded.fused.rmse_m is not None and described.fused.rmse_m is not None
    assert described.fused_steps == recorded.fused_steps
    assert described.fused.rmse_m == pytest.approx(recorded.fused.rmse_m, rel=0.02, abs=1e-4)
    for robot, r in recorded.per_robot.items():
        assert described.per_robot[robot].detections == r.detections


def test_the_exact_camera_file_names_the_field_so_the_default_fits_the_lines(
        converted: tuple[Path, Path], tmp_path: Path) -> None:
    log, cams = converted
    assert read_camera_file(cams).field == FIELDS["18x12"]
    recorded = replay(ROLLING, options_for(progress=False))
    described = replay(log, options_for(cameras=cams, progress=False, **TOPICS))
    # the line fit runs on both; the detector is the same, chosen from the recording's
    # metadata and from the team log's images
    assert described.pipeline is not None and recorded.pipeline is not None
    assert without_reason(described.pipeline) == without_reason(recorded.pipeline)
    assert "paper detector (chosen: in its first images" in described.pipeline
    assert recorded.pipeline is not None and "from the field lines" in recorded.pipeline
    assert recorded.fused.rmse_m is not None and described.fused.rmse_m is not None
    assert described.fused.rmse_m == pytest.approx(recorded.fused.rmse_m, rel=0.05, abs=2e-3)


def test_measured_points_are_what_dsp_calibrate_reads(tmp_path: Path) -> None:
    points = tmp_path / "points.csv"
    assert team.main(["measure", str(ROLLING), str(points), *LAYOUT, "--points", "8"]) == 0
    m = read_measurements(points)
    assert m.centroids and len(m.samples["default"]) == 8
    assert all(0.5 <= s.range_m <= 8.5 for s in m.samples["default"])
