"""Replaying with the tracker (``--fusion track``): unsynchronised cameras and a moving ball,
velocity in the results and as nav_msgs/Odometry, the same bytes run to run."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from synthetic import NS, write_log

from dsp.errors import UsageError
from replay import ReplayOptions, replay

MS = 1_000_000
VELOCITY = (3.0, -1.0)  # m/s
PHASES = {"robot1": 0, "robot2": 17 * MS, "robot3": 34 * MS}  # no two images share a stamp


def _results(path: Path) -> dict[str, Any]:
    doc: dict[str, Any] = json.loads(path.read_text(encoding="ascii"))
    return doc


@pytest.fixture(scope="module")
def moving_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("track") / "moving.mcap"
    write_log(path, ball=(0.5, 0.3), ball_velocity=VELOCITY, duration_s=1.0, image_hz=20.0,
              camera_phases_ns=PHASES, with_odometry=True)
    return path


@pytest.fixture(scope="module")
def replays(moving_log: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("track-out")
    paths = {}
    for fusion in ("track", "weighted"):
        paths[fusion] = out / f"{fusion}.json"
        replay(moving_log, ReplayOptions(fusion=fusion, out=paths[fusion],
                                         out_mcap=out / f"{fusion}.mcap", progress=False))
    return paths


def test_the_tracker_gives_a_step_at_every_image_stamp(replays: dict[str, Path]) -> None:
    doc = _results(replays["track"])
    stamps = sorted(f["stamp_ns"] for f in doc["frames"])
    assert [s["stamp_ns"] for s in doc["fused"]] == stamps
    assert len(set(stamps)) == len(stamps) == 21 + 20 + 20  # 20 Hz for 1 s, three phases
    assert doc["options"]["fusion"] == "track"
    # the first image starts a tentative track (not reported: it may be a false blob); the
    # next robot's image confirms it, and from there every step has a position and a velocity
    first, *rest = doc["fused"]
    assert first["x_m"] is None and "velocity_m_s" not in first
    assert all(s["x_m"] is not None and s["velocity_m_s"] is not None for s in rest)


def test_the_tracker_beats_window_fusion_on_a_moving_ball(replays: dict[str, Path]) -> None:
    track, window = _results(replays["track"]), _results(replays["weighted"])
    # the window averages estimates 0-34 ms apart: a 3.2 m/s ball is smeared by ~5 cm
    assert window["summary"]["fused"]["rmse_m"] > 0.02
    assert track["summary"]["fused"]["rmse_m"] < 0.005
    assert track["summary"]["fused"]["rmse_m"] < window["summary"]["fused"]["rmse_m"] / 5


def test_velocity_and_its_error_against_the_true_velocity(replays: dict[str, Path]) -> None:
    doc = _results(replays["track"])
    later = [s for s in doc["fused"] if s["t_s"] >= 0.2]
    for s in later:
        assert s["truth_velocity_m_s"] == pytest.approx(list(VELOCITY), abs=1e-9)
        vx, vy = s["velocity_m_s"]
        err = math.hypot(vx - VELOCITY[0], vy - VELOCITY[1])
        assert s["velocity_error_m_s"] == pytest.approx(err, abs=2e-6)
        cov = np.array(s["velocity_covariance"])
        assert np.all(np.linalg.eigvalsh(cov) > 0)
    assert float(np.median([s["velocity_error_m_s"] for s in later])) < 0.1
    velocity = doc["summary"]["fused"]["velocity"]
    assert velocity["errors"] == len(doc["fused"]) - 1  # all but the tentative first step
    assert velocity["rmse_m_s"] >= velocity["mean_error_m_s"] > 0
    # a window fusion estimates no velocity: its steps and summary have no velocity keys
    window = _results(replays["weighted"])
    assert not any("velocity_m_s" in s or "velocity_error_m_s" in s for s in window["fused"])
    assert all("truth_velocity_m_s" in s for s in window["fused"])
    assert "velocity" not in window["summary"]["fused"]


def test_odometry_in_the_estimates_mcap_decodes_with_the_velocity(
        replays: dict[str, Path]) -> None:
    doc = _results(replays["track"])
    by_stamp = {s["stamp_ns"]: s for s in doc["fused"]}
    odometry = []
    with replays["track"].with_suffix(".mcap").open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, _channel, message, msg in reader.iter_decoded_messages(
                topics=["/estimate/ball/odometry"]):
            assert schema is not None and schema.name == "nav_msgs/msg/Odometry"
            assert (msg.header.frame_id, msg.child_frame_id) == ("field", "ball")
            stamp = msg.header.stamp.sec * NS + msg.header.stamp.nanosec
            assert message.log_time == stamp
            step = by_stamp[stamp]
            assert msg.pose.pose.position.x == pytest.approx(step["x_m"], abs=1e-6)
            assert (msg.twist.twist.linear.x, msg.twist.twist.linear.y) == pytest.approx(
                step["velocity_m_s"], abs=1e-6)
            cov = msg.twist.covariance
            assert [cov[0], cov[1], cov[6], cov[7]] == pytest.approx(
                [v for row in step["velocity_covariance"] for v in row], abs=1e-6)
            assert msg.pose.covariance[0] == pytest.approx(step["covariance"][0][0], abs=1e-6)
            odometry.append((stamp, msg.twist.twist.linear.x, msg.twist.twist.linear.y))
    assert len(odometry) == len(doc["fused"]) - 1  # all but the tentative first step
    late = [(vx, vy) for t, vx, vy in odometry if t >= 0.2 * NS]
    assert np.median(np.hypot(*(np.array(late) - VELOCITY).T)) < 0.1
    # a window fusion writes no odometry (and no Odometry schema)
    with replays["weighted"].with_suffix(".mcap").open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    assert "nav_msgs/msg/Odometry" not in {s.name for s in summary.schemas.values()}


def test_the_tracker_replays_to_the_same_bytes(moving_log: Path, replays: dict[str, Path],
                                               tmp_path: Path) -> None:
    again = tmp_path / "again.json"
    replay(moving_log, ReplayOptions(fusion="track", out=again, out_mcap=tmp_path / "a.mcap",
                                     progress=False))
    assert again.read_bytes() == replays["track"].read_bytes()
    assert (tmp_path / "a.mcap").read_bytes() == replays["track"].with_suffix(
        ".mcap").read_bytes()


def test_without_true_velocity_there_is_no_velocity_error(tmp_path: Path) -> None:
    log = write_log(tmp_path / "no-odometry.mcap", ball_velocity=(1.0, 0.0), duration_s=0.3,
                    image_hz=20.0, camera_phases_ns=PHASES)
    out = tmp_path / "r.json"
    summary = replay(log.path, ReplayOptions(out=out, progress=False))  # track by default
    doc = _results(out)
    assert all(s["velocity_m_s"] is not None for s in doc["fused"][1:])
    assert not any("velocity_error_m_s" in s or "truth_velocity_m_s" in s
                   for s in doc["fused"])
    assert "velocity" not in doc["summary"]["fused"] and summary.fused_velocity is None


def test_smooth_replays_the_whole_track_offline(moving_log: Path, replays: dict[str, Path],
                                                tmp_path: Path) -> None:
    out = tmp_path / "smooth.json"
    replay(moving_log, ReplayOptions(fusion="track", smooth=True, out=out,
                                     out_mcap=tmp_path / "s.mcap", progress=False))
    smooth, causal = _results(out), _results(replays["track"])
    assert smooth["options"]["smooth"] is True and "smooth" not in causal["options"]
    assert [s["stamp_ns"] for s in smooth["fused"]] == [s["stamp_ns"] for s in causal["fused"]]
    assert smooth["frames"] == causal["frames"]
    assert smooth["summary"]["fused"]["rmse_m"] < causal["summary"]["fused"]["rmse_m"]
    v_smooth = smooth["summary"]["fused"]["velocity"]["rmse_m_s"]
    assert v_smooth < causal["summary"]["fused"]["velocity"]["rmse_m_s"]
    with pytest.raises(UsageError, match="--smooth smooths the tracker; it needs --fusion track"):
        ReplayOptions(fusion="weighted", smooth=True)


def test_calibrated_noise_lets_robust_reject_what_weighted_averages_in(tmp_path: Path) -> None:
    # robot3 believes itself 0.2 m off along its line of sight to the ball: within CAMBADA's
    # range sigma (0.10 m at 3 m), far outside the calibrated one (about 1 cm)
    log = write_log(tmp_path / "biased.mcap", duration_s=0.2, pose_bias_m={"robot3": (
        0.2 * 2.5 / math.hypot(2.5, 1.8), 0.2 * 1.8 / math.hypot(2.5, 1.8))})
    docs = {}
    for fusion, noise in (("weighted", "cambada"), ("robust", "cambada"),
                          ("weighted", "calibrated"), ("robust", "calibrated")):
        out = tmp_path / f"{fusion}-{noise}.json"
        replay(log.path, ReplayOptions(fusion=fusion, noise=noise, out=out, progress=False))
        docs[fusion, noise] = _results(out)
    assert docs["robust", "cambada"]["fused"] == docs["weighted", "cambada"]["fused"]
    assert "noise" not in docs["robust", "cambada"]["options"]
    assert docs["robust", "calibrated"]["options"]["noise"] == "calibrated"
    robust, weighted = docs["robust", "calibrated"], docs["weighted", "calibrated"]
    assert all(s["fused_robots"] == ["robot1", "robot2"] for s in robust["fused"])
    assert robust["summary"]["fused"]["rmse_m"] < 0.005 < weighted["summary"]["fused"]["rmse_m"]
    with pytest.raises(UsageError, match="--noise 'cambda'; choose one of cambada, calibrated"):
        ReplayOptions(noise="cambda")


def test_clock_ticks_add_steps_without_images_and_leave_the_image_steps_alone(
        moving_log: Path, replays: dict[str, Path], tmp_path: Path) -> None:
    plain = _results(replays["track"])
    out = tmp_path / "clock.json"
    replay(moving_log, ReplayOptions(fusion="track", clock_hz=40.0, out=out, progress=False))
    doc = _results(out)
    assert doc["options"]["clock_hz"] == 40.0 and "clock_hz" not in plain["options"]
    images = [s for s in doc["fused"] if "tick" not in s]
    ticks = [s for s in doc["fused"] if s.get("tick")]
    assert all(s["robots"] == [] and s["tick"] is True for s in ticks)
    strip = ("step",)  # numbered among the ticks
    assert [{k: v for k, v in s.items() if k not in strip} for s in images] == [
        {k: v for k, v in s.items() if k not in strip} for s in plain["fused"]]
    # every 25 ms from the first image (t = 0) to the last (robot1's, t = 1 s), in order
    assert [s["stamp_ns"] for s in ticks] == [k * 25 * MS for k in range(41)]
    stamps = [s["stamp_ns"] for s in doc["fused"]]
    assert stamps == sorted(stamps) and [s["step"] for s in doc["fused"]] == list(
        range(len(stamps)))
    # a tick is the track predicted to it: on the line the ball rolls, with its velocity
    for s in ticks[2:]:
        t = s["stamp_ns"] / NS
        assert math.hypot(s["x_m"] - (0.5 + 3.0 * t), s["y_m"] - (0.3 - 1.0 * t)) < 0.01
        assert s["error_m"] is not None and s["error_m"] < 0.01
        assert math.hypot(s["velocity_m_s"][0] - 3.0, s["velocity_m_s"][1] + 1.0) < 0.3
    # a window fusion has nothing at a tick
    window = tmp_path / "weighted.json"
    replay(moving_log, ReplayOptions(fusion="weighted", clock_hz=40.0, out=window,
                                     progress=False))
    assert all(s["x_m"] is None for s in _results(window)["fused"] if s.get("tick"))
    for hz in (0.0, 1e-300, 5e-324, 0.09):  # a tick 1e300 s apart overflowed a stamp
        with pytest.raises(UsageError, match="--clock"):
            ReplayOptions(clock_hz=hz)


def test_hops_give_the_same_track_at_the_images_with_a_clock_or_without(tmp_path: Path
                                                                         ) -> None:
    # a clock's tick reads the 3-D track and moves nothing (ticks that stepped it moved 10
    # of the golden match's 12 rows at the images)
    log = Path(__file__).resolve().parents[2] / "logs" / "golden" / "match.mcap"
    rows = {}
    for clock in (None, 100.0):
        out = tmp_path / f"clock-{clock}.json"
        replay(log, ReplayOptions(fusion="track", hops=True, clock_hz=clock, out=out,
                                  progress=False))
        fused = _results(out)["fused"]
        rows[clock] = [{k: v for k, v in s.items() if k != "step"} for s in fused
                       if not s.get("tick")]
        assert len(rows[clock]) < len(fused) if clock else len(rows[clock]) == len(fused)
    assert rows[None] == rows[100.0]
    assert sum(s.get("error_m") is not None for s in rows[None]) >= 10


def test_hops_give_a_lofted_ball_s_position_from_the_3d_track(tmp_path: Path) -> None:
    # the golden lob: a ball in the air, which each robot places farther out along its ray;
    # the tracker alone follows those estimates out, --hops places it in 3-D
    log = Path(__file__).resolve().parents[2] / "logs" / "golden" / "lobs.mcap"
    docs = {}
    for hops in (False, True):
        out = tmp_path / f"hops-{hops}.json"
        replay(log, ReplayOptions(fusion="track", hops=hops, out=out, progress=False))
        docs[hops] = _results(out)
    plain, hopped = docs[False], docs[True]
    assert hopped["options"]["hops"] is True and "hops" not in plain["options"]
    assert hopped["frames"] == plain["frames"]
    assert plain["summary"]["fused"]["rmse_m"] > 0.3
    assert hopped["summary"]["fused"]["rmse_m"] < 0.01
    # ...at its height: every step in 3-D, the ball in the air within centimetres
    aloft = [s for s in hopped["fused"] if s.get("truth_z_m", 0.0) > 0.3]
    assert aloft and all(s["error_3d_m"] < 0.05 for s in aloft)
    assert all("z_m" not in s for s in plain["fused"])
    # the velocity stays the tracker's
    assert [s.get("velocity_m_s") for s in hopped["fused"]] == [
        s.get("velocity_m_s") for s in plain["fused"]]
    with pytest.raises(UsageError, match="--hops follows the tracker's ball in 3-D; it "
                       "needs --fusion track, not 'weighted'"):
        ReplayOptions(fusion="weighted", hops=True)
    with pytest.raises(UsageError, match="it does not go with --smooth"):
        ReplayOptions(fusion="track", smooth=True, hops=True)
