"""The match scenario as recorded: deterministic per seed, free-running camera phases, a
drifting localisation bias, the ball's true velocity, distractors that look like a ball."""

from __future__ import annotations

import hashlib
import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from dsp import contract as c
from dsp.errors import UsageError
from dsp.metadata import RecordingMetadata, ScenarioMetadata
from estimator import corrected, detection
from estimator.calibration import CameraCalibration
from estimator.camera import make_camera
from estimator.geometry import RobotPose
from recorder.effects import PoseDrift
from recorder.field import field_spec
from recorder.omni import OmniRenderer
from recorder.record import RecordOptions, record
from recorder.scenarios import make_scenario
from recorder.world import World

ROBOTS = ("robot1", "robot2", "robot3")
FAST = {"face_px": 256, "renderer": "tiny"}
"""Small faces and TinyRenderer: a few frames record in about a second."""

Messages = dict[str, list[tuple[int, Any]]]


def _read(path: Path) -> tuple[Messages, dict[str, Any]]:
    """topic -> [(log_time_ns, decoded)] and the recording's metadata JSON."""
    topics: Messages = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _s, channel, message, decoded in reader.iter_decoded_messages():
            topics.setdefault(channel.topic, []).append((message.log_time, decoded))
        f.seek(0)
        meta = {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}
    return topics, ScenarioMetadata.from_metadata(meta[c.SCENARIO_METADATA]).params()


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Short matches of seed 3: twice as they come (random phases), once in sync with a
    drifting bias (no white noise), once with blur, gain and noise."""
    d = tmp_path_factory.mktemp("match")
    runs = {
        "a": {}, "b": {},
        "sync": {"camera_phase": "sync", "pose_bias_m": 0.05, "yaw_bias_deg": 1.0,
                 "pose_bias_tau_s": 5.0},
        "noisy": {"exposure_ms": 8.0, "image_noise": 3.0, "gain_jitter": 0.1},
    }
    out = {}
    for name, opts in runs.items():
        path = d / f"{name}.mcap"
        record(path, RecordOptions(scenario="match", seed=3, frames=3, **FAST, **opts))  # type: ignore[arg-type]
        out[name] = path
    return out


def test_same_seed_same_bytes_other_seed_other_match(logs: dict[str, Path]) -> None:
    assert _sha(logs["a"]) == _sha(logs["b"])
    assert make_scenario("match", 3) == make_scenario("match", 3)
    assert make_scenario("match", 3).play != make_scenario("match", 4).play


def _image_stamps(topics: Messages) -> dict[str, list[int]]:
    return {r: [t for t, _ in topics[c.topic_for(c.IMAGE_TOPIC, r)]] for r in ROBOTS}


def test_random_phases_never_share_a_stamp_sync_phases_always_do(
        logs: dict[str, Path]) -> None:
    topics, params = _read(logs["a"])
    stamps = _image_stamps(topics)
    every = [t for s in stamps.values() for t in s]
    assert len(every) == 3 * len(ROBOTS) and len(set(every)) == len(every)
    rec = params["recording"]
    assert rec["camera_phase"] == "random" and rec["rate_hz"] == 20.0
    assert {r: s[0] for r, s in stamps.items()} == rec["camera_offsets_ns"]
    for s in stamps.values():  # each camera still fires at its own steady rate
        assert {b - a for a, b in itertools.pairwise(s)} == {12 * 4_166_667}
    sync, sync_params = _read(logs["sync"])
    sync_stamps = _image_stamps(sync)
    assert sync_stamps["robot1"] == sync_stamps["robot2"] == sync_stamps["robot3"]
    assert sync_params["recording"]["camera_phase"] == "sync"


def test_drifting_bias_is_correlated_from_message_to_message(logs: dict[str, Path]) -> None:
    topics, params = _read(logs["sync"])
    assert params["recording"]["pose_bias_m"] == 0.05
    sizes, steps = [], []
    for robot in ROBOTS:
        believed = topics[c.topic_for(c.POSE_TOPIC, robot)]
        truth = topics[c.topic_for(c.GT_POSE_TOPIC, robot)]
        err = np.array([(b.pose.position.x - g.pose.position.x,
                         b.pose.position.y - g.pose.position.y)
                        for (_, b), (_, g) in zip(believed, truth, strict=True)])
        assert len(err) == 36  # 240 Hz over 3 frames at 20 Hz
        sizes.append(np.abs(err).mean())
        steps.append(np.abs(np.diff(err, axis=0)).mean())
    # sigma 5 cm: the errors are centimetres, but an OU step at dt = 1/240 s, tau = 5 s
    # moves ~4% of sigma (~2 mm), where white noise of that size would move ~5 cm
    assert np.mean(sizes) > 0.01, sizes
    assert max(steps) < 0.1 * 0.05, steps


def test_pose_drift_is_an_ou_process_with_the_stated_spread() -> None:
    drift = PoseDrift(["r"], 0, pose_bias_m=0.1, yaw_bias_deg=0.0, tau_s=0.5, dt_s=0.05)
    xs = np.array([drift.step()["r"][0] for _ in range(4000)])
    assert 0.08 < xs.std() < 0.12
    lag1 = np.corrcoef(xs[:-1], xs[1:])[0, 1]
    assert abs(lag1 - math.exp(-0.05 / 0.5)) < 0.05
    assert PoseDrift(["r"], 0, pose_bias_m=0, yaw_bias_deg=0, tau_s=1, dt_s=1).step() == {}


def test_truth_odometry_velocity_is_the_derivative_of_the_truth(logs: dict[str, Path]) -> None:
    topics, params = _read(logs["a"])
    assert params["recording"]["ball_odometry"] is True
    odom = topics[c.GT_BALL_ODOMETRY_TOPIC]
    pos = topics[c.GT_BALL_TOPIC]
    assert [t for t, _ in odom] == [t for t, _ in pos]
    assert all(m.header.frame_id == c.FIELD_FRAME for _, m in odom)
    t = np.array([s for s, _ in odom]) / 1e9
    xy = np.array([(m.pose.pose.position.x, m.pose.pose.position.y) for _, m in odom])
    v = np.array([(m.twist.twist.linear.x, m.twist.twist.linear.y) for _, m in odom])
    assert np.allclose(xy, [(m.pose.position.x, m.pose.position.y) for _, m in pos])
    fd = (xy[2:] - xy[:-2]) / (t[2:] - t[:-2])[:, None]
    diff = np.linalg.norm(fd - v[1:-1], axis=1)
    speed = np.linalg.norm(v, axis=1)
    assert speed.max() > 1.5  # kicked at t = 0: the ball is moving
    assert np.median(diff) < 0.02 and np.percentile(diff, 90) < 0.1, diff


@pytest.mark.parametrize(("yaw_deg", "seen"), [(40.0, True), (0.0, False)])
def test_distractor_turned_is_taken_for_a_ball_where_it_stands(yaw_deg: float,
                                                               seen: bool) -> None:
    """An orange box beside the field, the ball out of sight: turned, the colour threshold
    takes the box for a ball and the estimate lands on the box; square-on (a fill ratio no
    ball has) it is refused."""
    camera = make_camera("ideal")
    with World(field_spec("18x12"), renderer="tiny") as world:
        world.add_distractor(3.0, 6.8, 0.25, math.radians(yaw_deg))
        world.set_ball(-30.0, -3.0)  # far outside the field, out of every camera's sight
        world.add_robot("robot1")
        world.set_robot_pose("robot1", 0.5, 5.0, 0.0)
        omni = OmniRenderer(camera, face_px=256, renderer="tiny")
        img = omni.render(world, "robot1", 0.5, 5.0, 0.0)
    det = detection.detect_ball(img)
    assert (det is not None) == seen
    if det is not None:
        e = corrected.estimate_ball(det.cx_px, det.cy_px, RobotPose(0.5, 5.0, 0.0),
                                    CameraCalibration(camera), centre_px=camera.centre_px)
        assert math.hypot(e.x_m - 3.0, e.y_m - 6.8) < 0.4


def test_ball_in_sight_outranks_a_distractor() -> None:
    camera = make_camera("ideal")
    with World(field_spec("18x12"), renderer="tiny") as world:
        world.add_distractor(3.0, 6.8, 0.25, math.radians(40.0))
        world.set_ball(-1.0, 3.0)
        world.add_robot("robot1")
        omni = OmniRenderer(camera, face_px=256, renderer="tiny")
        img = omni.render(world, "robot1", 0.5, 5.0, 0.0)
    assert len(detection.detect_blobs(img)) == 2
    det = detection.detect_ball(img)
    assert det is not None
    e = corrected.estimate_ball(det.cx_px, det.cy_px, RobotPose(0.5, 5.0, 0.0),
                                CameraCalibration(camera), centre_px=camera.centre_px)
    assert math.hypot(e.x_m + 1.0, e.y_m - 3.0) < 0.2


def test_distractors_stand_beside_the_field_and_change_nothing_else() -> None:
    plain, busy = make_scenario("match", 5), make_scenario("match", 5, distractors=4)
    assert plain.play is not None and busy.play is not None
    assert busy.play.kicks == plain.play.kicks and busy.robots == plain.robots
    spec = field_spec("18x12")
    assert len(busy.play.distractors) == 4
    for d in busy.play.distractors:
        assert abs(d.x_m) > spec.half_length_m + 0.3 or abs(d.y_m) > spec.half_width_m + 0.3
        assert abs(d.x_m) < spec.half_length_m + spec.border_m
        assert abs(d.y_m) < spec.half_width_m + spec.border_m
    with pytest.raises(UsageError, match="match scenario"):
        make_scenario("rolling", 0, distractors=1)


def test_match_kicks_are_passes_and_shots_at_two_to_eight_metres_a_second() -> None:
    kicks = [k for s in range(10) for k in make_scenario("match", s).play.kicks  # type: ignore[union-attr]
             if k.t_s < 10]
    assert all(2.0 <= k.speed_mps <= 8.0 for k in kicks)
    assert {k.target_robot is None for k in kicks} == {True, False}
    assert all(k.t_s == 0 for k in kicks[:1])


def test_recording_metadata_keeps_old_logs_and_reads_the_new_keys() -> None:
    base = {"rate_hz": 5.0, "pose_rate_hz": 10.0, "frames": 3, "camera": "ideal",
            "image_format": "png", "pose_noise_m": 0.0, "yaw_noise_deg": 0.0, "face_px": 256,
            "physics_hz": 240}
    old = RecordingMetadata.from_json(base)
    assert old.to_json() == base and old.camera_phase is None
    new = {**base, "camera_phase": "random", "camera_offsets_ns": {"robot1": 4166667},
           "ball_odometry": True, "exposure_ms": 4.0}
    assert RecordingMetadata.from_json(new).to_json() == new
    with pytest.raises(ValueError, match="ball_odometry"):
        RecordingMetadata.from_json({**base, "ball_odometry": "yes"})


@pytest.mark.parametrize(("opts", "message"), [
    ({"camera_phase": "late"}, "unknown camera phase"),
    ({"exposure_ms": -1.0}, r"--exposure -1.0: give a finite number in \[0, 100\] ms"),
    ({"pose_bias_tau_s": 0.0}, "--pose-bias-tau"),
])
def test_bad_match_options_are_refused(opts: dict[str, Any], message: str) -> None:
    with pytest.raises(UsageError, match=message):
        RecordOptions(scenario="match", **opts)


def test_pose_rate_must_be_a_multiple_of_the_camera_rate(tmp_path: Path) -> None:
    with pytest.raises(UsageError, match="whole multiple"):
        record(tmp_path / "m.mcap", RecordOptions(scenario="match", frames=1, rate_hz=7.0,
                                                  **FAST))  # type: ignore[arg-type]
    with pytest.raises(UsageError, match="random camera phases"):
        record(tmp_path / "s.mcap", RecordOptions(scenario="scenario1", frames=1,
                                                  camera_phase="random", **FAST))  # type: ignore[arg-type]


def test_effects_change_the_images_only(logs: dict[str, Path]) -> None:
    """Blur, gain and noise leave poses and truth alone (their draws are their own)."""
    _, params = _read(logs["noisy"])
    assert params["recording"]["exposure_ms"] == 8.0
    a, b = _raw(logs["a"]), _raw(logs["noisy"])
    assert a.keys() == b.keys()
    for topic in a:
        assert (a[topic] == b[topic]) == ("image" not in topic), topic


def _raw(path: Path) -> dict[str, list[bytes]]:
    out: dict[str, list[bytes]] = {}
    with open(path, "rb") as f:
        for _s, channel, message in make_reader(f).iter_messages():
            out.setdefault(channel.topic, []).append(message.data)
    return out


def test_dsp_record_takes_the_match_flags(tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    from recorder import cli

    out = tmp_path / "m.mcap"
    assert cli.main([str(out), "--scenario", "match", "--frames", "1", "--camera-phase", "sync",
                     "--distractors", "1", "--pose-bias", "0.02", "--gain-jitter", "0.05",
                     "--face-px", "256", "--renderer", "tiny", "-q"]) == 0
    _, params = _read(out)
    rec = params["recording"]
    assert (rec["camera_phase"], rec["pose_bias_m"], rec["gain_jitter"]) == ("sync", 0.02, 0.05)
    assert len(params["play"]["distractors"]) == 1
    assert cli.main([str(tmp_path / "r.mcap"), "--scenario", "rolling", "--distractors", "2",
                     "--renderer", "tiny", "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--distractors is for the match scenario" in err[0]
