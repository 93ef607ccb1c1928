"""Replaying synthetic logs: accuracy, paper-mode bias, sync, skipping, determinism, sinks."""

from __future__ import annotations

import json
import math
import os
import stat
from dataclasses import replace
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from synthetic import B_M, DEFAULT_BALL, DEFAULT_ROBOTS, write_log

from dsp.errors import OutputExistsError
from replay import ReplayOptions, RerunTarget, replay


@pytest.fixture(scope="module")
def static_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("logs") / "static.mcap"
    write_log(path, duration_s=0.5)
    return path


def _results(path: Path) -> dict:
    return json.loads(path.read_text())


def test_corrected_estimates_within_a_few_cm(static_log: Path, tmp_path: Path) -> None:
    out = tmp_path / "r.json"
    s = replay(static_log, ReplayOptions(method="corrected", out=out, progress=False))
    assert s.frames == 18 and s.skipped == {}
    for robot in DEFAULT_ROBOTS:
        assert s.per_robot[robot].estimates == 6
        assert s.per_robot[robot].rmse_m is not None and s.per_robot[robot].rmse_m < 0.03
    assert s.fused.rmse_m is not None and s.fused.rmse_m < 0.03
    doc = _results(out)
    assert doc["summary"]["frames"] == 18
    assert len(doc["frames"]) == 18 and len(doc["fused"]) == 6
    step = doc["fused"][0]
    assert step["robots"] == sorted(DEFAULT_ROBOTS)
    assert step["x_m"] == pytest.approx(DEFAULT_BALL[0], abs=0.03)
    assert step["y_m"] == pytest.approx(DEFAULT_BALL[1], abs=0.03)
    assert "wall" not in out.read_text() and "estimator_ms" not in out.read_text()


def test_paper_mode_shows_its_per_axis_offset(static_log: Path, tmp_path: Path) -> None:
    out = tmp_path / "r.json"
    replay(static_log, ReplayOptions(method="paper", out=out, progress=False))
    for f in _results(out)["frames"]:
        rx, ry, _yaw = DEFAULT_ROBOTS[f["robot"]]
        dx, dy = DEFAULT_BALL[0] - rx, DEFAULT_BALL[1] - ry
        d = math.hypot(dx, dy)
        # eq. 11-12 add b to each axis instead of to the range: est - truth = b (1, 1) - b u
        want = (B_M * (1 - dx / d), B_M * (1 - dy / d))
        got = (f["estimate"]["x_m"] - DEFAULT_BALL[0], f["estimate"]["y_m"] - DEFAULT_BALL[1])
        assert got == pytest.approx(want, abs=0.03)


def test_moving_ball_turning_robots_images_between_poses(tmp_path: Path) -> None:
    log = tmp_path / "moving.mcap"
    write_log(log, duration_s=1.0, ball_velocity=(0.8, -0.4), yaw_rate_rad_s=0.6,
              image_offset_ns=7_000_000)
    out = tmp_path / "r.json"
    s = replay(log, ReplayOptions(out=out, progress=False))
    assert s.skipped == {}
    frames = _results(out)["frames"]
    assert all(f["pose"]["interpolated"] for f in frames)
    assert max(f["error_m"] for f in frames) < 0.05
    assert s.fused.rmse_m is not None and s.fused.rmse_m < 0.04


def test_frames_without_a_near_pose_are_skipped(tmp_path: Path) -> None:
    log = tmp_path / "gap.mcap"
    write_log(log, duration_s=1.0, drop_poses={"robot1": (0.3, 0.75)})
    out = tmp_path / "r.json"
    s = replay(log, ReplayOptions(out=out, pose_tolerance_s=0.1, progress=False))
    assert s.skipped == {"no_pose": 3}
    skipped = [f for f in _results(out)["frames"] if f["status"] == "no_pose"]
    assert [(f["robot"], f["t_s"]) for f in skipped] == [
        ("robot1", 0.4), ("robot1", 0.5), ("robot1", 0.6)]
    assert all(f["estimate"] is None for f in skipped)
    s2 = replay(log, ReplayOptions(pose_tolerance_s=0.3, progress=False))
    assert s2.skipped == {}


def test_a_bad_image_is_counted_and_the_rest_replayed(tmp_path: Path) -> None:
    log = tmp_path / "bad.mcap"
    write_log(log, duration_s=0.5, corrupt_images=[4])
    s = replay(log, ReplayOptions(progress=False))
    assert s.skipped == {"bad_image": 1}
    assert s.frames == 18 and sum(r.estimates for r in s.per_robot.values()) == 17


def test_replay_is_deterministic(static_log: Path, tmp_path: Path) -> None:
    outs = []
    for i in range(2):
        opts = ReplayOptions(out=tmp_path / f"r{i}.json", out_mcap=tmp_path / f"e{i}.mcap",
                             fusion="weighted", progress=False)
        replay(static_log, opts)
        outs.append(((tmp_path / f"r{i}.json").read_bytes(),
                     (tmp_path / f"e{i}.mcap").read_bytes()))
    assert outs[0] == outs[1]
    assert outs[0][0].endswith(b"}\n")


def test_subset_and_time_range(static_log: Path) -> None:
    s = replay(static_log, ReplayOptions(robots=("robot2",), start_s=0.1, end_s=0.3,
                                         progress=False))
    assert s.robots == ("robot2",) and s.frames == 3


def test_outputs_are_not_overwritten_without_force(static_log: Path, tmp_path: Path) -> None:
    out = tmp_path / "r.json"
    out.write_text("keep")
    with pytest.raises(OutputExistsError, match="--force"):
        replay(static_log, ReplayOptions(out=out, progress=False))
    assert out.read_text() == "keep"
    replay(static_log, ReplayOptions(out=out, force=True, progress=False))
    assert _results(out)["format"] == "dsp-replay-results"
    assert not list(tmp_path.glob(".*.tmp"))


def test_outputs_get_the_mode_of_any_new_file(static_log: Path, tmp_path: Path) -> None:
    old = os.umask(0o022)
    try:
        replay(static_log, ReplayOptions(out=tmp_path / "r.json", progress=False))
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "r.json").stat().st_mode) == 0o644


def test_estimates_mcap_reads_back(static_log: Path, tmp_path: Path) -> None:
    out = tmp_path / "e.mcap"
    replay(static_log, ReplayOptions(out_mcap=out, progress=False))
    topics: dict[str, int] = {}
    with out.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _schema, channel, message, decoded in reader.iter_decoded_messages():
            topics[channel.topic] = topics.get(channel.topic, 0) + 1
            assert message.log_time == decoded.header.stamp.sec * 10**9 + \
                decoded.header.stamp.nanosec
            if channel.topic == "/estimate/ball":
                assert decoded.pose.pose.position.x == pytest.approx(DEFAULT_BALL[0], abs=0.03)
                assert decoded.pose.covariance[0] > 0
    # the default fusion (track) also writes the ball's odometry at every step
    assert topics == {"/estimate/robot1/ball": 6, "/estimate/robot2/ball": 6,
                      "/estimate/robot3/ball": 6, "/estimate/ball": 6,
                      "/estimate/ball/odometry": 6}
    from rosbags.highlevel import AnyReader

    with AnyReader([out]) as bag:
        assert bag.message_count == 30
        for conn, _t, raw in bag.messages():
            msg = bag.deserialize(raw, conn.msgtype)
            if conn.topic == "/estimate/robot1/ball":
                assert msg.point.y == pytest.approx(DEFAULT_BALL[1], abs=0.03)
            if conn.topic == "/estimate/ball/odometry":  # a still ball
                assert (msg.header.frame_id, msg.child_frame_id) == ("field", "ball")
                assert msg.pose.pose.position.x == pytest.approx(DEFAULT_BALL[0], abs=0.03)
                assert abs(msg.twist.twist.linear.x) < 0.1 and msg.twist.covariance[0] > 0


def test_save_rrd_holds_the_scene(static_log: Path, tmp_path: Path) -> None:
    from rerun.chunk import RrdReader

    rrd = tmp_path / "out.rrd"
    opts = ReplayOptions(rerun=RerunTarget("save", str(rrd)), progress=False)
    replay(static_log, opts)
    reader = RrdReader(rrd)
    assert len(reader.recordings()) == 1 and len(reader.blueprints()) == 1
    chunks = reader.stream().to_chunks()
    entities = {c.entity_path for c in chunks}
    for robot in DEFAULT_ROBOTS:
        for e in ("camera/image", "camera/detection/centroid", "camera/detection/radius"):
            assert f"/robots/{robot}/{e}" in entities
        assert f"/field/robots/{robot}/estimate" in entities
        assert f"/plots/error/{robot}" in entities
    for e in ("/field/lines", "/field/fused", "/field/fused/covariance",
              "/field/ground_truth/ball", "/plots/error/fused"):
        assert e in entities

    def column(entity: str, name: str) -> list:
        values = []
        for c in chunks:
            if c.entity_path == entity:
                rb = c.to_record_batch()
                if name in rb.schema.names:
                    values += [v for v in rb.column(name).to_pylist() if v]
        return values

    centroids = column("/robots/robot1/camera/detection/centroid", "Points2D:positions")
    assert len(centroids) == 6
    (cx, cy), = centroids[0]
    assert 400 < cx < 700 and 300 < cy < 400  # the ball ahead of robot1: up in the image
    for robot in DEFAULT_ROBOTS:
        (x, y, _z), = column(f"/field/robots/{robot}/estimate", "Points3D:positions")[0]
        assert (x, y) == pytest.approx(DEFAULT_BALL, abs=0.03)
    fused = column("/field/fused", "Points3D:positions")
    assert len(fused) == 6
    assert fused[0][0][:2] == pytest.approx(DEFAULT_BALL, abs=0.03)
    recording_id = reader.recordings()[0].recording_id
    rrd2 = tmp_path / "again.rrd"
    replay(static_log, replace(opts, rerun=RerunTarget("save", str(rrd2))))
    assert RrdReader(rrd2).recordings()[0].recording_id == recording_id


def test_camera_metadata_centre_and_calibration_file(tmp_path: Path) -> None:
    from estimator.calibration import PAPER_CALIBRATION, calibration_to_json

    log = tmp_path / "cam.mcap"
    write_log(log, duration_s=0.2, with_cameras=True, centre_px=(551.0, 530.0))
    cal = tmp_path / "paper.json"
    cal.write_text(calibration_to_json(PAPER_CALIBRATION))
    out = tmp_path / "r.json"
    s = replay(log, ReplayOptions(calibration=cal, out=out, progress=False))
    assert s.fused.rmse_m is not None and s.fused.rmse_m < 0.03  # centre from the metadata
    doc = _results(out)
    assert doc["options"]["calibration"] == "paper.json"
    f = doc["frames"][0]
    r = math.hypot(f["detection"]["cx_px"] - 551.0, f["detection"]["cy_px"] - 530.0)
    assert f["detection"]["r_px"] == pytest.approx(r, abs=1e-5)


def test_frames_without_a_ball_are_not_skipped(tmp_path: Path) -> None:
    log = tmp_path / "far.mcap"
    write_log(log, duration_s=0.2, ball=(30.0, 0.0))  # out of every robot's image
    out = tmp_path / "r.json"
    s = replay(log, ReplayOptions(out=out, progress=False))
    assert s.frames == 9 and s.skipped == {} and s.fused_steps == 0
    assert all(r.detections == 0 for r in s.per_robot.values())
    doc = _results(out)
    assert {f["status"] for f in doc["frames"]} == {"no_detection"}
    assert doc["summary"]["fused"]["rmse_m"] is None


@pytest.mark.parametrize(("method", "fusion", "expected"), [
    ("paper", None, "mean"), ("corrected", None, "track"), ("corrected", "nearest", "nearest"),
])
def test_default_fusion_follows_the_method(static_log: Path, tmp_path: Path, method: str,
                                           fusion: str | None, expected: str) -> None:
    out = tmp_path / "r.json"
    replay(static_log, ReplayOptions(method=method, fusion=fusion, out=out, progress=False))
    assert _results(out)["options"]["fusion"] == expected


def test_a_localisers_pose_topic_with_covariance_replays(tmp_path: Path) -> None:
    """Real robots often publish geometry_msgs/PoseWithCovarianceStamped (AMCL)."""
    from dsp import contract

    log = tmp_path / "amcl.mcap"
    write_log(log, duration_s=0.3, pose_schema=contract.POSE_WITH_COVARIANCE_STAMPED,
              pose_topic="/{robot}/amcl_pose")
    s = replay(log, ReplayOptions(pose_topic="/{robot}/amcl_pose", progress=False))
    assert s.robots == tuple(DEFAULT_ROBOTS)
    assert s.fused.rmse_m is not None and s.fused.rmse_m < 0.01
