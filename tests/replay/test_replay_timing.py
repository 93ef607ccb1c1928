"""Timing in replay results: truth and poses interpolated at the right point between samples,
pose gaps in seconds, fusion windows half-open, poses read ahead of ``start_s``.

The synthetic log here has a ball rolling at a known velocity, poses and truth every 20 ms and
images 5 ms after a pose (a quarter of the way to the next one), so an interpolation taken
from the wrong end, or a sample missed, moves the result by millimetres to centimetres.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
from synthetic import NS, write_log

from replay import ReplayOptions, replay
from replay.log import PoseMessage, TruthMessage
from replay.sync import FusionGrouper, History, interpolate_pose, interpolate_truth

MS = 1_000_000
BALL = (0.5, 0.3)
BALL_VELOCITY = (1.2, -0.8)  # m/s: 24 mm / -16 mm between truth samples
POSE_HZ = 50.0  # poses and truth every 20 ms
IMAGE_HZ = 10.0  # images every 100 ms ...
IMAGE_OFFSET_NS = 5 * MS  # ... at 5, 105, 205 ms: s = 0.25 between the 20 ms samples
ROBOTS = {"robot1": (-3.0, 0.0, 0.0), "robot2": (-1.0, 2.0, -math.pi / 2)}
RESULTS_DECIMALS_ABS = 2e-6  # the results file rounds floats to 6 decimals


def ball_at(t_ns: int) -> tuple[float, float]:
    s = t_ns / NS
    return BALL[0] + BALL_VELOCITY[0] * s, BALL[1] + BALL_VELOCITY[1] * s


@pytest.fixture(scope="module")
def rolling_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("timing") / "rolling.mcap"
    write_log(path, robots=ROBOTS, ball=BALL, ball_velocity=BALL_VELOCITY, duration_s=0.3,
              image_hz=IMAGE_HZ, pose_hz=POSE_HZ, image_offset_ns=IMAGE_OFFSET_NS)
    return path


def _replay(log: Path, out: Path, **options: Any) -> dict[str, Any]:
    # the window fusion: these tests pin how frames group into windows (and the tracker's
    # state depends on where the replay starts; its steps: tests/replay/test_track_replay.py)
    options.setdefault("fusion", "weighted")
    replay(log, ReplayOptions(method="corrected", out=out, progress=False, **options))
    doc: dict[str, Any] = json.loads(out.read_text(encoding="ascii"))
    return doc


@pytest.fixture(scope="module")
def results(rolling_log: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    return _replay(rolling_log, tmp_path_factory.mktemp("timing-out") / "r.json")


# --- replay results ------------------------------------------------------------------------


def test_frame_and_step_truth_is_interpolated_from_the_right_end(results: dict[str, Any]) -> None:
    stamps = [f["stamp_ns"] for f in results["frames"]]
    assert sorted(set(stamps)) == [5 * MS, 105 * MS, 205 * MS]
    for f in results["frames"]:
        want = ball_at(f["stamp_ns"])
        assert (f["truth"]["x_m"], f["truth"]["y_m"]) == pytest.approx(
            want, abs=RESULTS_DECIMALS_ABS), f"frame {f['frame']}"
    assert len(results["fused"]) == 3
    for s in results["fused"]:
        assert (s["truth"]["x_m"], s["truth"]["y_m"]) == pytest.approx(
            ball_at(s["stamp_ns"]), abs=RESULTS_DECIMALS_ABS), f"step {s['step']}"


def test_pose_gap_is_written_in_seconds(results: dict[str, Any]) -> None:
    for f in results["frames"]:
        pose = f["pose"]
        assert pose["interpolated"] is True
        assert pose["gap_s"] == pytest.approx(IMAGE_OFFSET_NS / NS, abs=1e-9)  # 0.005 s
        rx, ry, ryaw = ROBOTS[f["robot"]]
        assert (pose["x_m"], pose["y_m"], pose["yaw_rad"]) == pytest.approx(
            (rx, ry, ryaw), abs=RESULTS_DECIMALS_ABS)


def test_an_item_exactly_one_window_later_starts_a_new_step(rolling_log: Path,
                                                            tmp_path: Path) -> None:
    # window 100 ms: the images at 105 ms are exactly one window after the step at 5 ms,
    # so every image stamp is a step of its own (the window is [t0, t0 + window))
    doc = _replay(rolling_log, tmp_path / "r.json", window_s=0.1)
    assert [s["stamp_ns"] for s in doc["fused"]] == [5 * MS, 105 * MS, 205 * MS]
    assert all(s["robots"] == sorted(ROBOTS) for s in doc["fused"])
    assert doc["summary"]["steps"] == 3
    # just under a window later joins the open step (each robot keeps its latest frame)
    doc = _replay(rolling_log, tmp_path / "r2.json", window_s=0.1 + 1e-9)
    assert [s["stamp_ns"] for s in doc["fused"]] == [5 * MS, 205 * MS]


def test_start_reads_poses_and_truth_stamped_before_it(rolling_log: Path,
                                                      results: dict[str, Any],
                                                      tmp_path: Path) -> None:
    # start at the 105 ms images: their bracketing pose and truth samples are at 100 and
    # 120 ms, so the one at 100 ms lies before --start and must still be read
    start_s = 0.105
    doc = _replay(rolling_log, tmp_path / "r.json", start_s=start_s)
    later = [f for f in results["frames"] if f["stamp_ns"] >= start_s * NS]
    assert len(doc["frames"]) == len(later) == 4

    def without_index(f: dict[str, Any]) -> dict[str, Any]:
        return {k: v for k, v in f.items() if k != "frame"}

    assert [without_index(f) for f in doc["frames"]] == [without_index(f) for f in later]
    first = doc["frames"][0]
    assert first["pose"]["interpolated"] is True and first["pose"]["gap_s"] == 0.005
    assert (first["truth"]["x_m"], first["truth"]["y_m"]) == pytest.approx(
        ball_at(105 * MS), abs=RESULTS_DECIMALS_ABS)
    later_steps = [s for s in results["fused"] if s["stamp_ns"] >= start_s * NS]
    assert [{k: v for k, v in s.items() if k != "step"} for s in doc["fused"]] == [
        {k: v for k, v in s.items() if k != "step"} for s in later_steps]


# --- the synchronisation units -------------------------------------------------------------


def _pose(t_ms: int, x: float) -> PoseMessage:
    return PoseMessage("robot1", t_ms * MS, x, 0.0, 0.0, 0.0, 0.0, 1.0)


def test_truth_interpolation_at_a_quarter() -> None:
    h: History[TruthMessage] = History(10**12)
    h.add(TruthMessage(0, 0.0, 10.0))
    h.add(TruthMessage(100 * MS, 1.0, 2.0))
    assert interpolate_truth(h, 25 * MS, 100 * MS) == pytest.approx((0.25, 8.0))
    assert interpolate_truth(h, 75 * MS, 100 * MS) == pytest.approx((0.75, 4.0))


def test_an_out_of_order_pose_is_inserted_in_stamp_order() -> None:
    h: History[PoseMessage] = History(10_000 * MS)
    for t_ms, x in ((0, 0.0), (40, 4.0), (20, 2.0), (60, 6.0), (10, 1.0)):
        h.add(_pose(t_ms, x))
    assert len(h) == 5
    for t_ms, want_x, gap_ms in ((5, 0.5, 5), (15, 1.5, 5), (30, 3.0, 10), (50, 5.0, 10)):
        m = interpolate_pose(h, t_ms * MS, 100 * MS)
        assert m is not None and m.interpolated, t_ms
        assert m.pose.x_m == pytest.approx(want_x), t_ms
        assert m.gap_ns == gap_ms * MS, t_ms
    assert h.neighbours(20 * MS)[0] is h.neighbours(20 * MS)[1]
    assert h.neighbours(20 * MS)[0].x_m == 2.0  # type: ignore[union-attr]


def test_fusion_window_is_half_open() -> None:
    g: FusionGrouper[str] = FusionGrouper(50 * MS)
    assert g.add("robot1", 0, "a") == []
    assert g.add("robot2", 50 * MS - 1, "b") == []  # inside [0, 50 ms)
    assert g.add("robot1", 50 * MS, "c") == [(0, {"robot1": "a", "robot2": "b"})]
    assert g.flush() == [(50 * MS, {"robot1": "c"})]
