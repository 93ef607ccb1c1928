"""Balls in the air seen by cameras with no model (replay.aloft): placed by their width, a
still lifted blob put back down, the tracker's clutter counted where the ray meets the
ground, and the whole default on a log whose cameras are range tables alone."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from estimator.tracking import BallTracker, Measurement
from replay import ReplayOptions, replay
from replay.aloft import TRUST_COUNT, StillFilter, ground_xy, width_robots
from replay.evaluate.foreign import (
    IMAGE_TOPIC,
    TRUTH_TOPIC,
    ForeignOptions,
    pose_topic,
    write_camera_file,
    write_foreign_log,
)
from replay.profiles import options_for
from replay.records import RobotEstimate

ROOT = Path(__file__).resolve().parents[2]
MS = 1_000_000


def _lifted(x_m: float, ground: tuple[float, float]) -> RobotEstimate:
    """A robot at the origin facing +x sees a blob along +x: lifted to x_m, its ray meeting
    the ground at ``ground`` (on the same bearing)."""
    bearing = math.atan2(ground[1], ground[0])
    return RobotEstimate("r1", x_m * math.cos(bearing), x_m * math.sin(bearing), x_m, bearing,
                         0.0, 0.0, 0.0, range_sigma_m=0.05, ray_range_m=math.hypot(*ground))


def test_ground_xy_is_where_the_ray_meets_the_ground() -> None:
    e = _lifted(3.0, (6.0, 8.0))
    g = ground_xy(e)
    assert g is not None and g == pytest.approx((6.0, 8.0))
    assert ground_xy(RobotEstimate("r1", 1.0, 2.0, 2.2, 1.1, 0.0, 0.0, 0.0)) is None


def _trusting(f: StillFilter, robot: str) -> None:
    """Blobs on the ground whose width agrees with the calibration: the robot's widths are
    trusted from then on."""
    ground = RobotEstimate(robot, 2.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0)
    for k in range(TRUST_COUNT):
        assert f.placed(robot, -k * MS, ground, 2.0) is ground


def test_widths_are_trusted_once_they_agree_with_the_calibration_on_the_ground() -> None:
    wide, fine = StillFilter(), StillFilter()
    for k in range(TRUST_COUNT):  # blobs 1.5 times wider than the calibration's ball
        ground = RobotEstimate("r1", 3.0, 0.0, 3.0, 0.0, 0.0, 0.0, 0.0)
        wide.placed("r1", k * MS, ground, 2.0)
    _trusting(fine, "r1")
    assert not wide.trusted("r1") and fine.trusted("r1") and not fine.trusted("r2")
    up = _lifted(3.0, (6.0, 0.0))
    assert wide.placed("r1", 100 * MS, up, 3.0).ray_range_m is None  # put back down
    assert fine.placed("r1", 100 * MS, up, 3.0) is up


def test_a_still_lifted_blob_goes_back_down_a_moving_one_stays_up() -> None:
    still, moving = StillFilter(), StillFilter()
    _trusting(still, "r1")
    _trusting(moving, "r1")
    kept = []
    for k in range(8):  # 20 Hz for 0.4 s
        t = k * 50 * MS
        box = still.placed("r1", t, _lifted(4.0, (7.0, 0.0)), 4.0)  # its ray stays put
        kept.append(box.ray_range_m is not None)
        ball = moving.placed("r1", t, _lifted(3.0 + 0.2 * k, (6.0 + 0.5 * k, 0.0)), 3.0)
        assert ball.ray_range_m is not None and ball.x_m == pytest.approx(3.0 + 0.2 * k)
    # lifted until three of its ground points span 0.2 s at one place, then back down
    assert kept[:5] == [True] * 5 and not any(kept[5:])
    down = still.placed("r1", 8 * 50 * MS, _lifted(4.0, (7.0, 0.0)), 4.0)
    assert (down.x_m, down.y_m, down.range_m, down.ray_range_m) == pytest.approx(
        (7.0, 0.0, 7.0, None))


@pytest.mark.parametrize(("given", "method", "want"), [
    (None, "corrected", {"r2"}), (True, "corrected", {"r1", "r2"}),
    (False, "corrected", set()), (None, "paper", set())])
def test_which_robots_the_width_places(given: bool | None, method: str,
                                       want: set[str]) -> None:
    options = ReplayOptions(method=method, width_range=given)
    assert width_robots(options, ("r1", "r2"), {"r1"}) == want


def test_the_tracker_counts_a_lifted_estimate_where_its_ray_meets_the_ground() -> None:
    """A confirmed track at the origin rejects a box's lifted estimates, placed differently
    each time (its robot moves) while their rays meet the ground at one place: that place is
    clutter to the tracker, where the lifted places are not."""
    t = BallTracker()
    cov = ((0.01, 0.0), (0.0, 0.01))
    for k in range(6):
        for robot in ("a", "b"):
            t.update(Measurement(k * 40 * MS, robot, 0.0, 0.0, cov))
    for k in range(6, 14):
        x = 8.0 + 0.4 * ((3 * k) % 5)  # the robot moves to and fro: no one path
        t.update(Measurement(k * 40 * MS, "c", x, 4.0, cov, None, (6.0, 8.0)))
        t.update(Measurement(k * 40 * MS + MS, "a", 0.0, 0.0, cov))
    now = 14 * 40 * MS
    assert t._clutter.covers(now, 6.0, 8.0)
    assert not any(t._clutter.covers(now, 8.0 + 0.4 * j, 4.0) for j in range(5))
    m = Measurement(0, "c", 1.0, 2.0, cov)
    assert m.still_xy == (1.0, 2.0)


def _foreign(tmp: Path) -> tuple[Path, Path, ForeignOptions]:
    """2.5 s of another renderer's match, five robots whose cameras are range tables alone,
    poses drifting 10 cm / 2 deg: the ball is kicked up in its first second."""
    options = ForeignOptions(seed=3108, robots=5, rate_hz=20.0, duration_s=2.5,
                             poses="drift", drift=(0.1, 2.0), covariance="honest")
    log, cameras = tmp / "foreign.mcap", tmp / "foreign.yaml"
    write_foreign_log(log, options)
    write_camera_file(cameras, options)
    return log, cameras, options


def _replayed(log: Path, cameras: Path, options: ForeignOptions, out: Path,
              **given: object) -> tuple[dict[str, float], list[dict], dict]:
    replay(log, options_for(cameras=cameras, image_topic=IMAGE_TOPIC, out=out,
                            pose_topic=pose_topic(options), truth_topic=TRUTH_TOPIC,
                            progress=False, quiet=True, **given))
    doc = json.loads(out.read_text())
    steps = [s for s in doc["fused"] if s.get("error_m") is not None]
    rmse = {}
    for part, keep in (("air", lambda z: z >= 0.12), ("ground", lambda z: z < 0.12)):
        errors = [s["error_m"] for s in steps if keep(s.get("truth_z_m") or 0.0)]
        rmse[part] = math.sqrt(sum(e * e for e in errors) / len(errors))
    return rmse, doc["frames"], doc["pipeline"]


def test_a_flight_seen_by_range_tables_alone_is_placed_by_its_width(tmp_path: Path) -> None:
    log, cameras, options = _foreign(tmp_path)
    on, frames, pipeline = _replayed(log, cameras, options, tmp_path / "on.json")
    lifted = [f for f in frames if (f.get("estimate") or {}).get("ray_range_m")]
    assert lifted and pipeline["width"] == [f"r{i}" for i in range(1, 6)]
    off, _, off_pipeline = _replayed(log, cameras, options, tmp_path / "off.json",
                                     width_range=False)
    assert "width" not in off_pipeline
    # in the air: placed under the ball, not metres out along the rays; on the ground alike
    assert on["air"] < 0.3 * off["air"] and on["ground"] < 1.05 * off["ground"]
