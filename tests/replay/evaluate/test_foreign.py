"""Foreign logs (replay.evaluate.foreign): a team's layout and nothing of the project's, the
same bytes from the same seed, poses off the truth by the stated sigma, a camera file that
describes the camera exactly, and a command that refuses bad values in one line."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from dsp import contract
from dsp.camera_file import read_camera_file
from estimator.detection import detect_ball
from replay.cli import main as replay_main
from replay.evaluate.foreign import (
    IMAGE_TOPIC,
    TRUTH_TOPIC,
    ForeignOptions,
    camera_entry,
    pose_streams,
    write_camera_file,
    write_foreign_log,
)
from replay.evaluate.foreign_cli import main as foreign_main
from replay.evaluate.foreign_render import Renderer
from replay.evaluate.foreign_scene import BALL_RADIUS_M, PoseError, pose_errors
from replay.evaluate.foreign_suite import (
    CHECK_SEEDS,
    FOREIGN_LOGS,
    REPORT_SEEDS,
    TUNE_SEEDS,
    ForeignTask,
    foreign_markdown,
    foreign_tasks,
    run_foreign_task,
)
from replay.profiles import without_reason

SMALL = ForeignOptions(seed=5, robots=2, rate_hz=10.0, duration_s=2.0, size_px=320)


def _read(path: Path) -> tuple[dict[str, str], list[str], list[tuple[str, object]]]:
    """The log's topics (topic -> schema name), metadata names and decoded messages."""
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None
        topics = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
        metadata = [m.name for m in reader.iter_metadata()]
        messages = [(ch.topic, msg) for _, ch, _, msg in reader.iter_decoded_messages()]
    return topics, metadata, messages


@pytest.mark.parametrize(("covariance", "image", "truth", "pose_schema", "image_schema",
                          "truth_schema"), [
    ("none", "jpeg", "odometry", contract.POSE_STAMPED, contract.COMPRESSED_IMAGE,
     contract.ODOMETRY),
    ("honest", "raw", "point", contract.POSE_WITH_COVARIANCE_STAMPED, contract.IMAGE,
     contract.POINT_STAMPED),
])
def test_the_log_is_a_teams_with_nothing_of_the_projects(
        tmp_path: Path, covariance: str, image: str, truth: str, pose_schema: str,
        image_schema: str, truth_schema: str) -> None:
    options = ForeignOptions(**{**SMALL.__dict__, "covariance": covariance, "image": image,
                                "truth": truth, "duration_s": 1.0})
    log = tmp_path / "team.mcap"
    write_foreign_log(log, options)
    topics, metadata, messages = _read(log)
    pose = "/{robot}/pose" if covariance == "none" else "/{robot}/amcl_pose"
    want = {TRUTH_TOPIC: truth_schema}
    for robot in ("r1", "r2"):
        want[IMAGE_TOPIC.format(robot=robot)] = image_schema
        want[pose.format(robot=robot)] = pose_schema
    assert topics == want
    assert metadata == []
    assert not any(t.startswith(("/tf", "/ground_truth")) for t in topics)
    stamps = [msg.header.stamp.sec for _, msg in messages]
    assert min(stamps) >= 1_700_000_000  # Unix time
    frames = {msg.header.frame_id for t, msg in messages
              if "pose" in t or t == TRUTH_TOPIC}
    assert frames == {"map"}


def test_the_same_seed_gives_the_same_bytes(tmp_path: Path) -> None:
    a, b, c = (tmp_path / f"{n}.mcap" for n in "abc")
    options = ForeignOptions(**{**SMALL.__dict__, "poses": "drift", "duration_s": 1.0})
    write_foreign_log(a, options)
    write_foreign_log(b, options)
    write_foreign_log(c, ForeignOptions(**{**options.__dict__, "seed": 6}))
    assert a.read_bytes() == b.read_bytes()
    assert a.read_bytes() != c.read_bytes()
    with pytest.raises(Exception, match="exists"):
        write_foreign_log(a, options)  # refused without force


def test_drifting_poses_are_off_by_the_stated_sigma() -> None:
    long = ForeignOptions(seed=3, robots=2, duration_s=900.0, poses="drift",
                          drift=(0.05, 1.0), tau_s=3.0)
    sigma_m, sigma_rad = long.pose_error.stated_sigma()
    for stream in pose_streams(long):
        err = stream.believed - stream.truth
        err[:, 2] = np.remainder(err[:, 2] + math.pi, math.tau) - math.pi
        assert np.std(err[:, 0]) == pytest.approx(sigma_m, rel=0.2)
        assert np.std(err[:, 1]) == pytest.approx(sigma_m, rel=0.2)
        assert np.std(err[:, 2]) == pytest.approx(sigma_rad, rel=0.2)
        assert abs(np.mean(err[:, 0])) < 0.5 * sigma_m
        # a drift, not a white noise: errors a pose apart (20 ms) nearly the same
        lag = np.corrcoef(err[:-1, 0], err[1:, 0])[0, 1]
        assert lag > 0.9
    exact = ForeignOptions(seed=3, robots=2, duration_s=30.0)
    for stream in pose_streams(exact):
        assert np.array_equal(stream.believed, stream.truth)


def test_the_gauss_markov_bias_forgets_over_its_time_constant() -> None:
    t = np.arange(0, 2000 * 10**9, 20 * 10**6, dtype=np.int64)  # 2000 s at 50 Hz
    err = pose_errors(np.random.default_rng(0), PoseError(0.1, 0.0, tau_s=2.0), t)[:, 0]
    lag = 100  # 2 s = tau: the correlation is exp(-1)
    r = np.corrcoef(err[:-lag], err[lag:])[0, 1]
    assert r == pytest.approx(math.exp(-1.0), abs=0.08)


def test_the_log_holds_the_poses_the_stream_gives(tmp_path: Path) -> None:
    options = ForeignOptions(**{**SMALL.__dict__, "poses": "drift", "duration_s": 1.0,
                                "covariance": "honest"})
    log = tmp_path / "drift.mcap"
    write_foreign_log(log, options)
    _, _, messages = _read(log)
    r1 = [msg for t, msg in messages if t == "/r1/amcl_pose"]
    stream = pose_streams(options)[0]
    assert len(r1) == len(stream.stamps_ns)
    xs = [m.pose.pose.position.x for m in r1]
    assert xs == pytest.approx(stream.believed[:, 0].tolist(), abs=1e-12)
    cov = r1[0].pose.covariance
    sigma_m, sigma_rad = options.pose_error.stated_sigma()
    assert (cov[0], cov[7], cov[35]) == pytest.approx((sigma_m**2, sigma_m**2, sigma_rad**2))


@pytest.mark.parametrize(("camera", "model"), [("own", "lookup"), ("mirror", "mirror")])
def test_the_camera_file_describes_the_camera(tmp_path: Path, camera: str, model: str) -> None:
    """The default detector's centroid of a ball rendered at a known place, read through the
    camera file's calibration, gives the ball's range and bearing back."""
    options = ForeignOptions(size_px=640, camera=camera)
    path = tmp_path / "cams.yaml"
    write_camera_file(path, options)
    spec = read_camera_file(path).for_robot("r1")
    assert spec is not None and spec.model == model
    assert spec.entry == camera_entry(options)
    cal, (cu, cv) = spec.range_calibration, spec.centre_px
    renderer = Renderer(options.model, options.field_spec, np.random.default_rng(0))
    rng = np.random.default_rng(1)
    for rho, bearing in ((0.8, 0.3), (2.0, -2.0), (4.0, 1.0), (6.0, 2.8), (8.0, -0.7)):
        ball = (rho * math.cos(bearing), rho * math.sin(bearing), BALL_RADIUS_M)
        det = detect_ball(renderer.render((0.0, 0.0, 0.0), ball, [], rng, BALL_RADIUS_M))
        assert det is not None
        du, dv = det.cx_px - cu, det.cy_px - cv
        assert cal.range_m(math.hypot(du, dv)) == pytest.approx(rho, rel=0.02, abs=0.02)
        assert math.atan2(-du, -dv) == pytest.approx(bearing, abs=0.01)


def test_an_exact_pose_log_replays_within_centimetres(tmp_path: Path) -> None:
    """The suite's task on a short log: drawn with its camera file, replayed as a team
    would, each robot's estimates and the fused ones within a few centimetres."""
    options = ForeignOptions(seed=7, robots=3, rate_hz=10.0, duration_s=2.0, size_px=320)
    task = ForeignTask("exact", tmp_path / "exact.mcap", options)
    score = run_foreign_task(task)
    assert task.cameras.exists()
    assert score.pipeline.startswith("pipeline (best):")
    errors = [e for errs in score.robots.values() for e in errs]
    assert len(errors) > 20
    assert float(np.median(errors)) < 0.05
    st = score.scores.stats()
    assert st["estimates"] > 10 and st["median_m"] < 0.05
    assert st["velocity_median_m_s"] is not None
    ground = score.ground.stats()
    assert ground["estimates"] <= st["estimates"]
    doc = {"set": "test", "duration_s": 2.0, "image_px": 320, "pooled": st,
           "pooled_ground": ground, "logs": [{"label": "exact", "seed": 7, "fused": st,
                                              "ground": ground, "pipeline": score.pipeline}]}
    text = foreign_markdown(doc)
    assert "| exact | 7 |" in text and "(chosen: " in score.pipeline
    # the footnote is the pipeline without why its detector was chosen (it differs by log)
    assert "1. " + without_reason(score.pipeline) in text
    assert without_reason("pipeline (best): paper detector (chosen: its images (the colour "
                          "chain) say so), corrected ranges") == (
        "pipeline (best): paper detector, corrected ranges")


def test_the_suite_keeps_tune_and_report_seeds_apart(tmp_path: Path) -> None:
    assert not set(TUNE_SEEDS) & set(REPORT_SEEDS)
    assert not (set(TUNE_SEEDS) | set(REPORT_SEEDS)) & set(CHECK_SEEDS)
    assert len(TUNE_SEEDS) == len(REPORT_SEEDS) == len(CHECK_SEEDS) == len(FOREIGN_LOGS)
    drifts = {log.drift for log in FOREIGN_LOGS}
    assert drifts == {None, (0.02, 0.5), (0.05, 1.0), (0.10, 2.0)}
    assert {log.covariance for log in FOREIGN_LOGS} == {False, True}
    assert {log.rate_hz for log in FOREIGN_LOGS} == {20.0, 30.0}
    assert {log.robots for log in FOREIGN_LOGS} == {2, 3, 4, 5}
    assert {log.camera for log in FOREIGN_LOGS} == {"own", "mirror"}
    named = [log for log in FOREIGN_LOGS if log.field]  # a team's file naming its field
    assert named and {log.camera for log in named} == {"mirror"}
    assert {log.drift for log in named} >= {None, (0.10, 2.0)}
    tasks = foreign_tasks(tmp_path, seeds=REPORT_SEEDS, duration_s=10.0)
    assert len({t.log.name for t in tasks}) == len(tasks)
    assert [t.options.names_field for t in tasks] == [log.field for log in FOREIGN_LOGS]


def test_a_camera_file_naming_the_field_gets_the_line_fit(tmp_path: Path) -> None:
    o = ForeignOptions(seed=7, robots=3, rate_hz=15.0, duration_s=4.0, camera="mirror",
                       poses="drift", drift=(0.10, 2.0))
    log = tmp_path / "team.mcap"
    write_foreign_log(log, o)
    runs = {}
    for named in (False, True):
        cams = tmp_path / f"named-{named}.cameras.yaml"
        write_camera_file(cams, dataclasses.replace(o, names_field=named))
        assert (read_camera_file(cams).field is not None) is named
        out = tmp_path / f"named-{named}.json"
        assert replay_main([str(log), "--cameras", str(cams), "--image-topic", IMAGE_TOPIC,
                            "--pose-topic", "/{robot}/pose", "--truth-topic", TRUTH_TOPIC,
                            "--out", str(out), "--quiet"]) == 0
        runs[named] = json.loads(out.read_text())
    assert runs[False]["pipeline"]["poses"] == "ball"
    assert runs[True]["pipeline"]["poses"] == "lines"
    rmse = {k: math.sqrt(np.mean([s["error_m"] ** 2 for s in r["fused"]
                                  if s.get("error_m") is not None]))
            for k, r in runs.items()}
    assert rmse[True] < 0.5 * rmse[False], rmse  # 10 cm / 2 deg of drift: the lines fix it


@pytest.mark.parametrize("argv", [
    ["--robots", "0"], ["--robots", "two"], ["--rate", "x"], ["--rate", "500"],
    ["--poses", "wobbly"], ["--drift", "0.05", "--poses", "drift"],
    ["--drift", "a,b", "--poses", "drift"], ["--image", "png"],
    ["--drift", "0.05,1"], ["--tau", "5"],  # with exact poses: they would be ignored
    ["--duration", "-1"], ["--covariance", "sometimes"], ["--seed", "-3"], ["--size", "nan"],
])
def test_bad_values_are_refused_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                            argv: list[str]) -> None:
    out = tmp_path / "x.mcap"
    assert foreign_main([str(out), *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and argv[0] in err[0], err
    assert not out.exists()


def test_the_command_writes_the_log_and_says_how_to_replay_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "cli.mcap"
    assert foreign_main([str(out), "--seed", "2", "--robots", "2", "--duration", "0.5",
                         "--size", "160", "--poses", "drift", "--drift", "0.02,0.5"]) == 0
    assert out.exists() and (tmp_path / "cli.cameras.yaml").exists()
    said = capsys.readouterr().out
    assert "dsp-replay" in said and "--truth-topic /mocap/ball" in said
    assert foreign_main([str(out), "--duration", "0.5"]) == 3  # exists: refused


def test_the_suite_refuses_switches_it_does_not_replay_with(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from replay.evaluate.cli import main as eval_main

    assert eval_main(["--suite", "foreign", "--realism", "field", "--out-dir",
                      str(tmp_path), "--no-progress"]) == 2
    assert "--realism" in capsys.readouterr().err
    assert not (tmp_path / "foreign").exists()


def test_options_refuse_what_they_cannot_draw() -> None:
    with pytest.raises(ValueError, match="poses = 'wobbly'"):
        ForeignOptions(poses="wobbly")
    with pytest.raises(ValueError, match="a robot"):
        ForeignOptions(robots=0)
