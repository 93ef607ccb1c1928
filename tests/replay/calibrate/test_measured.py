"""dsp-calibrate for a real camera: from measured points or a log with the ball at a known
place, the centre and mounting fitted, the models ranked on held-out samples (the simulated
procedure's rule), the camera file and the residual figure written."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from synthetic import ball_pixel, write_log

from dsp.camera_file import read_camera_file
from replay import ReplayOptions, replay
from replay.calibrate import read_measurements
from replay.calibrate.cli import main
from replay.calibrate.measurements import MeasurementError

CENTRE = (640.0, 512.0)
MOUNT = math.pi / 2


def _points(path: Path, n: int = 40, *, spread_deg: float = 180.0, robot: str = "",
            seed: int = 0) -> Path:
    """Measured points of a turned paper camera centred at CENTRE in a 1280 x 1024 image:
    the detector's centroid noise, a tape's on the range, a protractor's on the angle."""
    rng = np.random.default_rng(seed)
    rows = [("robot," if robot else "") + "u_px,v_px,range_m,angle_deg"]
    for _ in range(n):
        d, a = rng.uniform(0.6, 6.0), rng.uniform(-spread_deg, spread_deg)
        u, v = ball_pixel((0.0, 0.0, 0.0), (d * math.cos(math.radians(a)),
                                            d * math.sin(math.radians(a))), CENTRE, MOUNT)
        rows.append((f"{robot}," if robot else "") + f"{u + rng.normal(0, 0.3):.2f},"
                    f"{v + rng.normal(0, 0.3):.2f},{d + rng.normal(0, 0.005):.3f},"
                    f"{a + rng.normal(0, 0.2):.2f}")
    path.write_text("# measured on the lab floor\n" + "\n".join(rows) + "\n")
    return path


def _run(argv: list[object], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_from_measurements_fits_centre_mounting_and_range(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    points = _points(tmp_path / "points.csv")
    out = tmp_path / "cameras.yaml"
    code, text, err = _run(["--from-measurements", points, "--image-size", "1280x1024",
                            "-o", out], capsys)
    assert code == 0 and err == ""
    assert "default: 40 samples" in text and "best: linear (ranked on held-out samples)" in text
    assert (tmp_path / "cameras.png").stat().st_size > 10_000  # the residual figure
    spec = read_camera_file(out).default
    assert spec is not None and spec.model == "lookup"
    assert spec.centre_px == pytest.approx(CENTRE, abs=0.5)
    assert math.degrees(spec.mount_yaw_rad) == pytest.approx(90.0, abs=0.3)
    assert spec.calibration is not None and spec.calibration.name == "linear"
    assert spec.calibration_rms_m is not None and spec.calibration_rms_m < 0.02
    log = tmp_path / "turned.mcap"
    write_log(log, duration_s=0.4, image_size_px=(1280, 1024), centre_px=CENTRE,
              mount_yaw_rad=MOUNT, cameras=None)
    s = replay(log, ReplayOptions(cameras=out, progress=False))
    assert s.fused.rmse_m is not None and s.fused.rmse_m < 0.02


def test_the_camera_height_and_the_field_are_written_for_the_line_fit(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """--camera-height and --field go into the file: the lookup camera becomes a projection
    model (what the line fit and the 3-D track need) and the file names the field; a height
    no ball is seen from, or a field of no known name, is one line, and no file."""
    points = _points(tmp_path / "points.csv")
    out = tmp_path / "cameras.yaml"
    code, _, err = _run(["--from-measurements", points, "--image-size", "1280x1024",
                         "--camera-height", "0.85", "--field", "msl", "-o", out], capsys)
    assert code == 0 and err == ""
    cameras = read_camera_file(out)
    assert cameras.field is not None and cameras.field.name == "22x14"
    spec = cameras.default
    assert spec is not None and spec.model == "lookup" and spec.camera is not None
    assert spec.camera.height_m == 0.85
    bad = tmp_path / "bad.yaml"
    for flag, value, said in (("--camera-height", "0.05", "(0.11, 10] m"),
                              ("--field", "30x20", "is not a field's name")):
        code, _, err = _run(["--from-measurements", points, "--image-size", "1280x1024",
                             flag, value, "-o", bad], capsys)
        assert code == 2 and len(err.splitlines()) == 1 and said in err and flag in err
        assert not bad.exists()
    code, _, err = _run(["--field", "msl", "-o", tmp_path / "c.json"], capsys)
    assert code == 2 and "--field go with --from-measurements or --from-log" in err


def test_the_figure_and_file_are_the_same_bytes_every_run(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    points = _points(tmp_path / "points.csv", robot="robot2")
    files = []
    for name in ("a", "b"):
        out = tmp_path / f"{name}.json"
        assert _run(["--from-measurements", points, "--image-size", "1280x1024", "-o", out],
                    capsys)[0] == 0
        files.append((out.read_bytes(), out.with_suffix(".png").read_bytes()))
    assert files[0] == files[1]
    assert read_camera_file(tmp_path / "a.json").for_robot("robot2") is not None


def test_points_in_one_direction_need_the_centre(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    points = _points(tmp_path / "ahead.csv", spread_deg=2.0)
    argv = ["--from-measurements", points, "--image-size", "1280x1024", "-o",
            tmp_path / "c.yaml"]
    code, _, err = _run(argv, capsys)
    assert code == 1 and "too narrow a spread of directions" in err and "--centre" in err
    code, _, err = _run([*argv, "--centre", "640,512"], capsys)
    assert code == 0, err
    spec = read_camera_file(tmp_path / "c.yaml").default
    assert spec is not None and spec.centre_px == (640.0, 512.0)
    assert math.degrees(spec.mount_yaw_rad) == pytest.approx(90.0, abs=1.0)


def test_radii_and_bearings_about_a_known_centre(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    rows = ["r_px,bearing_deg,range_m,angle_deg"]
    for d in np.linspace(0.8, 7.0, 12):
        r = (d - 0.2786) / 0.0163
        rows.append(f"{r:.2f},{-90.0 + 10 * d:.2f},{d:.3f},{10 * d:.2f}")  # turned by 90 deg
    path = tmp_path / "radii.csv"
    path.write_text("\n".join(rows) + "\n")
    argv = ["--from-measurements", path, "--image-size", "1080x1080", "-o", tmp_path / "c.json"]
    code, _, err = _run(argv, capsys)
    assert code == 1 and "give it (--centre CU,CV)" in err
    assert _run([*argv, "--centre", "539,539"], capsys)[0] == 0
    spec = read_camera_file(tmp_path / "c.json").default
    assert spec is not None and math.degrees(spec.mount_yaw_rad) == pytest.approx(90.0)


def test_from_a_log_with_the_ball_at_a_known_place(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "calib.mcap"
    write_log(log, duration_s=2.0, ball=(0.5, 0.3), yaw_rate_rad_s=2.0,
              robot_velocity=(0.6, 0.2), mount_yaw_rad=MOUNT, cameras=None)
    out = tmp_path / "cameras.yaml"
    code, text, err = _run(["--from-log", log, "--ball-at", "0.5,0.3", "-o", out], capsys)
    assert code == 0, err
    cams = read_camera_file(out)
    for robot in ("robot1", "robot2", "robot3"):
        spec = cams.for_robot(robot)
        assert spec is not None and spec.centre_px == pytest.approx((539.0, 539.0), abs=0.5)
        assert math.degrees(spec.mount_yaw_rad) == pytest.approx(90.0, abs=0.3)
        assert (spec.width_px, spec.height_px) == (1080, 1080)
    assert f"{robot}: 21 samples" in text
    check = tmp_path / "check.mcap"
    write_log(check, duration_s=0.4, mount_yaw_rad=MOUNT, cameras=None)
    s = replay(check, ReplayOptions(cameras=out, progress=False))
    assert s.fused.rmse_m is not None and s.fused.rmse_m < 0.02
    truth = tmp_path / "truth.yaml"
    assert _run(["--from-log", log, "--truth-topic", "/ground_truth/ball", "-o", truth],
                capsys)[0] == 0
    assert read_camera_file(truth).robots.keys() == cams.robots.keys()


@pytest.mark.parametrize(("text", "message"), [
    ("u_px,v_px,range_m\n1,2,3\n", "lacks angle_deg"),
    ("u_px,v_px,range_m,angle_deg\n1,2,x,4\n", "row 1: range_m = 'x' is not a number"),
    ("u_px,v_px,range_m,angle_deg\n1,2,-1,4\n", "row 1: range_m = -1 is not in (0, 100] m"),
    ("u_px,v_px,range_m,angle_deg\n1,2,0,4\n", "row 1: range_m = 0 is not in (0, 100] m"),
    ("u_px,v_px,range_m,angle_deg\n1,2,3\n", "row 1: 3 cells, the header has 4"),
    ("u_px,v_px,range_m,angle_deg\n", "no measurement rows"),
    ("u_px,v_px,range_m,angle_deg\n1,2,3,nan\n", "angle_deg = 'nan' is not a finite number"),
    ("u_px,v_px,range_m,angle_deg\n# a comment\n1,2,3,4\n1," + "9" * (129 << 10) + ",3,4\n",
     "row 2: not CSV measurements (field larger than field limit"),
    ("u_px,v_px," + "x" * (129 << 10) + "\n1,2,3\n",
     "the header: not CSV measurements (field larger than field limit"),
])
def test_a_bad_measurements_file_is_one_line_naming_the_row(tmp_path: Path, text: str,
                                                            message: str) -> None:
    path = tmp_path / "m.csv"
    path.write_text(text)
    with pytest.raises(MeasurementError) as err:
        read_measurements(path)
    assert str(err.value).startswith(str(path)) and message in str(err.value)



def test_a_cell_over_the_csv_limit_is_one_line_on_the_command_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "m.csv"
    path.write_text("u_px,v_px,range_m,angle_deg\n1,2,3," + "4" * (200 << 10) + "\n")
    code, _, err = _run(["--from-measurements", path, "--image-size", "1280x1024", "-o",
                         tmp_path / "c.yaml"], capsys)
    assert code == 1 and len(err.splitlines()) == 1 and "Traceback" not in err
    assert err.startswith(f"dsp-calibrate: error: {path}: row 1: not CSV measurements")


def test_options_that_do_not_go_together(tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    points = _points(tmp_path / "p.csv")
    out = tmp_path / "c.yaml"
    assert _run(["--from-measurements", points, "-o", out], capsys)[1:] == (
        "", "dsp-calibrate: error: --from-measurements needs --image-size WxH (the images' "
        "size)\n")
    code, _, err = _run(["--from-measurements", points, "--image-size", "1280x1024",
                         "--ball-at", "1,2", "-o", out], capsys)
    assert code == 2 and "--ball-at goes with --from-log" in err
    code, _, err = _run(["--centre", "1,2", "-o", tmp_path / "c.json"], capsys)
    assert code == 2 and "--centre go with --from-measurements or --from-log" in err
    code, _, err = _run(["--from-measurements", points, "--image-size", "1280x1024",
                         "-o", tmp_path / "c.txt"], capsys)
    assert code == 2 and ".yaml or .yml or .json" in err
    few = _points(tmp_path / "few.csv", n=4)
    code, _, err = _run(["--from-measurements", few, "--image-size", "1280x1024", "-o", out],
                        capsys)
    assert code == 1 and "4 samples; a calibration needs at least 6" in err
    assert not out.exists()


def test_without_a_real_camera_the_paper_procedure_runs_in_simulation(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "cal.json"
    code, text, err = _run(["--camera", "ideal", "-o", out, "--start-m", "1", "--stop-m", "8",
                            "--step-m", "1", "--directions", "0,90", "--no-plot",
                            "--no-progress"], capsys)
    assert code == 0, err
    assert "models on all samples (ranked by held-out RMS)" in text and out.exists()
