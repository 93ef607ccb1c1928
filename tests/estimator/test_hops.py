"""estimator.hops: the 3-D track beside the ground tracker takes the ball's estimates near
it, places a hopping ball better than the ground tracker, and is given up when it strays."""

from __future__ import annotations

import math

import numpy as np
import pytest

from estimator.constants import BALL_RADIUS_M
from estimator.estimates import BallEstimate, FusedEstimate, covariance_rows
from estimator.hops import HopFollower
from estimator.noise import CalibratedNoise
from estimator.tracking import BallTracker, Measurement, TrackState
from estimator.tracking.flight_fit import Kink
from estimator.tracking.ray_pairs import RayPairs

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
    return _sees(robot, ROBOTS[robot], _ball(t))


def _sees(robot: str, at: tuple[float, float], ball: tuple[float, float, float]
          ) -> BallEstimate:
    """Where a robot at ``at`` places a ball (or a blob) at ``ball`` (x, y, z of its centre)."""
    rx, ry = at
    bx, by, bz = ball
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
    assert hops.takes(e, True, None, 0)
    assert hops.takes(e, False, _track(0, -1.0, 1.4), 0)
    assert not hops.takes(e, False, _track(0, -1.0, 1.6), 0)  # beyond near_m (1.5 m)
    assert not hops.takes(e, False, None, 0)


def _fed(tracker: BallTracker, hops: HopFollower, e: BallEstimate, t_ns: int
         ) -> tuple[TrackState | None, FusedEstimate | None]:
    """One image's estimate into the ground tracker, then the 3-D track if it takes it:
    the ground track and the 3-D track's position at its stamp."""
    accepted = tracker.update(Measurement(t_ns, e.robot, e.x_m, e.y_m,
                                          covariance_rows(hops.noise.covariance(e))))
    track = tracker.state_at(t_ns)
    return track, hops.step(t_ns, [e] if hops.takes(e, accepted, track, t_ns) else [], track)


def test_a_hopping_ball_is_placed_where_it_is_not_where_the_far_robots_lift_it() -> None:
    tracker, hops = BallTracker(), HopFollower(CalibratedNoise())
    ground, hopped = [], []
    for k in range(90):  # the robots' images in turn, 12.5 ms apart (27 Hz each)
        t_ns = k * 12 * MS + k * MS // 2
        track, flight = _fed(tracker, hops, _seen(list(ROBOTS)[k % 3], t_ns / 1e9), t_ns)
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
    hops = HopFollower(CalibratedNoise(), loose_ratio=math.inf)  # a new track is loose
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
        assert hops.takes(e, False, astray, stamp)  # near the 3-D track, not the ground track
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
    assert hops.takes(e, True, _track(200 * MS, 2.0, 0.0), 200 * MS)  # the ground tracker took it
    assert hops.step(200 * MS, [e], _track(200 * MS, 2.0, 0.0)) is None


def _joined(hops: HopFollower) -> None:
    """The 3-D track and the ground track on a still ball at (-1, 0) for 200 ms."""
    _still_ball(hops, 10)


LOB = (1.2, -0.6, BALL_RADIUS_M + 0.3)
"""A lobbed ball 0.3 m up, 0.9 m from the near robot and 7.4 m from the far one."""


def test_it_takes_the_near_robot_that_sees_a_lob_where_the_far_robots_ray_passes() -> None:
    """The far robot places the lob 5 m beyond it, and the ground tracker, taking that for
    a kick, is on its way there; the near robot places it 0.6 m off, but more than near_m
    from both tracks: its ray crosses the far robot's there."""
    hops = HopFollower(CalibratedNoise())
    _joined(hops)
    far = _sees("far", ROBOTS["far"], LOB)
    astray = _track(200 * MS, -0.2, 1.5)  # within guard_m of the 3-D track, still at (-1, 0)
    assert hops.takes(far, True, astray, 200 * MS)
    hops.step(200 * MS, [far], astray)
    near = _sees("near", ROBOTS["near"], LOB)
    assert math.hypot(near.x_m - LOB[0], near.y_m - LOB[1]) < 0.7
    x = hops._flight.tracker.x
    assert x is not None
    for px, py in ((astray.x_m, astray.y_m), (float(x[0]), float(x[1]))):
        assert math.hypot(near.x_m - px, near.y_m - py) > hops.near_m
    assert hops.takes(near, False, astray, 210 * MS)


def test_a_ray_that_crosses_the_far_robots_far_from_its_own_estimate_is_not_taken() -> None:
    """A blob seen on the ground 4 m beyond the point where its ray crosses the far
    robot's (0.6 m up): the crossing is no ball there, and it is not taken."""
    hops = HopFollower(CalibratedNoise())
    _joined(hops)
    far = _sees("far", ROBOTS["far"], LOB)
    astray = _track(200 * MS, -0.2, 1.5)
    hops.step(200 * MS, [far], astray)
    u = (H - 0.6) / (H - LOB[2])  # the far robot's ray at 0.6 m up
    fx, fy = ROBOTS["far"]
    cx, cy = fx + u * (LOB[0] - fx), fy + u * (LOB[1] - fy)
    blob = _sees("side", (cx - 2.0, cy), (cx, cy, 0.6))  # its ray through that point
    assert math.hypot(blob.x_m - cx, blob.y_m - cy) > 3.0
    assert not hops.takes(blob, False, astray, 210 * MS)


def test_a_far_robots_false_blob_whose_ray_passes_the_ball_low_is_not_taken() -> None:
    """The ball still on the ground; a robot 10 m away reports a blob 2.1 m from it whose
    ray crosses the far robot's ray 0.9 m from the ball, 8 cm up, 1.2 m from the blob: no
    lob is that low, and the blob is not taken (taken, the 3-D track restarted on the
    crossing, 0.9 m off a ball both tracks had)."""
    for lob_m, taken in ((HopFollower.lob_m, False), (-math.inf, True)):
        hops = HopFollower(CalibratedNoise(), lob_m=lob_m)
        _joined(hops)
        track = _track(200 * MS, -1.0, 0.0)
        far = _sees("far", ROBOTS["far"], (-1.0, 0.0, BALL_RADIUS_M))
        hops.step(200 * MS, [far] if hops.takes(far, True, track, 200 * MS) else [], track)
        fx, fy = ROBOTS["far"]
        d = math.hypot(fx + 1.0, fy)
        low = (-1.0 + 0.9 * (fx + 1.0) / d, 0.9 * fy / d,
               BALL_RADIUS_M + 0.9 * (H - BALL_RADIUS_M) / d)  # the far ray 0.9 m out
        blob = _sees("fourth", (low[0] - 3.51, low[1] + 9.36), low)  # its ray through there
        assert math.hypot(blob.x_m + 1.0, blob.y_m) > 2.0
        assert math.hypot(blob.x_m - low[0], blob.y_m - low[1]) < 1.3
        assert hops.takes(blob, False, track, 210 * MS) is taken


def _lob(t: float) -> tuple[float, float, float]:
    """Still at (-1, 0) until 0.2 s, then kicked up: 2 m/s along x, 3 m/s up."""
    if t <= 0.2:
        return (-1.0, 0.0, BALL_RADIUS_M)
    dt = t - 0.2
    return (-1.0 + 2.0 * dt, 0.0, max(BALL_RADIUS_M, BALL_RADIUS_M + 3.0 * dt - 4.905 * dt * dt))


def test_a_flying_3d_track_is_kept_where_the_ground_track_runs_off_with_the_lift() -> None:
    """Every estimate is one the ground tracker took, but it took the far robot's lifted
    ones for a kick and ran off along them; the 3-D track, flying (its height known from
    the crossed rays), places them in the air and is kept through the flight."""
    hops = HopFollower(CalibratedNoise())
    kept, errors = 0, []
    for k in range(60):  # 0.75 s, the robots' images in turn 12.5 ms apart
        t_ns = k * 12 * MS + k * MS // 2
        robot = list(ROBOTS)[k % 3]
        ball = _lob(t_ns / 1e9)
        e = _sees(robot, ROBOTS[robot], ball)
        far = _sees("far", ROBOTS["far"], ball)
        track = _track(t_ns, far.x_m, far.y_m)  # the ground track on the far robot's
        assert hops.takes(e, True, track, t_ns)
        flight = hops.step(t_ns, [e], track)
        if ball[2] > BALL_RADIUS_M + 0.2 and math.hypot(far.x_m - ball[0], far.y_m - ball[1]) > 3:
            assert flight is not None
            kept += 1
            errors.append(math.hypot(flight.x_m - ball[0], flight.y_m - ball[1]))
    assert kept > 10  # more than keep_ns (100 ms) of it
    assert max(errors) < 0.5


def _kicked_along_the_rays(hops: HopFollower) -> list[float]:
    """A ball rolling at 1 m/s along y = 0, kicked at 0.5 s to 8 m/s the same way, seen in
    turn (every 25 ms) by two robots at either end of the field whose rays run along its
    way: the 3-D track's errors from the second image after the kick on."""
    at = {"east": (9.0, 0.6), "west": (-9.0, -0.6)}
    tracker, errors = BallTracker(), []
    for k in range(32):
        t_ns = k * 25 * MS + 3 * MS
        t = t_ns / 1e9
        ball = (-1.0 + t if t < 0.5 else -0.5 + 8.0 * (t - 0.5), 0.0, BALL_RADIUS_M)
        robot = ("east", "west")[k % 2]
        _fed(tracker, hops, _sees(robot, at[robot], ball), t_ns)
        x = hops._flight.tracker.x
        if t > 0.525:
            assert x is not None
            errors.append(math.hypot(float(x[0]) - ball[0], float(x[1]) - ball[1]))
    return errors


def test_a_kick_along_the_rays_is_followed_from_the_second_image_after_it() -> None:
    """The ground tracker follows the kick at once; the 3-D track, whose points say little
    along the rays, takes a kick when its velocity is that far from the ground track's, and
    is within 2 cm from the second image after the kick (8 cm behind without)."""
    assert max(_kicked_along_the_rays(HopFollower(CalibratedNoise()))) < 0.02
    assert max(_kicked_along_the_rays(HopFollower(CalibratedNoise(), kick_mps=math.inf))) > 0.06


def _kicked_across_shallow_rays(hops: HopFollower, tick: bool = False
                                ) -> tuple[float, float]:
    """Two robots 8.8 and 12 m away whose rays meet at 7 deg see a ball rolling at 1 m/s in
    turn; 1 ms after the second one's image the ball is kicked to 9 m/s across their rays,
    and the ground track (given) follows. The first robot's next image, 25 ms on: the 3-D
    track's error and height. ``tick``: a step without images (a clock's) between the kick
    and that image, the ground track already kicked there."""
    at = {"a": (8.3, 2.55), "b": (10.95, 4.7)}
    v0, vk = (0.84, -0.64), (-1.0, 9.0)
    t_ns = 0
    for k in range(24):
        t_ns = k * 25 * MS
        ball = (v0[0] * t_ns / 1e9, v0[1] * t_ns / 1e9, BALL_RADIUS_M)
        robot = "ab"[k % 2]
        hops.step(t_ns, [_sees(robot, at[robot], ball)], _moving(t_ns, ball, v0))
    kick = t_ns / 1e9 + 0.001
    if tick:
        t = kick + 0.010
        at_tick = (v0[0] * kick + vk[0] * 0.010, v0[1] * kick + vk[1] * 0.010, BALL_RADIUS_M)
        hops.step(round(t * 1e9), [], _moving(round(t * 1e9), at_tick, vk))
    t_ns += 25 * MS
    dt = t_ns / 1e9 - kick
    ball = (v0[0] * kick + vk[0] * dt, v0[1] * kick + vk[1] * dt, BALL_RADIUS_M)
    hops.step(t_ns, [_sees("a", at["a"], ball)], _moving(t_ns, ball, vk))
    x = hops._flight.tracker.x
    assert x is not None
    return math.hypot(float(x[0]) - ball[0], float(x[1]) - ball[1]), float(x[2])


def _moving(t_ns: int, ball: tuple[float, float, float], v: tuple[float, float]
            ) -> TrackState:
    cov = ((1e-4, 0.0), (0.0, 1e-4))
    return TrackState(t_ns, ball[0], ball[1], v[0], v[1], cov, cov, True)


def test_after_a_kick_a_ray_is_not_crossed_with_one_from_before_it(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A ray of before the kick, moved with the velocity before it, crosses the first ray
    after it metres along the two (they meet at 7 deg), in the air: the 3-D track must not
    take that crossing for a lob. With the rays of before the kick forgotten it places the
    ball on the ground within 3 cm; kept, 1.8 m off and 0.27 m up (a replayed match's
    kick, seed 13 at 9.94 s)."""
    error, z = _kicked_across_shallow_rays(HopFollower(CalibratedNoise()))
    assert error < 0.03 and z == pytest.approx(BALL_RADIUS_M, abs=0.01)
    monkeypatch.setattr(RayPairs, "forget", lambda self: None)
    error, z = _kicked_across_shallow_rays(HopFollower(CalibratedNoise()))
    assert error > 1.0 and z > 0.2


def test_a_kick_seen_between_images_is_acted_on_at_the_next_image() -> None:
    """The ground track's kick read at a step without images (a clock's tick): the first
    image after it still forgets the rays of before the kick: the ball on the ground, 0.24 m
    behind (moved to the tick with the velocity before the kick), not 1.8 m off in the air."""
    error, z = _kicked_across_shallow_rays(HopFollower(CalibratedNoise()), tick=True)
    assert error < 0.3 and z == pytest.approx(BALL_RADIUS_M, abs=0.01)


def test_a_rolling_3d_track_far_looser_than_the_ground_track_gives_its_position() -> None:
    """A 3-D track begun on one robot's image knows little along its ray; where the ground
    track is much surer (loose_ratio), its position is given, the 3-D track kept."""
    e = _seen("near", 0.0)
    sure, unsure = ((1e-4, 0.0), (0.0, 1e-4)), ((1.0, 0.0), (0.0, 1.0))
    for cov, given in ((sure, False), (unsure, True)):
        hops = HopFollower(CalibratedNoise())
        _joined(hops)  # a track of two robots' crossed rays, then a fresh one of one image
        hops._flight = type(hops._flight)(hops.noise)
        track = TrackState(200 * MS, e.x_m, e.y_m, 0.0, 0.0, cov, cov, True)
        assert (hops.step(200 * MS, [e], track) is not None) is given
        assert hops._flight.tracker.x is not None  # kept either way


def test_the_looseness_ratio_is_a_ratio_of_variances_as_given() -> None:
    """loose_ratio 4: a rolling 3-D track 8 times as loose as the ground track (variance)
    gives the ground track's position, one 3 times as loose its own (a ratio of 16, the
    ratio squared, kept the 8 times looser one)."""
    e = _seen("near", 0.0)

    def step(ground_variance: float | None) -> FusedEstimate | None:
        hops = HopFollower(CalibratedNoise(), loose_ratio=4.0)
        _joined(hops)
        hops._flight = type(hops._flight)(hops.noise)  # a fresh track of one image
        v = 1.0 if ground_variance is None else ground_variance
        cov = ((v, 0.0), (0.0, v))
        return hops.step(200 * MS, [e], TrackState(200 * MS, e.x_m, e.y_m, 0.0, 0.0, cov,
                                                   cov, True))

    own = step(None)  # the ground track far looser: the 3-D track's own position
    assert own is not None
    (a, b), (_, d) = own.covariance
    largest = 0.5 * (a + d) + math.hypot(0.5 * (a - d), b)
    assert step(largest / 3.0) is not None
    assert step(largest / 8.0) is None


def test_a_3d_track_that_refuses_what_the_ground_tracker_took_gives_its_position() -> None:
    """The ground tracker moved 0.8 m with an estimate the 3-D track refused: the ground
    track's position is given until the 3-D track takes an estimate again."""
    hops = HopFollower(CalibratedNoise())
    _joined(hops)  # on the still ball at (-1, 0)
    jumped = _sees("near", ROBOTS["near"], (-0.2, 0.0, BALL_RADIUS_M))
    track = _track(200 * MS, -0.2, 0.0)
    assert hops.takes(jumped, True, track, 200 * MS)
    assert hops.step(200 * MS, [jumped], track) is None
    assert hops._flight.tracker.last_accepted_ns == 180 * MS  # refused, not followed
    assert hops.step(210 * MS, [], track) is None  # still refusing at a tick
    back = _seen("side", 0.0)
    flight = hops.step(220 * MS, [back], _track(220 * MS, -1.0, 0.0))
    assert flight is not None and math.hypot(flight.x_m + 1.0, flight.y_m) < 0.02


def test_a_peek_between_images_changes_nothing_the_track_does_after_it() -> None:
    """A clock's tick reads the 3-D track (peek); the next images' steps are those of a
    track never peeked at, though stepping it there (step with no estimates) moves them."""
    reads = []

    def run(between: str) -> list[tuple[float, float]]:
        tracker, hops = BallTracker(), HopFollower(CalibratedNoise())
        out = []
        for k in range(70):  # the hopping ball again; a read 5 ms after every image
            t_ns = k * 12 * MS + k * MS // 2
            _, flight = _fed(tracker, hops, _seen(list(ROBOTS)[k % 3], t_ns / 1e9), t_ns)
            if flight is not None:
                out.append((flight.x_m, flight.y_m))
            tick = t_ns + 5 * MS
            if between == "peek":
                reads.append(hops.peek(tick, tracker.state_at(tick)))
            elif between == "step":
                hops.step(tick, [], tracker.state_at(tick))
        return out

    plain = run("none")
    assert len(plain) > 30
    assert run("peek") == plain
    assert sum(r is not None for r in reads) > 30  # the ticks read the 3-D track
    assert run("step") != plain


def test_a_lob_is_given_at_its_height_not_on_the_ground() -> None:
    """Cameras in sync: the near and side robots see the lob at each step, their rays
    crossed; the 3-D track's position is given with its height, within a few centimetres
    of the ball's centre in 3-D while it flies (on the ground the ball is 0.4 m below)."""
    tracker, hops = BallTracker(), HopFollower(CalibratedNoise())
    errors = []
    for k in range(40):  # 0.8 s at 50 Hz: still, then kicked up at 0.2 s
        t_ns = k * 20 * MS
        ball = _lob(t_ns / 1e9)
        taken = []
        for robot in ("near", "side"):
            e = _sees(robot, ROBOTS[robot], ball)
            accepted = tracker.update(Measurement(t_ns, robot, e.x_m, e.y_m,
                                                  covariance_rows(hops.noise.covariance(e))))
            if hops.takes(e, accepted, tracker.state_at(t_ns), t_ns):
                taken.append(e)
        state = tracker.state_at(t_ns)
        flight = hops.step(t_ns, taken, state if state is not None and state.confirmed else None)
        if ball[2] > BALL_RADIUS_M + 0.3:
            assert flight is not None and flight.z_m is not None
            errors.append(math.dist((flight.x_m, flight.y_m, flight.z_m), ball))
    assert len(errors) > 10
    assert max(errors) < 0.05


def test_a_rolling_3d_track_that_takes_nothing_while_the_ground_track_is_kicked_gives_way(
        ) -> None:
    """At a step without estimates for it, a rolling 3-D track whose velocity is kick_mps
    from the ground track's would move on with a velocity it has not found yet: the ground
    track's position is given; with the velocities alike, its own."""
    for v, given in ((5.0, False), (0.5, True)):
        hops = HopFollower(CalibratedNoise())
        _joined(hops)  # a still ball at (-1, 0), the last image at 180 ms
        cov = ((1e-2, 0.0), (0.0, 1e-2))
        kicked = TrackState(200 * MS, -1.0 + 0.02 * v, 0.0, v, 0.0, cov, cov, True)
        assert (hops.step(200 * MS, [], kicked) is not None) is given


@pytest.mark.parametrize(("height_m", "sigma_m", "kept"), [
    (0.06, 0.02, False),  # a kick the 3-D track missed, a hop a few centimetres up
    (0.14, 0.17, False),  # above lob_m, but not surely (two sigmas)
    (0.44, 0.11, True),  # surely up: a lob's first images, before its flight is fitted
])
def test_a_flying_3d_track_that_refuses_gives_way_unless_it_is_surely_up(
        height_m: float, sigma_m: float, kept: bool) -> None:
    """The 3-D track flies (by itself: no flight fitted to its rays) and refused the ground
    tracker's estimate: its position is given only when it is surely more than lob_m up."""
    hops = HopFollower(CalibratedNoise())
    _joined(hops)
    tracker = hops._flight.tracker
    assert tracker.x is not None and not hops._flight.flights.flying
    tracker.x[2], tracker.x[5] = BALL_RADIUS_M + height_m, 1.5
    tracker.P[2, 2] = sigma_m ** 2
    assert tracker.airborne
    jumped = _sees("near", ROBOTS["near"], (0.2, 0.0, BALL_RADIUS_M))  # 1.2 m on
    track = _track(200 * MS, 0.2, 0.0)
    assert hops.takes(jumped, True, track, 200 * MS)
    flight = hops.step(200 * MS, [jumped], track)
    assert hops._flight.tracker.last_accepted_ns != 200 * MS  # refused
    assert (flight is not None) == kept


@pytest.mark.parametrize(("since_ms", "kept"), [(60, True), (140, False)])
def test_a_3d_track_just_down_from_a_fitted_flight_keeps_its_position(
        since_ms: int, kept: bool) -> None:
    """The 3-D track flew a flight its fits followed, landed by itself (the ball coming
    down, no longer airborne) and refuses the next estimate (the ball bouncing up): within
    keep_ns of the flight its position is given, not the ground track's, which knew nothing
    of the flight; later the ground track's is."""
    hops = HopFollower(CalibratedNoise())
    _joined(hops)
    tracker = hops._flight.tracker
    assert tracker.x is not None
    tracker.x[2], tracker.x[5] = BALL_RADIUS_M + 0.5, 2.0
    theta = np.array([-1.0, 0.0, 0.5, 0.0, 0.0, 2.0])
    hops._flight.flights._kink = Kink(0, "free", "fly", theta, np.eye(6) * 1e-4, 0.0, 6, 3)
    assert tracker.airborne and hops._flight.flights.flying
    hops.step(190 * MS, [], _track(190 * MS, -1.0, 0.0))  # flying, at a tick
    tracker.x[2], tracker.x[5] = BALL_RADIUS_M, 0.0  # down
    assert not tracker.airborne
    t_ns = (190 + since_ms) * MS
    jumped = _sees("near", ROBOTS["near"], (0.2, 0.0, BALL_RADIUS_M))  # 1.2 m on
    track = _track(t_ns, 0.2, 0.0)
    assert hops.takes(jumped, True, track, t_ns)
    flight = hops.step(t_ns, [jumped], track)
    assert hops._flight.tracker.last_accepted_ns != t_ns  # refused
    assert (flight is not None) == kept
