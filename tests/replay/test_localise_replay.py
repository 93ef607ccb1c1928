"""``--localise lines`` in a replay: each frame's pose corrected from the field lines in its
own image before the ball is located, beside the believed pose in every output; the same
bytes whatever the thread count; the default replay untouched."""

from __future__ import annotations

import csv
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from synthetic import write_log

from replay import ReplayOptions, replay
from replay.cli import main
from replay.options import RerunTarget
from replay.sinks import ResultsCollector
from replay.sinks.csv_export import CSV_COLUMNS, LOCALISATION_COLUMNS

ROBOTS = {"robot1": (-4.0, 1.0, 0.3), "robot2": (-1.0, -2.5, 2.0), "robot3": (2.5, 2.0, -2.4)}
BALL = (0.2, 0.4)
BIAS_M = {"robot1": (0.07, -0.05), "robot2": (-0.06, 0.04), "robot3": (0.05, 0.06)}
BIAS_YAW = {"robot1": math.radians(1.2), "robot2": math.radians(-0.9), "robot3": 0.0}


@pytest.fixture(scope="module")
def carpet_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("loc") / "carpet.mcap"
    write_log(path, robots=ROBOTS, ball=BALL, duration_s=0.6, image_hz=5.0, pose_hz=20.0,
              carpet=True, pose_bias_m=BIAS_M, yaw_bias_rad=BIAS_YAW)
    return path


def _replay(log: Path, **kw: object) -> ResultsCollector:
    col = ResultsCollector()
    replay(log, ReplayOptions(progress=False, quiet=True, **kw), sinks=[col])  # type: ignore[arg-type]
    return col


def test_poses_are_corrected_and_the_ball_located_from_them(carpet_log: Path) -> None:
    believed = _replay(carpet_log, threads=1)
    lines = _replay(carpet_log, localise="lines", threads=1)
    assert all("localisation" not in f for f in believed.frames)
    assert len(lines.frames) == len(believed.frames) == 12
    for f, b in zip(lines.frames, believed.frames, strict=True):
        x, y, yaw = ROBOTS[f["robot"]]
        loc = f["localisation"]
        assert loc["source"] == "lines" and loc["status"] == "ok"
        assert math.hypot(loc["x_m"] - x, loc["y_m"] - y) < 0.01
        assert abs(loc["yaw_rad"] - yaw) < math.radians(0.1)
        assert f["pose"] == b["pose"]  # the believed pose, as without --localise
        sd = [math.sqrt(loc["covariance"][i][i]) for i in range(3)]
        assert sd[0] < 0.05 and sd[2] < math.radians(1.0)  # tighter than the prior
    # the same images with exact poses: the ball located from them is what the lines give
    exact = _replay(_exact_log(carpet_log), threads=1)
    for f, b, e in zip(lines.frames, believed.frames, exact.frames, strict=True):
        gap = math.hypot(f["estimate"]["x_m"] - e["estimate"]["x_m"],
                         f["estimate"]["y_m"] - e["estimate"]["y_m"])
        before = math.hypot(b["estimate"]["x_m"] - e["estimate"]["x_m"],
                            b["estimate"]["y_m"] - e["estimate"]["y_m"])
        assert gap < 0.01 and before > 0.02 and gap < before / 5


def _exact_log(biased: Path) -> Path:
    path = biased.with_name("exact.mcap")
    if not path.exists():
        write_log(path, robots=ROBOTS, ball=BALL, duration_s=0.6, image_hz=5.0,
                  pose_hz=20.0, carpet=True)
    return path


def test_same_bytes_whatever_the_thread_count(carpet_log: Path, tmp_path: Path) -> None:
    outs = []
    for threads in (1, 3):
        out = tmp_path / f"r{threads}.json"
        replay(carpet_log, ReplayOptions(localise="lines", threads=threads, out=out,
                                         progress=False, quiet=True))
        outs.append(out.read_bytes())
    assert outs[0] == outs[1]
    doc = json.loads(outs[0])
    assert doc["options"]["localise"] == "lines"
    assert "pose_sigma_m" not in doc["options"]  # learnt from the fits: none was given
    assert {r: b["line_fits"] for r, b in doc["summary"]["learnt"].items()} == {
        "robot1": 4, "robot2": 4, "robot3": 4}
    assert doc["summary"]["localisation"] == {"sources": {"lines": 12}, "statuses": {"ok": 12}}


def test_the_default_replay_has_no_localisation(carpet_log: Path, tmp_path: Path) -> None:
    out, table = tmp_path / "r.json", tmp_path / "r.csv"
    replay(carpet_log, ReplayOptions(out=out, out_csv=table, progress=False, quiet=True))
    doc = json.loads(out.read_text())
    assert "localise" not in doc["options"] and "localisation" not in doc["summary"]
    with table.open() as f:
        assert tuple(next(csv.reader(f))) == CSV_COLUMNS


def test_csv_columns_and_cli(carpet_log: Path, tmp_path: Path,
                             capsys: pytest.CaptureFixture[str]) -> None:
    table = tmp_path / "r.csv"
    assert main([str(carpet_log), "--localise", "lines", "--pose-sigma", "0.1,2",
                 "--out-csv", str(table), "--threads", "1"]) == 0
    assert "poses corrected (from): lines 12" in capsys.readouterr().out
    with table.open() as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0]) == CSV_COLUMNS + LOCALISATION_COLUMNS
    frames = [r for r in rows if r["kind"] == "frame"]
    assert all(r["pose_source"] == "lines" for r in frames)
    assert all(r["corrected_x_m"] != r["robot_x_m"] for r in frames)
    assert all(r["pose_source"] == "" for r in rows if r["kind"] == "fused")


def test_a_robot_without_a_camera_model_keeps_its_belief(tmp_path: Path) -> None:
    log = tmp_path / "plain.mcap"
    write_log(log, duration_s=0.4, image_hz=5.0)
    plain = _replay(log, threads=1)
    lines = _replay(log, localise="lines", threads=1)
    for f, b in zip(lines.frames, plain.frames, strict=True):
        loc = f["localisation"]
        assert loc["status"] == "no_camera" and loc["source"] == "prior"
        assert (loc["x_m"], loc["y_m"], loc["yaw_rad"]) == (
            b["pose"]["x_m"], b["pose"]["y_m"], b["pose"]["yaw_rad"])
        assert f["estimate"] == b["estimate"]


@pytest.mark.parametrize(("args", "message"), [
    (["--localise", "everything"], "invalid choice"),
    (["--localise", "lines", "--pose-sigma", "0.05"], "M,DEG"),
    (["--localise", "lines", "--pose-sigma", "0,1"], "--pose-sigma"),
])
def test_bad_options_are_one_line(carpet_log: Path, args: list[str], message: str,
                                  capsys: pytest.CaptureFixture[str]) -> None:
    try:
        code = main([str(carpet_log), *args])
    except SystemExit as exc:  # argparse's own errors
        code = int(str(exc.code))
    assert code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_the_viewer_shows_the_corrected_pose_beside_the_believed_one(
        carpet_log: Path, tmp_path: Path) -> None:
    chunk = pytest.importorskip("rerun.chunk")
    rrd = tmp_path / "r.rrd"
    col = ResultsCollector()
    replay(carpet_log, ReplayOptions(localise="lines", threads=1, progress=False, quiet=True,
                                     rerun=RerunTarget("save", str(rrd))), sinks=[col])
    centres: dict[str, list[tuple[float, float]]] = {}
    labels: dict[str, list[str]] = {}
    lines_seen = set()
    believed_labels: dict[str, list[str]] = {}
    shown: set[object] = set()
    for ch in chunk.RrdReader(rrd).stream():
        path = ch.entity_path
        batch = ch.to_record_batch().to_pydict()
        if path.endswith("/corrected") and "Boxes3D:centers" in batch:
            robot = path.split("/")[3]
            centres.setdefault(robot, []).extend(
                (c[0][0], c[0][1]) for c in batch["Boxes3D:centers"] if c)
            labels.setdefault(robot, []).extend(
                lab[0] for lab in batch.get("Boxes3D:labels", []) if lab)
        if path.count("/") == 3 and path.startswith("/field/robots/") and (
                "Boxes3D:labels" in batch):  # the believed pose's box
            believed_labels.setdefault(path.split("/")[3], []).extend(
                lab[0] for lab in batch["Boxes3D:labels"] if lab)
        if path.endswith("/corrected") and "Boxes3D:show_labels" in batch:
            shown.update(tuple(v) for v in batch["Boxes3D:show_labels"] if v)
        if path.endswith("/camera/lines") and "Points2D:positions" in batch:
            lines_seen.update(path.split("/")[2] for p in batch["Points2D:positions"]
                              if p and len(p) > 20)
    assert set(centres) == set(ROBOTS) == lines_seen
    for robot, got in centres.items():
        want = [(f["localisation"]["x_m"], f["localisation"]["y_m"]) for f in col.frames
                if f["robot"] == robot]
        assert len(got) == len(want)
        for (gx, gy), (wx, wy) in zip(got, want, strict=True):  # float32 in the recording
            assert abs(gx - wx) < 1e-5 and abs(gy - wy) < 1e-5
        # the believed pose is 6-9 cm off, and the label says so, in words
        said = [re.fullmatch(rf"{robot} \(pose corrected (\d+\.\d) cm, [+-]\d+\.\d\d° "
                             r"from the field lines\)", lab) for lab in labels[robot]]
        assert all(said), labels[robot][:3]
        first = said[0]
        assert first is not None and 5.0 < float(first.group(1)) < 12.0
        # the two boxes lie centimetres apart: both labels show on hovering (the name is
        # written beside the believed one), and they give the same correction
        assert believed_labels[robot] == labels[robot]
    assert shown == {(False,)}


def test_a_camera_turned_on_its_robot_is_turned_back() -> None:
    from field_images import render_carpet

    from dsp.field import FIELDS
    from estimator.camera import make_camera
    from estimator.geometry import RobotPose
    from replay.localise import Localiser

    camera = make_camera("ideal", cu_px=539.0, cv_px=539.0)
    true, mount = RobotPose(-2.0, 1.5, 0.4), math.radians(35.0)
    # the image up shows the robot-frame direction mount: as from a robot turned by it
    image = render_carpet(camera, RobotPose(true.x_m, true.y_m, true.yaw_rad + mount))
    believed = RobotPose(true.x_m + 0.04, true.y_m - 0.03, true.yaw_rad + math.radians(0.8))
    errors = {}
    for name, yaw in (("turned back", mount), ("not", 0.0)):
        loc = Localiser(FIELDS["18x12"], {"r": camera}, sigma_m=0.05, sigma_deg=1.0,
                        mount_yaw_rad={"r": yaw})
        fit = loc.fit(loc.points("r", image), believed)
        assert fit is not None
        got = fit.pose if fit.status.value == "ok" else believed
        errors[name] = (math.hypot(got.x_m - true.x_m, got.y_m - true.y_m),
                        abs(got.yaw_rad - true.yaw_rad))
    assert errors["turned back"][0] < 0.01 and errors["turned back"][1] < math.radians(0.1)
    assert errors["not"][0] > 0.02 or errors["not"][1] > math.radians(0.5)


def test_the_line_points_pixels_are_worked_out_only_for_a_viewer() -> None:
    """The line points' place in the image (what the viewer draws) is their ground point
    seen through the camera, in the camera's own frame however it is turned on the robot;
    it is worked out when first asked for, so a replay with no viewer never pays for it."""
    from field_images import render_carpet

    from dsp.field import FIELDS
    from estimator.camera import make_camera
    from estimator.geometry import RobotPose
    from replay.localise import Localiser

    camera = make_camera("ideal", cu_px=539.0, cv_px=539.0)
    image = render_carpet(camera, RobotPose(-2.0, 1.5, 0.4))
    loc = Localiser(FIELDS["18x12"], {"r": camera}, sigma_m=0.05, sigma_deg=1.0,
                    mount_yaw_rad={"r": math.radians(35.0)})
    points = loc.points("r", image)
    assert points is not None and len(points.points) > 100
    settled = loc.settle("r", 0, RobotPose(-2.0, 1.5, 0.4), loc.fit(points, RobotPose(
        -2.0, 1.5, 0.4)), points)
    assert "pixels" not in vars(points)  # not worked out yet
    pixels = settled.pixels
    assert pixels is not None and pixels.shape == (len(points.points), 2)
    # each pixel reads the white line the point was found on (the points are in the robot's
    # frame, turned by the mount; the pixels in the image's)
    uv = np.round(pixels).astype(int)
    assert np.median(image[uv[:, 1], uv[:, 0]].min(axis=1)) > 150
    back = camera.pixel_to_ray(pixels[:, 0].astype(np.float64), pixels[:, 1].astype(np.float64))
    ground = back[:, :2] * (camera.height_m / -back[:, 2:3])
    c, s = math.cos(math.radians(35.0)), math.sin(math.radians(35.0))
    turned = points.points.xy_m @ np.array([[c, -s], [s, c]])  # robot frame -> camera's
    assert np.allclose(ground, turned, atol=0.01)
