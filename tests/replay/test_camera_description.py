"""A log's cameras come from its metadata or the options, never from a guess: a log without
a camera description fails with one line saying what to give; a camera file gives each
robot's size, centre, mounting, calibration and poses' frame; what a replay that worked
must still say is warned about, and --strict makes that an error."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from synthetic import B_M, GREEN_BGR, K_M_PER_PX, write_log

from dsp import contract
from dsp.camera_file import camera_file_text
from dsp.errors import UsageError
from estimator.constants import NS_PER_S
from replay import ReplayOptions, replay
from replay.cli import main
from replay.errors import NoCameraError, StrictError

PAPER_LINE = {"model": "linear", "a_m_per_px": K_M_PER_PX, "b_m": B_M}


def _camera_file(tmp_path: Path, entries: dict[str, dict[str, object]],
                 name: str = "cameras.yaml") -> Path:
    path = tmp_path / name
    path.write_text(camera_file_text(entries, path.suffix), encoding="utf-8")
    return path


def _lookup(width: int = 1080, height: int = 1080, cu: float = 539.0, cv: float = 539.0,
            **extra: object) -> dict[str, object]:
    return {"model": "lookup", "width_px": width, "height_px": height, "cu_px": cu,
            "cv_px": cv, "calibration": PAPER_LINE, **extra}


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main([*map(str, argv), "--no-progress"])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def bare(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A robot's own log: no camera metadata."""
    path = tmp_path_factory.mktemp("bare") / "bare.mcap"
    write_log(path, duration_s=0.4, cameras=None)
    return path


def test_a_log_without_a_camera_description_says_what_to_give(
        bare: Path, capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "r.json"
    code, _, err = _run([bare, "--out", out], capsys)
    assert code == 1 and len(err.strip().splitlines()) == 1
    assert "no camera description for robot1, robot2, robot3 (the log has no dsp.cameras" in err
    assert "give --cameras FILE" in err and "dsp-info --cameras-template" in err
    assert "--cameras paper" in err and not out.exists()
    with pytest.raises(NoCameraError):
        replay(bare, ReplayOptions(calibration=tmp_path / "any.json", progress=False))


@pytest.mark.parametrize("flag", ["--cameras", "--calibration"])
def test_the_papers_constants_are_asked_for_by_name(
        bare: Path, flag: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = _run([bare, flag, "paper"], capsys)
    assert code == 0 and err == "" and "fused" in out
    s = replay(bare, ReplayOptions(cameras="paper", progress=False))
    assert s.fused.rmse_m is not None and s.fused.rmse_m < 0.01


def test_a_camera_file_describes_the_robots_it_names_and_its_default(
        bare: Path, tmp_path: Path) -> None:
    path = _camera_file(tmp_path, {"default": _lookup(), "robot2": {"cv_px": 549.0}})
    out = tmp_path / "r.json"
    s = replay(bare, ReplayOptions(cameras=path, out=out, progress=False))
    doc = json.loads(out.read_text())
    assert doc["options"]["cameras"] == "cameras.yaml"
    robot2 = s.per_robot["robot2"]
    assert robot2.rmse_m is not None and robot2.rmse_m > 0.1  # its centre is 10 px off
    assert s.per_robot["robot1"].rmse_m is not None and s.per_robot["robot1"].rmse_m < 0.01
    only = _camera_file(tmp_path, {"robot1": _lookup()}, "one.json")
    with pytest.raises(NoCameraError, match=r"robot2, robot3 \(neither .*one.json nor"):
        replay(bare, ReplayOptions(cameras=only, progress=False))


def test_a_bad_camera_file_is_one_line_naming_the_file_and_field(
        bare: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _camera_file(tmp_path, {"default": _lookup(cu="middle")})
    code, _, err = _run([bare, "--cameras", path], capsys)
    assert code == 1
    assert err.strip() == (f"dsp-replay: error: {path}: default.cu_px = 'middle' is not a "
                           "number")


def test_a_camera_off_centre_in_a_wide_image_replays_as_the_square_one(tmp_path: Path) -> None:
    square, wide = tmp_path / "square.mcap", tmp_path / "wide.mcap"
    write_log(square, duration_s=0.4)
    write_log(wide, duration_s=0.4, image_size_px=(1280, 1024), centre_px=(640.0, 512.0),
              cameras=None)
    cams = _camera_file(tmp_path, {"default": _lookup(1280, 1024, 640.0, 512.0)})
    a = replay(square, ReplayOptions(progress=False))
    b = replay(wide, ReplayOptions(cameras=cams, progress=False))
    assert a.fused.rmse_m is not None and b.fused.rmse_m is not None
    assert b.fused.rmse_m == pytest.approx(a.fused.rmse_m, rel=0.05, abs=1e-4)


def test_the_papers_camera_on_a_wide_image_warns_of_its_size(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    wide = tmp_path / "wide.mcap"
    write_log(wide, duration_s=0.2, image_size_px=(1280, 1024), centre_px=(640.0, 512.0),
              cameras=None)
    code, _, err = _run([wide, "--cameras", "paper"], capsys)
    assert code == 0
    assert ("3 of robot1's 3 images are 1280 x 1024 px, but the paper's camera describes a "
            "1080 x 1080 camera") in err
    code, _, err = _run([wide, "--cameras", "paper", "--strict"], capsys)
    assert code == 1 and err.startswith("dsp-replay: error: --strict: ")


def test_a_turned_camera_is_described_by_its_mounting(tmp_path: Path) -> None:
    log = tmp_path / "turned.mcap"
    write_log(log, duration_s=0.4, mount_yaw_rad=math.pi / 2, cameras=None)
    right = _camera_file(tmp_path, {"default": _lookup(mount_yaw_deg=90.0)})
    wrong = _camera_file(tmp_path, {"default": _lookup()}, "wrong.yaml")
    for method in ("corrected", "paper"):
        good = replay(log, ReplayOptions(cameras=right, method=method, fusion="mean",
                                         progress=False))
        bad = replay(log, ReplayOptions(cameras=wrong, method=method, fusion="mean",
                                        progress=False))
        assert good.fused.rmse_m is not None and bad.fused.rmse_m is not None
        assert good.fused.rmse_m < (0.01 if method == "corrected" else 0.5)
        assert bad.fused.rmse_m > 1.0


def test_poses_in_a_map_frame_are_turned_into_the_field(tmp_path: Path) -> None:
    log = tmp_path / "map.mcap"
    write_log(log, duration_s=0.4, map_origin=(-9.0, -6.0), cameras=None)
    moved = _camera_file(tmp_path, {"default": _lookup(
        map_to_field={"x_m": -9.0, "y_m": -6.0, "yaw_deg": 0.0})})
    out = tmp_path / "r.json"
    s = replay(log, ReplayOptions(cameras=moved, out=out, progress=False))
    assert s.fused.rmse_m is not None and s.fused.rmse_m < 0.01
    pose = json.loads(out.read_text())["frames"][0]["pose"]
    assert (pose["x_m"], pose["y_m"]) == pytest.approx((-3.0, 0.0))  # robot1, in the field
    plain = replay(log, ReplayOptions(cameras="paper", progress=False))
    assert plain.fused.rmse_m is not None and plain.fused.rmse_m > 5.0


def test_balls_beyond_the_usable_radius_are_out_of_range_and_warned_of(
        bare: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    small = _camera_file(tmp_path, {"default": _lookup(usable_radius_px=100.0)})
    code, _, err = _run([bare, "--cameras", small], capsys)
    assert code == 0
    assert ("5 of the 5 balls robot1 saw are out of range (beyond its calibration or usable "
            "radius): is the image centre (539, 539) or the linear calibration from") in err
    s = replay(bare, ReplayOptions(cameras=small, progress=False))
    assert s.skipped == {"out_of_range": 15}


def test_a_ball_no_robot_sees_is_warned_of_and_strict_fails_writing_nothing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "yellow.mcap"
    write_log(log, duration_s=0.2, ball_colour=(0, 220, 230))  # a yellow ball
    out = tmp_path / "r.json"
    code, _, err = _run([log, "--out", out, "-q"], capsys)
    assert code == 0 and out.exists()  # -q hides the summary, never a warning
    assert err.strip() == (f"warning: {log}: no robot saw the ball in any of its images (9 "
                           "images: robot1 3, robot2 3, robot3 3): is the ball another colour "
                           "than the detector's orange, or the image topic not the ball "
                           "camera's?")
    strict_out = tmp_path / "strict.json"
    code, _, err = _run([log, "--out", strict_out, "--strict"], capsys)
    assert code == 1 and not strict_out.exists()
    assert err.startswith("dsp-replay: error: --strict: ") and "no robot saw the ball" in err
    with pytest.raises(StrictError):
        replay(log, ReplayOptions(strict=True, progress=False))
    assert GREEN_BGR != (0, 220, 230)


def test_a_ball_no_robot_sees_with_a_ball_model_is_warned_of_in_the_model_s_words(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """With --ball the detector looks for the model's ball, not for orange: the warning names
    the model file."""
    from dsp.ball_file import ball_file_text, shipped_generic

    log = tmp_path / "yellow.mcap"
    write_log(log, duration_s=0.2, ball_colour=(0, 220, 230))
    ball = tmp_path / "yellow-ball.json"
    ball.write_text(ball_file_text(shipped_generic()), encoding="utf-8")
    code, _, err = _run([log, "--ball", ball, "-q"], capsys)
    assert code == 0 and "no robot saw the ball in any of its images" in err
    assert "orange" not in err
    assert "is the ball unlike the one the ball model yellow-ball.json was fitted to" in err


def test_an_unsupported_encoding_is_named(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "nv12.mcap"
    write_log(log, duration_s=0.2, image_encoding="nv12")
    code, _, err = _run([log, "--image-topic", "/{robot}/omni/image"], capsys)
    assert code == 1
    assert "none of the 9 images decodes (9: encoding 'nv12' is not one replay reads" in err


def test_a_truth_topic_of_its_own(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "mocap.mcap"
    write_log(log, duration_s=0.3, truth_topic="/mocap/ball")
    s = replay(log, ReplayOptions(truth_topic="/mocap/ball", progress=False))
    assert s.fused.rmse_m is not None and s.fused.rmse_m < 0.01
    assert replay(log, ReplayOptions(progress=False)).fused.rmse_m is None  # not scored
    with pytest.raises(UsageError, match="--truth-topic /nope: no such topic"):
        replay(log, ReplayOptions(truth_topic="/nope", progress=False))


EPOCH_NS = 1_733_068_800 * NS_PER_S


@pytest.mark.parametrize(("start", "end", "frames"), [
    ("0.25", "0.55", 9), ("@1733068800.25", "@1733068800.55", 9), ("0.25", None, 18),
])
def test_start_and_end_count_from_the_logs_start(tmp_path: Path, start: str, end: str | None,
                                                 frames: int) -> None:
    log = tmp_path / "epoch.mcap"
    write_log(log, duration_s=0.8, stamp_offset_ns=EPOCH_NS)
    out = tmp_path / "r.json"
    argv = [str(log), "--start", start, "--out", str(out), "-q", "--no-progress"]
    assert main(argv + (["--end", end] if end else [])) == 0
    doc = json.loads(out.read_text())
    assert doc["summary"]["frames"] == frames
    assert min(f["stamp_ns"] for f in doc["frames"]) == EPOCH_NS + 300_000_000


def test_a_start_past_an_epoch_logs_end_says_how_it_counts(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "epoch.mcap"
    write_log(log, duration_s=0.4, stamp_offset_ns=EPOCH_NS)
    code, _, err = _run([log, "--start", "5"], capsys)
    assert code == 2
    assert ("--start 5 s is past the end of" in err
            and "(its messages run from 0.000 to 0.400 s after its first, stamped "
            "@1733068800.000)" in err)
    code, _, err = _run([log, "--start", "@x"], capsys)
    assert code == 2 and "give seconds (e.g. 2.5) or @" in err


def test_a_recorders_log_keeps_its_sim_seconds() -> None:
    from replay.selection import log_origin_ns

    with __import__("replay.log", fromlist=["LogReader"]).LogReader(
            Path(__file__).resolve().parents[2] / "logs" / "golden" / "rolling.mcap") as r:
        assert r.info.recorder is not None and log_origin_ns(r.info) == 0
    assert contract.GT_BALL_TOPIC == "/ground_truth/ball"


def test_the_library_returns_warnings_and_the_commands_print_them(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "yellow.mcap"
    write_log(log, duration_s=0.2, ball_colour=(0, 220, 230))
    s = replay(log, ReplayOptions(progress=False))
    assert len(s.warnings) == 1 and "no robot saw the ball" in s.warnings[0]
    assert capsys.readouterr().err == ""  # dsp-eval's scenes replay quietly
    code, _, err = _run([log, "--out-dir", tmp_path / "batch", "--workers", "1"], capsys)
    assert code == 0 and err.count("warning: ") == 1 and "no robot saw the ball" in err


def test_the_ball_model_entry_is_passed_on_unread(tmp_path: Path) -> None:
    from replay.cameras import cameras_for

    path = _camera_file(tmp_path, {"default": _lookup(ball="models/orange.json"),
                                   "robot2": {"ball": {"hue": [5, 25]}}})
    cams = cameras_for(["robot1", "robot2"], log="x.mcap", metadata=None, cameras=path)
    assert cams.ball_models() == {"robot1": str(tmp_path / "models" / "orange.json"),
                                  "robot2": {"hue": [5, 25]}}
    assert cams.sources == {"robot1": str(path), "robot2": str(path)}
