"""The recorded log: contract topics and metadata, independent readers, determinism, errors.

Recordings here are tiny (a few frames, small cube faces) so the file stays quick; the
renderer is whatever World picks (EGL here; DSP_RENDERER=tiny forces TinyRenderer).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from dsp import contract as c
from dsp.errors import OutputExistsError, UsageError
from estimator.camera import camera_from_dict, make_camera
from recorder.cli import main
from recorder.errors import UnknownScenarioError
from recorder.record import RecordingInterrupted, RecordOptions, RecordSummary, record

SMALL: dict[str, Any] = {"face_px": 256}
ROBOTS = ["robot1", "robot2", "robot3"]


def expected_topics(robots: list[str]) -> set[str]:
    topics = {c.TF_TOPIC, c.GT_BALL_TOPIC}
    for r in robots:
        topics |= {c.topic_for(p, r) for p in (c.IMAGE_TOPIC, c.POSE_TOPIC, c.GT_POSE_TOPIC)}
    return topics


def read_all(path: Path) -> tuple[dict[str, list[tuple[int, int, object]]], dict[str, dict]]:
    """topic -> [(log_time, publish_time, decoded)], metadata name -> dict (mcap's reader)."""
    out: dict[str, list[tuple[int, int, object]]] = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _schema, channel, message, decoded in reader.iter_decoded_messages():
            out.setdefault(channel.topic, []).append(
                (message.log_time, message.publish_time, decoded))
        f.seek(0)
        meta = {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}
    return out, meta


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, RecordSummary]:
    path = tmp_path_factory.mktemp("log") / "scenario1.mcap"
    summary = record(path, RecordOptions(frames=2, pose_noise_m=0.05, yaw_noise_deg=2.0, **SMALL))
    return path, summary


def test_summary(log: tuple[Path, RecordSummary]) -> None:
    path, s = log
    assert s.path == path and path.exists()
    assert (s.scenario, s.seed, s.frames, s.robots, s.camera) == ("scenario1", 0, 2, 3, "ideal")
    assert s.renderer in ("egl", "tiny")
    assert s.file_size_bytes == path.stat().st_size
    assert s.sim_duration_ns == 300_000_000  # 2 frames at 5 Hz, poses every 100 ms
    assert not list(path.parent.glob(".*.tmp"))


def test_contract_topics_stamps_and_rates(log: tuple[Path, RecordSummary]) -> None:
    path, _ = log
    msgs, _ = read_all(path)
    assert set(msgs) == expected_topics(ROBOTS)
    for topic, items in msgs.items():
        for log_time, publish_time, m in items:
            assert log_time == publish_time
            stamps = ([t.header.stamp for t in m.transforms] if topic == c.TF_TOPIC
                      else [m.header.stamp])
            assert all(c.stamp_to_ns(s) == log_time for s in stamps)
    image_times = [t for t, _, _ in msgs["/robot1/omni/image/compressed"]]
    pose_times = [t for t, _, _ in msgs["/robot1/pose"]]
    assert image_times == [0, 200_000_000]
    assert pose_times == [0, 100_000_000, 200_000_000, 300_000_000]  # 2x the camera rate


def test_messages_content(log: tuple[Path, RecordSummary]) -> None:
    path, _ = log
    msgs, _ = read_all(path)
    _, _, img_msg = msgs["/robot2/omni/image/compressed"][0]
    assert img_msg.format == "png"
    assert img_msg.header.frame_id == "robot2/omni"
    img = cv2.imdecode(np.frombuffer(bytes(img_msg.data), np.uint8), cv2.IMREAD_COLOR)
    assert img.shape == (1080, 1080, 3)
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    assert cv2.inRange(hsv, (4, 120, 60), (24, 255, 255)).any(), "robot2 should see the ball"
    _, _, gt = msgs["/ground_truth/robot3/pose"][0]
    assert gt.header.frame_id == "field"
    assert (gt.pose.position.x, gt.pose.position.y) == (-2.0, -1.0)
    q = gt.pose.orientation
    assert (q.x, q.y, q.z, q.w) == (0.0, 0.0, 0.0, 1.0)
    _, _, believed = msgs["/robot3/pose"][1]
    assert believed.pose.position.x != -2.0  # --pose-noise 0.05
    assert abs(believed.pose.position.x + 2.0) < 0.5
    _, _, ball = msgs["/ground_truth/ball"][-1]
    assert math.hypot(ball.pose.position.x, ball.pose.position.y) < 1e-3
    assert ball.pose.position.z == pytest.approx(0.11, abs=2e-3)
    _, _, tf = msgs["/tf"][0]
    assert [t.child_frame_id for t in tf.transforms] == ROBOTS
    assert all(t.header.frame_id == "field" for t in tf.transforms)


def test_metadata(log: tuple[Path, RecordSummary]) -> None:
    path, s = log
    _, meta = read_all(path)
    sc = meta[c.SCENARIO_METADATA]
    assert (sc["name"], sc["seed"]) == ("scenario1", "0")
    params = json.loads(sc["params"])
    assert params["ball_xy_m"] == [0.0, 0.0]
    assert params["recording"]["frames"] == 2
    cams = meta[c.CAMERAS_METADATA]
    assert sorted(cams) == ROBOTS
    assert camera_from_dict(json.loads(cams["robot1"])) == make_camera("ideal")
    rec = meta[c.RECORDER_METADATA]
    assert rec["renderer"] == s.renderer
    assert {"pybullet", "numpy", "dual_sight", "mcap"} <= set(rec)


def test_rosbags_reads_it(log: tuple[Path, RecordSummary]) -> None:
    from rosbags.highlevel import AnyReader

    path, _ = log
    with AnyReader([path]) as reader:
        topics = {conn.topic: conn.msgtype for conn in reader.connections}
        assert set(topics) == expected_topics(ROBOTS)
        assert topics["/tf"] == c.TF_MESSAGE
        seen = set()
        for conn, t_ns, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            if conn.msgtype not in seen:
                seen.add(conn.msgtype)
                stamp = msg.transforms[0].header.stamp if conn.topic == "/tf" else msg.header.stamp
                assert stamp.sec * 1_000_000_000 + stamp.nanosec == t_ns
        assert seen == {c.COMPRESSED_IMAGE, c.POSE_STAMPED, c.TF_MESSAGE}


def test_rerun_reads_it(log: tuple[Path, RecordSummary]) -> None:
    from rerun.chunk import McapReader

    path, _ = log
    reader = McapReader(path, timeline_type="duration_ns")
    assert reader.info().message_count == 2 * 3 + 4 * (3 + 3 + 1 + 1)
    columns: dict[str, set[str]] = {}
    for chunk in reader.stream():
        names = {f.name for f in chunk.to_record_batch().schema}
        columns.setdefault(chunk.entity_path, set()).update(names)
    assert "EncodedImage:blob" in columns["/robot1/omni/image/compressed"]
    assert "InstancePoses3D:translations" in columns["/robot1/pose"]
    assert "Transform3D:translation" in columns["/tf"]


def test_byte_identical(tmp_path: Path, log: tuple[Path, RecordSummary]) -> None:
    path, s = log
    again = tmp_path / "again.mcap"
    record(again, RecordOptions(scenario="scenario1", frames=2, pose_noise_m=0.05,
                                yaw_noise_deg=2.0, renderer=s.renderer, **SMALL))
    assert again.read_bytes() == path.read_bytes()
    other = tmp_path / "other.mcap"
    record(other, RecordOptions(scenario="scenario1", seed=1, frames=2, pose_noise_m=0.05,
                                yaw_noise_deg=2.0, renderer=s.renderer, **SMALL))
    assert other.read_bytes() != path.read_bytes()  # the seed reaches the noise


@pytest.mark.parametrize(("camera", "fmt"), [("fisheye", "jpeg"), ("mirror", "png")])
def test_camera_models_and_formats(tmp_path: Path, camera: str, fmt: str) -> None:
    path = tmp_path / "random.mcap"
    s = record(path, RecordOptions(frames=1, camera=camera, image_format=fmt, robots=2,
                                    seed=3, **SMALL))
    assert (s.scenario, s.robots) == ("random", 2)
    msgs, meta = read_all(path)
    assert set(msgs) == expected_topics(["robot1", "robot2"])
    _, _, img_msg = msgs["/robot1/omni/image/compressed"][0]
    assert img_msg.format == fmt
    img = cv2.imdecode(np.frombuffer(bytes(img_msg.data), np.uint8), cv2.IMREAD_COLOR)
    assert img.shape == (1080, 1080, 3)
    assert img[0, 0].max() <= 8  # outside the image circle: black
    cam = camera_from_dict(json.loads(meta[c.CAMERAS_METADATA]["robot2"]))
    assert cam == make_camera(camera)


def test_rolling_ball_rolls_and_robots_drive(tmp_path: Path) -> None:
    path = tmp_path / "rolling.mcap"
    # 2.5 s of sim time, 3 images per robot
    record(path, RecordOptions(frames=3, rate_hz=1.0, **SMALL))
    msgs, _ = read_all(path)
    balls = [m.pose.position for _, _, m in msgs["/ground_truth/ball"]]
    assert math.hypot(balls[-1].x - balls[0].x, balls[-1].y - balls[0].y) > 3.0
    r2 = [m.pose.position for _, _, m in msgs["/ground_truth/robot2/pose"]]
    assert math.hypot(r2[-1].x - r2[0].x, r2[-1].y - r2[0].y) > 0.5


def test_refuses_to_overwrite(log: tuple[Path, RecordSummary], capsys: pytest.CaptureFixture[str]
                              ) -> None:
    path, _ = log
    before = path.read_bytes()
    with pytest.raises(OutputExistsError, match="--force"):
        record(path, RecordOptions(frames=1, **SMALL))
    assert main([str(path), "--frames", "1"]) == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "exists" in err and "Traceback" not in err
    assert path.read_bytes() == before


def test_force_overwrites(tmp_path: Path) -> None:
    path = tmp_path / "scenario3.mcap"
    path.write_bytes(b"not a log")
    assert main([str(path), "--frames", "1", "--face-px", "256", "--force"]) == 0
    _, meta = read_all(path)
    assert meta[c.SCENARIO_METADATA]["name"] == "scenario3"


def test_unknown_scenario_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main([str(tmp_path / "foo.mcap")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "scenario1, scenario2" in err and "rolling" in err
    with pytest.raises(UnknownScenarioError, match="choose one of"):
        record(tmp_path / "x.mcap", RecordOptions(scenario="scenario9"))
    with pytest.raises(UsageError, match="exactly 3 robots"):
        record(tmp_path / "scenario1.mcap", RecordOptions(robots=4))
    with pytest.raises(UsageError, match="does not exist"):
        record(tmp_path / "missing" / "scenario1.mcap", RecordOptions())
    assert not list(tmp_path.iterdir())


def test_ctrl_c_keeps_a_readable_partial_log(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    from recorder.omni import OmniRenderer

    real = OmniRenderer.render
    calls = {"n": 0}

    def flaky(self: OmniRenderer, *args: object, **kwargs: object) -> np.ndarray:
        calls["n"] += 1
        if calls["n"] == 5:  # second frame, second robot
            raise KeyboardInterrupt
        return real(self, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(OmniRenderer, "render", flaky)
    path = tmp_path / "scenario2.mcap"
    with pytest.raises(RecordingInterrupted) as info:
        record(path, RecordOptions(frames=3, **SMALL))
    partial = info.value.partial_path
    assert partial == tmp_path / "scenario2.partial.mcap"
    assert not path.exists() and partial.exists()
    assert [p.name for p in tmp_path.iterdir()] == [partial.name]  # no temp file left
    msgs, meta = read_all(partial)  # finished: summary and metadata are there
    assert len(msgs["/robot1/omni/image/compressed"]) == 2
    assert meta[c.SCENARIO_METADATA]["name"] == "scenario2"

    calls["n"] = 0
    partial.unlink()
    assert main([str(path), "--frames", "3", "--face-px", "256"]) == 130
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(partial) in err
