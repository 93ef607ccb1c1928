"""The ``ballistic`` fusion in the replay: a lob's arc, given as the robots' ground-plane
estimates step by step, is followed in 3-D with its vertical speed and landing; one robot
alone invents no height; a replay of a golden log writes the tracker's keys and columns."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from dsp.cameras import camera_spec_from_json
from estimator.constants import BALL_RADIUS_M, NS_PER_S
from estimator.fusion import BallisticFusion
from estimator.tracking.ballistic import G_MPS2
from replay.cameras import Cameras
from replay.estimation import FrameEstimator
from replay.options import ReplayOptions
from replay.records import FrameResult, FrameStatus, RobotEstimate, StepResult
from replay.runner import replay

GOLDEN = Path(__file__).resolve().parents[2] / "logs" / "golden"
R = BALL_RADIUS_M
HEIGHT_M = 12.0
"""The ideal camera's height: it sees a lob from above."""
ROBOTS = {"robot1": (-4.0, 2.0), "robot2": (4.0, 3.0), "robot3": (0.0, -4.0)}
V = (4.0, 1.0, 5.0)
"""The lob's launch velocity from (0, 0) [m/s]: 2 v_z / g = 1.02 s in the air."""
RATE_HZ = 20.0


def _estimator() -> FrameEstimator:
    spec = camera_spec_from_json({"model": "ideal", "width_px": 1024, "height_px": 1024,
                                  "cu_px": 512, "cv_px": 512, "max_radius_px": 512,
                                  "height_m": HEIGHT_M, "k_m_per_px": 0.02}, "test")
    cameras = Cameras(dict.fromkeys(ROBOTS, spec),
                      {r: spec.range_calibration for r in ROBOTS})
    return FrameEstimator(method="corrected", fusion_method="ballistic", cameras=cameras)


def _ball(t: float) -> tuple[float, float, float]:
    return V[0] * t, V[1] * t, R + V[2] * t - 0.5 * G_MPS2 * t * t


def _frame(robot: str, stamp_ns: int, ball: tuple[float, float, float]) -> FrameResult:
    """What the robot's calibrated camera says of a ball at ``ball``: the point where its
    ray meets z = R, with the exact range and bearing (yaw 0)."""
    rx, ry = ROBOTS[robot]
    scale = (HEIGHT_M - R) / (HEIGHT_M - ball[2])
    gx, gy = rx + (ball[0] - rx) * scale, ry + (ball[1] - ry) * scale
    est = RobotEstimate(robot, gx, gy, math.hypot(gx - rx, gy - ry),
                        math.atan2(gy - ry, gx - rx), rx, ry, 0.0)
    return FrameResult(0, robot, stamp_ns, FrameStatus.OK, estimate=est)


def _fly(robots: tuple[str, ...], until_s: float) -> list[StepResult]:
    est = _estimator()
    steps = []
    for k in range(int(until_s * RATE_HZ) + 1):
        t = k / RATE_HZ
        stamp = round(t * NS_PER_S)
        ball = _ball(t)
        steps.append(est.step(k, stamp, tuple(_frame(r, stamp, ball) for r in robots),
                              (ball[0], ball[1]), truth_z=ball[2]))
    return steps


def test_a_lob_seen_by_three_robots_is_followed_in_3d_with_its_landing() -> None:
    land_t = 2 * V[2] / G_MPS2
    steps = _fly(tuple(ROBOTS), land_t - 0.3)
    assert all(s.fused is not None and s.fused.triangulated for s in steps)
    errors = [s.error_3d_m for s in steps]
    assert all(e is not None for e in errors) and max(e for e in errors if e) < 0.03
    last = steps[-1]
    t = last.stamp_ns / NS_PER_S
    assert last.vz_m_s == pytest.approx(V[2] - G_MPS2 * t, abs=0.3)
    assert last.velocity_m_s == pytest.approx(V[:2], abs=0.3)
    assert last.landing is not None
    assert last.landing.stamp_ns / NS_PER_S == pytest.approx(land_t, abs=0.03)
    assert math.hypot(last.landing.x_m - V[0] * land_t,
                      last.landing.y_m - V[1] * land_t) < 0.1
    assert steps[0].landing is None  # on the ground at the kick: not flying yet


def test_one_robot_seeing_a_lob_gives_no_height() -> None:
    """One robot's rays: the track keeps the ground point's height assumption with a
    height variance of metres (the covariance says it is unknown), is never crossed, and
    neither flies nor predicts a landing from one ray."""
    steps = _fly(("robot1",), 0.8)
    for s in steps:
        assert s.fused is not None and not s.fused.triangulated
        assert s.fused.covariance_3d is not None
        assert s.fused.covariance_3d[2][2] > 1.0
        assert s.landing is None and s.vz_m_s == 0.0
    flying = [s for s in steps if s.truth_z_m is not None and s.truth_z_m > 1.0]
    assert flying and all(s.z_error_m is not None and s.z_error_m < -0.5 for s in flying)


def test_free_running_cameras_rays_at_their_own_stamps_give_the_lob_in_3d() -> None:
    """Each robot's camera at its own phase (10 Hz, 33 ms apart): every step has one image,
    one ray, nothing to cross it with at that instant. The steps are the images' stamps;
    the rays, each at its own, lift the track and fly it within 2 cm from 0.15 s on, with
    its landing (one ray at a time held no height before)."""
    est = _estimator()
    assert est.step_window_ns(50_000_000) == 1
    phase = {"robot1": 0.0, "robot2": 0.033, "robot3": 0.067}
    land_t = 2 * V[2] / G_MPS2
    images = sorted((k / 10 + p, r) for r, p in phase.items() for k in range(10)
                    if k / 10 + p < land_t - 0.05)
    steps = []
    for i, (t, robot) in enumerate(images):
        stamp, ball = round(t * NS_PER_S), _ball(t)
        steps.append(est.step(i, stamp, (_frame(robot, stamp, ball),), (ball[0], ball[1]),
                              truth_z=ball[2]))
    late = [s for s in steps if s.stamp_ns >= 0.15 * NS_PER_S]
    assert all(s.error_3d_m is not None and s.error_3d_m < 0.02 for s in late)
    assert all(s.landing is not None and not s.fused.triangulated for s in late if s.fused)
    last = late[-1].landing
    assert last is not None and last.stamp_ns / NS_PER_S == pytest.approx(land_t, abs=0.03)


def test_the_one_shot_fusion_is_the_triangulation() -> None:
    f = BallisticFusion()
    assert f.name == "ballistic" and f.fuse([]) is None
    assert f.step(0, []) is None  # nothing seen yet: no track


def test_a_replay_writes_the_tracker_s_keys(tmp_path: Path) -> None:
    """Golden scenario 2 (a still ball, three robots): every step at the ball's height,
    no vertical speed, no landing; the header names the fusion; the CSV's columns."""
    replay(GOLDEN / "scenario2.mcap", ReplayOptions(
        fusion="ballistic", out=tmp_path / "r.json", out_csv=tmp_path / "r.csv",
        progress=False))
    doc = json.loads((tmp_path / "r.json").read_text())
    assert doc["options"]["fusion"] == "ballistic"
    assert doc["fused"]
    for s in doc["fused"]:
        assert abs(s["z_m"] - R) < 0.02 and s["error_m"] < 0.015
        assert s["vz_m_s"] == 0.0 and s["landing"] is None
        assert len(s["velocity_m_s"]) == 2 and np.hypot(*s["velocity_m_s"]) < 0.1
    with (tmp_path / "r.csv").open(newline="") as f:
        fused = [r for r in csv.DictReader(f) if r["kind"] == "fused"]
    assert len(fused) == len(doc["fused"])
    assert all(r["vz_m_s"] == "0.0" and r["landing_t_s"] == "" for r in fused)


def test_the_landing_topic_and_the_height_round_trip_through_the_mcap(tmp_path: Path) -> None:
    """The estimates MCAP of a lob's steps: /estimate/ball/landing (PointStamped, stamped
    at the predicted landing, logged at the step), the Odometry's z and vz, the fused
    pose's z and z variance; read back with the ROS 2 bag reader."""
    from rosbags.highlevel import AnyReader

    from replay.sinks.estimates_mcap import McapSink

    steps = _fly(tuple(ROBOTS), 0.8)
    out = tmp_path / "e.mcap"
    sink = McapSink(out)
    for s in steps:
        sink.step(s)
    sink.close(True)
    by_log: dict[str, dict[int, tuple[str, Any]]] = {}
    with AnyReader([out]) as bag:
        for conn, t, raw in bag.messages():
            msgtype = str(conn.msgtype)
            by_log.setdefault(conn.topic, {})[t] = (msgtype, bag.deserialize(raw, msgtype))
    landings = by_log["/estimate/ball/landing"]
    assert len(landings) == sum(s.landing is not None for s in steps) > 10
    for s in steps:
        fused = s.fused
        assert fused is not None and fused.z_m is not None and fused.covariance_3d is not None
        _, odo = by_log["/estimate/ball/odometry"][s.stamp_ns]
        assert odo.pose.pose.position.z == pytest.approx(fused.z_m)
        assert odo.twist.twist.linear.z == pytest.approx(s.vz_m_s)
        assert odo.pose.covariance[14] == pytest.approx(fused.covariance_3d[2][2])
        _, pose = by_log["/estimate/ball"][s.stamp_ns]
        assert pose.pose.pose.position.z == pytest.approx(fused.z_m)
        if s.landing is None:
            assert s.stamp_ns not in landings
            continue
        kind, msg = landings[s.stamp_ns]
        assert kind == "geometry_msgs/msg/PointStamped" and msg.header.frame_id == "field"
        assert msg.header.stamp.sec * NS_PER_S + msg.header.stamp.nanosec == s.landing.stamp_ns
        assert (msg.point.x, msg.point.y, msg.point.z) == pytest.approx(
            (s.landing.x_m, s.landing.y_m, R))


def test_the_viewer_draws_the_predicted_landing(tmp_path: Path) -> None:
    """A lob's steps through the Rerun sink: /field/track/landing is a ring with a cross on
    the ground at each predicted landing, labelled with the time to it; cleared while the
    ball does not fly; the trail follows the ball up and down, and the true ball stands on
    a line from the ground."""
    rr_chunk = pytest.importorskip("rerun.chunk")
    from replay.log import LogReader
    from replay.options import RerunTarget
    from replay.sinks.rerun.sink import RerunSink

    steps = _fly(tuple(ROBOTS), 0.8)
    rrd = tmp_path / "lob.rrd"
    options = ReplayOptions(fusion="ballistic", rerun=RerunTarget("save", str(rrd)),
                            progress=False)
    with LogReader(GOLDEN / "scenario2.mcap") as reader:
        info = reader.info
    assert options.rerun is not None
    sink = RerunSink(options.rerun, info=info, digest="0" * 64, options=options, centres={})
    for s in steps:
        sink.step(s)
    sink.close(True)
    drawn, labels, cleared, trails, truths = [], [], 0, [], []
    for ch in rr_chunk.RrdReader(rrd).stream():
        if ch.entity_path == "/field/track/trail":
            trails += ch.to_record_batch().column("LineStrips3D:strips").to_pylist()
        if ch.entity_path == "/field/ground_truth/ball":
            truths += ch.to_record_batch().column("LineStrips3D:strips").to_pylist()
        if ch.entity_path != "/field/track/landing" or ch.is_static:
            continue
        batch = ch.to_record_batch()
        names = batch.schema.names
        if "LineStrips3D:strips" in names:
            drawn += [s for s in batch.column("LineStrips3D:strips").to_pylist() if s]
            labels += [t for row in batch.column("LineStrips3D:labels").to_pylist()
                       for t in row or []]
        cleared += any("Clear" in n for n in names)
    flying = [s for s in steps if s.landing is not None]
    assert len(drawn) == len(flying) > 10
    for strips, s in zip(drawn, flying, strict=True):
        assert s.landing is not None and len(strips) == 3  # the ring and the cross
        centre = np.mean(np.array(strips[0])[:-1], axis=0)
        assert centre == pytest.approx((s.landing.x_m, s.landing.y_m, 0.01), abs=1e-3)
    last = flying[-1]
    assert last.landing is not None
    assert labels[-1] == f"lands in {(last.landing.stamp_ns - last.stamp_ns) / NS_PER_S:.2f} s"
    assert cleared  # the kick's first step, before the ball flies
    # the trail is the flight's arc, at the ball's heights (not flat on the ground)
    tracked = [s.fused.z_m for s in steps if s.fused is not None and s.velocity_m_s is not None]
    arc = [p[2] for p in trails[-1][0]]
    assert arc == pytest.approx(tracked, abs=1e-6) and max(arc) > 1.0
    # the true ball: a ring atop it and, in the air, a line from the ground to its underside
    assert len(truths) == len(steps)
    for strips, s in zip(truths, steps, strict=True):
        assert s.truth_z_m is not None and strips[0][0][2] == pytest.approx(s.truth_z_m + R)
        if s.truth_z_m > 2 * R:
            assert s.truth is not None
            line = [(*s.truth, 0.0), (*s.truth, s.truth_z_m - R)]
            assert np.array(strips[1]) == pytest.approx(np.array(line))
        else:
            assert len(strips) == 1
