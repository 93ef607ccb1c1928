"""estimator.hops: the 3-D track beside the ground tracker takes the ball's estimates near
it, places a hopping ball better than the ground tracker, and is given up when it strays."""

from __future__ import annotations

import math

from estimator.constants import BALL_RADIUS_M
from estimator.estimates import BallEstimate, covariance_rows
from estimator.hops import HopFollower
from estimator.noise import CalibratedNoise
from estimator.tracking import BallTracker, Measurement, TrackState

MS = 1_000_000
H = 0.85  # the camera's height [m]
ROBOTS = {"near": (2.0, -1.0), "far": (2.0, -8.0), "side": (-6.0, 2.0)}


def _ball(t: float) -> tuple[float, float, float]:
    """x at 3 m/s along y = 0; from 0.3 to 0.7 s a hop 0.12 m high."""
    h = 0.0 if not 0.3 <= t <= 0.7 else 0.12 * (1.0 - ((t - 0.5) / 0.2) ** 2)
    return (-1.0 + 3.0 * t, 0.0, BALL_RADIUS_M + h)


def _seen(robot: str, t: float) -> BallEstimate:
    """Where ``robot`` places the ball: its ray through the ball's centre, met with the
    plane of a ball on the ground (a hop puts it farther out)."""
    rx, ry = ROBOTS[robot]
    bx, by, bz = _ball(t)
    s = (H - BALL_RADIUS_M) / (H - bz)
    x, y = rx + s * (bx - rx), ry + s * (by - ry)
    return BallEstimate(robot, rx, ry, math.hypot(x - rx, y - ry), math.atan2(y - ry, x - rx),
                        x, y, camera_height_m=H)


def _track(t_ns: int, x: float, y: float) -> TrackState:
    cov = ((1e-4, 0.0), (0.0, 1e-4))
    return TrackState(t_ns, x, y, 0.0, 0.0, cov, cov, True)


def test_it_takes_what_the_tracker_accepted_and_what_lies_near_its_track() -> None:
    hops = HopFollower(CalibratedNoise())
    e = _seen("near", 0.0)  # at (-1, 0)
    assert hops.takes(e, True, None)
    assert hops.takes(e, False, _track(0, -1.0, 1.4))
    assert not hops.takes(e, False, _track(0, -1.0, 1.6))  # beyond near_m (1.5 m)
    assert not hops.takes(e, False, None)


def test_a_hopping_ball_is_placed_where_it_is_not_where_the_far_robots_lift_it() -> None:
    noise = CalibratedNoise()
    tracker, hops = BallTracker(), HopFollower(noise)
    ground, hopped = [], []
    for k in range(90):  # the robots' images in turn, 12.5 ms apart (27 Hz each)
        t_ns = k * 12 * MS + k * MS // 2
        e = _seen(list(ROBOTS)[k % 3], t_ns / 1e9)
        accepted = tracker.update(Measurement(t_ns, e.robot, e.x_m, e.y_m,
                                              covariance_rows(noise.covariance(e))))
        track = tracker.state_at(t_ns)
        flight = hops.step(t_ns, [e] if hops.takes(e, accepted, track) else [], track)
        if 0.35 <= t_ns / 1e9 <= 0.75 and track is not None:
            bx, by, _ = _ball(t_ns / 1e9)
            ground.append(math.hypot(track.x_m - bx, track.y_m - by))
            assert flight is not None
            hopped.append(math.hypot(flight.x_m - bx, flight.y_m - by))
    rms = [math.sqrt(sum(d * d for d in errs) / len(errs)) for errs in (ground, hopped)]
    assert rms[0] > 0.1  # the ground tracker follows the lifted estimates out
    assert rms[1] < 0.4 * rms[0]


def _still_ball(hops: HopFollower, steps: int) -> None:
    """A ball still at (-1, 0), seen by two robots in turn every 20 ms, the ground track on it."""
    for k in range(steps):
        e = _seen(("near", "side")[k % 2], 0.0)
        flight = hops.step(k * 20 * MS, [e], _track(k * 20 * MS, e.x_m, e.y_m))
    assert flight is not None and math.hypot(flight.x_m + 1.0, flight.y_m) < 0.02


def test_it_starts_afresh_where_the_ground_track_is_far_from_it_and_nothing_came() -> None:
    hops = HopFollower(CalibratedNoise())
    _still_ball(hops, 10)  # the last estimate at 180 ms
    # the ground track is 3 m away (more than guard_m) and the 3-D track took nothing for
    # more than keep_ns (100 ms): no 3-D position, and the next estimates there start the
    # 3-D track afresh
    assert hops.step(300 * MS, [], _track(300 * MS, 2.0, 0.0)) is None
    moved = BallEstimate("near", 2.0, -1.0, 1.0, math.pi / 2, 2.0, 0.0, camera_height_m=H)
    flight = hops.step(320 * MS, [moved], _track(320 * MS, 2.0, 0.0))
    assert flight is not None and math.hypot(flight.x_m - 2.0, flight.y_m) < 0.02


def test_it_stays_with_the_ball_where_the_ground_track_runs_off() -> None:
    """The ground track 3 m off (it took a far robot's lifted estimate for a kick), the
    robots' estimates still on the ball: the 3-D track takes them and keeps its position."""
    hops = HopFollower(CalibratedNoise())
    _still_ball(hops, 10)
    for k in range(10, 20):
        stamp = k * 20 * MS
        astray = _track(stamp, 2.0, 0.0)
        e = _seen(("near", "side")[k % 2], 0.0)
        assert hops.takes(e, False, astray)  # near the 3-D track, not the ground track
        flight = hops.step(stamp, [e], astray)
        assert flight is not None and math.hypot(flight.x_m + 1.0, flight.y_m) < 0.02
    # nothing more comes: after keep_ns the ground track is believed again
    assert hops.step(19 * 20 * MS + 50 * MS, [], _track(0, 2.0, 0.0)) is not None
    assert hops.step(19 * 20 * MS + 120 * MS, [], _track(0, 2.0, 0.0)) is None


def test_a_3d_track_that_never_joined_the_ground_track_is_not_kept() -> None:
    """At the start the 3-D track follows what it is given (a box, say) before the ground
    tracker confirms a track elsewhere: however recent its estimates, it is not kept."""
    hops = HopFollower(CalibratedNoise())
    for k in range(10):
        e = _seen(("near", "side")[k % 2], 0.0)  # at (-1, 0); no confirmed ground track
        assert hops.step(k * 20 * MS, [e], None) is None
    e = _seen("near", 0.0)
    assert hops.step(200 * MS, [e], _track(200 * MS, 5.0, 0.0)) is None  # 6 m away


def test_a_3d_track_fed_only_what_the_ground_tracker_took_is_not_kept() -> None:
    """Far from the ground track, a 3-D track that took nothing the ground tracker refused
    has nothing of its own to vouch for it (a lob away from the far robot whose lifted
    estimates both followed): the ground track is given."""
    hops = HopFollower(CalibratedNoise())
    _still_ball(hops, 10)
    e = _seen("near", 0.0)
    assert hops.takes(e, True, _track(200 * MS, 2.0, 0.0))  # the ground tracker took it
    assert hops.step(200 * MS, [e], _track(200 * MS, 2.0, 0.0)) is None
