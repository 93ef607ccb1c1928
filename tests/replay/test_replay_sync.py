"""Time sync: pose interpolation and slerp, tolerance, bounded histories, fusion windows."""

from __future__ import annotations

import math

import pytest

from replay.log import ImageMessage, PoseMessage, TruthMessage
from replay.sync import DelayLine, FusionGrouper, History, interpolate_pose, interpolate_truth

MS = 1_000_000


def pose(t_ms: int, x: float, y: float, yaw: float, robot: str = "robot1") -> PoseMessage:
    return PoseMessage(robot, t_ms * MS, x, y, 0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


def test_interpolates_position_and_slerps_yaw() -> None:
    h: History[PoseMessage] = History(10_000 * MS)
    h.add(pose(0, 0.0, 0.0, 0.0))
    h.add(pose(100, 1.0, -2.0, math.pi / 2))
    m = interpolate_pose(h, 25 * MS, 100 * MS)
    assert m is not None and m.interpolated
    assert m.pose.x_m == pytest.approx(0.25)
    assert m.pose.y_m == pytest.approx(-0.5)
    assert m.pose.yaw_rad == pytest.approx(math.pi / 8)
    assert m.gap_ns == 25 * MS


def test_slerp_takes_the_short_way_across_pi() -> None:
    h: History[PoseMessage] = History(10_000 * MS)
    h.add(pose(0, 0.0, 0.0, math.radians(170)))
    h.add(pose(100, 0.0, 0.0, math.radians(-170)))
    m = interpolate_pose(h, 50 * MS, 100 * MS)
    assert m is not None
    assert abs(m.pose.yaw_rad) == pytest.approx(math.pi)


def test_exact_stamp_uses_that_pose() -> None:
    h: History[PoseMessage] = History(10_000 * MS)
    for t in (0, 20, 40):
        h.add(pose(t, t / 10, 0.0, 0.0))
    m = interpolate_pose(h, 20 * MS, 0)
    assert m is not None and m.pose.x_m == 2.0 and m.gap_ns == 0


def test_tolerance_rejects_far_poses_and_accepts_one_sided() -> None:
    h: History[PoseMessage] = History(10_000 * MS)
    h.add(pose(0, 0.0, 0.0, 0.0))
    h.add(pose(1000, 1.0, 0.0, 0.0))
    assert interpolate_pose(h, 500 * MS, 100 * MS) is None  # gap: nearest is 500 ms away
    assert interpolate_pose(h, 500 * MS, 500 * MS) is not None
    m = interpolate_pose(h, 1050 * MS, 100 * MS)  # only a pose before: held
    assert m is not None and not m.interpolated and m.pose.x_m == 1.0
    assert interpolate_pose(History(1), 0, 10**9) is None


def test_history_is_bounded_by_its_horizon() -> None:
    h: History[PoseMessage] = History(100 * MS)
    for t in range(0, 100_000, 10):
        h.add(pose(t, 0.0, 0.0, 0.0))
    assert len(h) <= 12


def test_truth_interpolation() -> None:
    h: History[TruthMessage] = History(10**12)
    h.add(TruthMessage(0, 0.0, 0.0))
    h.add(TruthMessage(100 * MS, 1.0, 2.0))
    assert interpolate_truth(h, 50 * MS, 100 * MS) == pytest.approx((0.5, 1.0))
    assert interpolate_truth(h, 500 * MS, 100 * MS) is None


def test_delay_line_releases_after_lookahead() -> None:
    d = DelayLine(100 * MS)
    img = ImageMessage("robot1", 0, 0, "png", b"")
    d.push(img)
    assert list(d.ready(100 * MS)) == []
    assert list(d.ready(101 * MS)) == [img]


def test_fusion_grouper_windows() -> None:
    g: FusionGrouper[str] = FusionGrouper(50 * MS)
    assert g.add("robot1", 0, "a") == []
    assert g.add("robot2", 10 * MS, "b") == []
    closed = g.add("robot1", 100 * MS, "c")
    assert closed == [(0, {"robot1": "a", "robot2": "b"})]
    assert g.flush() == [(100 * MS, {"robot1": "c"})]
    assert g.flush() == []
