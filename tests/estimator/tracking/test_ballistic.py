"""The 3-D tracker: a lob's arc followed and its landing predicted, a bounce, a kick up from
rolling, and one robot's view leaving the height unknown in the covariance."""

from __future__ import annotations

import copy
import math
from dataclasses import replace

import numpy as np
import pytest

from estimator.constants import BALL_RADIUS_M, NS_PER_S
from estimator.rays import BallRay
from estimator.tracking.ballistic import G_MPS2, BallisticParams, BallisticTracker

R = BALL_RADIUS_M
RATE_HZ = 20.0


def arc(t: float, v: tuple[float, float, float], start: tuple[float, float] = (0.0, 0.0),
        e: float = 0.6) -> tuple[float, float, float]:
    """A drag-free lob from the ground at t = 0 with bounces keeping e of vz."""
    x, y = start[0] + v[0] * t, start[1] + v[1] * t
    vz, t0 = v[2], 0.0
    while vz > 0.5:
        flight = 2 * vz / G_MPS2
        if t < t0 + flight:
            s = t - t0
            return x, y, R + vz * s - 0.5 * G_MPS2 * s * s
        t0 += flight
        vz *= e
    return x, y, R


def feed(tracker: BallisticTracker, times: np.ndarray, v: tuple[float, float, float],
         rng: np.random.Generator, sigma: float = 0.01) -> None:
    for t in times:
        p = np.array(arc(float(t), v)) + rng.normal(0.0, sigma, 3)
        tracker.update(round(t * NS_PER_S), tuple(p), np.eye(3) * sigma ** 2)


def test_a_lob_is_followed_and_its_landing_predicted_03_s_ahead() -> None:
    rng = np.random.default_rng(5)
    errors = []
    for _ in range(20):
        speed, elev = rng.uniform(6, 10), math.radians(rng.uniform(20, 50))
        az = rng.uniform(-math.pi, math.pi)
        h = speed * math.cos(elev)
        v = (h * math.cos(az), h * math.sin(az), speed * math.sin(elev))
        land_t = 2 * v[2] / G_MPS2
        tr = BallisticTracker()
        feed(tr, np.arange(0.0, land_t - 0.3, 1 / RATE_HZ), v, rng)
        landing = tr.landing()
        assert landing is not None
        assert abs(landing.stamp_ns / NS_PER_S - land_t) < 0.05
        errors.append(math.hypot(landing.x_m - v[0] * land_t, landing.y_m - v[1] * land_t))
    assert np.median(errors) < 0.15 and max(errors) < 0.3, errors


def test_through_a_bounce_and_down_to_rolling() -> None:
    rng = np.random.default_rng(6)
    v = (5.0, 0.0, 4.0)
    first = 2 * v[2] / G_MPS2
    tr = BallisticTracker()
    times = np.arange(0.0, 3.0, 1 / RATE_HZ)
    accepted = 0
    for t in times:
        p = np.array(arc(float(t), v)) + rng.normal(0.0, 0.01, 3)
        accepted += tr.update(round(t * NS_PER_S), tuple(p), np.eye(3) * 1e-4)
        if t > first + 0.1 and t < first + 0.3:  # after the bounce: up again, 0.6 of vz
            assert tr.x is not None and tr.x[5] == pytest.approx(
                0.6 * v[2] - G_MPS2 * (t - first), abs=0.5)
    assert accepted >= 0.9 * len(times)  # the last, small hops may be refused a few times
    assert tr.x is not None and not tr.airborne and abs(tr.x[2] - R) < 0.005  # rolls at the end
    assert tr.x[3] == pytest.approx(5.0, abs=0.2)
    assert tr.landing() is None


def test_a_rolling_ball_kicked_up_is_followed_at_once() -> None:
    rng = np.random.default_rng(7)
    tr = BallisticTracker()
    for t in np.arange(0.0, 1.0, 1 / RATE_HZ):  # rolling at 2 m/s
        tr.update(round(t * NS_PER_S), (2.0 * t + rng.normal(0, 0.01), 0.0, R), np.eye(3) * 1e-4)
    assert not tr.airborne
    v = (6.0, 0.0, 5.0)
    for t in np.arange(0.05, 0.5, 1 / RATE_HZ):
        x, y, z = arc(t, v, start=(2.0, 0.0))
        assert tr.update(round((1.0 + t) * NS_PER_S), (x, y, z), np.eye(3) * 1e-4)
    assert tr.airborne and tr.x is not None
    assert tr.x[5] == pytest.approx(v[2] - G_MPS2 * 0.45, abs=0.3)


def test_one_robot_s_ray_leaves_the_height_unknown() -> None:
    """Measurements whose covariance spreads along a ray from a camera 12 m up (one robot:
    no height): the track's z stays as uncertain as the rays say, it invents no height."""
    tr = BallisticTracker()
    u = np.array([0.4, 0.0, -0.9165])
    u /= np.linalg.norm(u)
    along = np.outer(u, u) * (3.4 / abs(u[2])) ** 2 / 3.0
    cov = along + np.eye(3) * 1e-4
    for t in np.arange(0.0, 1.0, 1 / RATE_HZ):
        tr.update(round(t * NS_PER_S), (1.0, 0.0, R), cov)
    assert tr.P[2, 2] > 0.5 ** 2


def _hit_a_robot(params: BallisticParams) -> tuple[BallisticTracker, list[bool], list[float]]:
    """At 0.3 s the ball bounces back off a robot (vx turns to -0.5 vx); 3-D measurements
    at 20 Hz: the tracker's answers and its position error after each."""
    rng = np.random.default_rng(8)
    v = (6.0, 0.0, 5.0)
    hit = 0.3
    x_hit, _, _ = arc(hit, v)

    def where(t: float) -> tuple[float, float, float]:
        _, _, z = arc(t, v)
        x = v[0] * t if t < hit else x_hit - 0.5 * v[0] * (t - hit)
        return x, 0.0, z

    tr = BallisticTracker(params)
    results, errors = [], []
    for t in np.arange(0.0, 0.9, 1 / RATE_HZ):
        p = np.array(where(float(t))) + rng.normal(0.0, 0.01, 3)
        results.append(tr.update(round(t * NS_PER_S), tuple(p), np.eye(3) * 1e-4))
        assert tr.x is not None
        errors.append(float(np.linalg.norm(tr.x[:3] - np.array(where(float(t))))))
    return tr, results, errors


def test_a_lob_that_hits_a_robot_is_picked_up_again_after_two_refusals() -> None:
    """Without restarting on a fixed point: the track refuses the next measurement,
    restarts at the second with the velocity between them, and follows the new flight."""
    tr, results, errors = _hit_a_robot(BallisticParams(restart_on_fixed=False))
    refused = [i for i, ok in enumerate(results) if not ok]
    assert 1 <= len(refused) <= 2 and refused[0] >= round(0.3 * RATE_HZ)
    assert all(results[refused[-1] + 1:])
    assert max(errors[i] for i in refused) > 0.2  # the refused steps: the old flight's
    assert tr.x is not None and tr.x[3] == pytest.approx(-3.0, abs=0.3)


def test_a_lob_that_hits_a_robot_restarts_at_the_first_point_it_misses() -> None:
    """3-D points (crossed rays) the track misses restart it at once: no step is refused
    and none is further off than the measurements' noise allows after the hit."""
    tr, results, errors = _hit_a_robot(BallisticParams())
    assert all(results)
    assert max(errors) < 0.06, errors
    assert tr.x is not None and tr.x[3] == pytest.approx(-3.0, abs=0.3)


def test_a_ray_the_track_misses_is_refused_not_restarted_on() -> None:
    """A refused one-robot measurement (its height unknown) never restarts the track by
    itself: a false blob's ray must not move a flying ball."""
    tr = BallisticTracker()
    for t in np.arange(0.0, 0.3, 1 / RATE_HZ):
        tr.update(round(t * NS_PER_S), arc(float(t), (5.0, 0.0, 5.0)), np.eye(3) * 1e-4)
    u = np.array([0.4, 0.0, -0.9165])
    u /= np.linalg.norm(u)
    cov = np.outer(u, u) * 3.0 + np.eye(3) * 1e-4
    assert tr.x is not None
    before = tr.x[:2].copy()
    assert not tr.update(round(0.3 * NS_PER_S), (before[0], before[1] + 3.0, R), cov)
    assert tr.x is not None and abs(tr.x[1] - before[1]) < 0.05


def _far_robots_point(camera: np.ndarray, ball: tuple[float, float, float]
                      ) -> tuple[tuple[float, float, float], np.ndarray]:
    """One robot's ground estimate of ``ball`` (where its ray meets z = R) and its covariance,
    wide along the ray (the height unknown)."""
    u = np.array(ball) - camera
    ground = camera + u * (camera[2] - R) / (camera[2] - ball[2])
    u /= np.linalg.norm(u)
    cov = np.outer(u, u) * 50.0 + np.eye(3) * 1e-4
    return (float(ground[0]), float(ground[1]), float(ground[2])), cov


def test_a_hop_seen_by_one_far_robot_restarts_on_its_ray_not_at_its_ground_point() -> None:
    """A rolling ball lobbed, seen only by a robot 10 m away whose camera is 0.85 m up: its
    ray passes through the ball, but meets the ground metres beyond it (5 and 8 m here). Two
    such points in a row restart the track (the ball met what the model does not know)
    where the ray passes nearest the predicted track, in the air: within 0.25 m of the ball
    (the prediction, still rolling, lags the lob along the ray), not at the ground point."""
    rng = np.random.default_rng(10)
    tr = BallisticTracker()
    for t in np.arange(0.0, 1.0, 1 / RATE_HZ):  # rolling at 1 m/s, 3-D points
        p = np.array([t, 0.0, R]) + rng.normal(0.0, [0.01, 0.01, 0.0])
        tr.update(round(t * NS_PER_S), tuple(p), np.eye(3) * 1e-4)
    assert not tr.airborne
    camera = np.array([11.0, 1.0, 0.85])
    v = (2.0, 0.5, 3.0)
    answers, ground_off = [], []
    for t in (0.1, 0.15):
        ball = arc(t, v, start=(1.0, 0.0))
        point, cov = _far_robots_point(camera, ball)
        ground_off.append(math.dist(point[:2], ball[:2]))
        answers.append(tr.update(round((1.0 + t) * NS_PER_S), point, cov))
    assert answers == [False, True]  # refused, then restarted on
    assert tr.x is not None and min(ground_off) > 2.5, ground_off
    assert math.dist(tr.x[:2], ball[:2]) < 0.25, (tr.x[:3], ball)
    assert tr.x[2] > R + 0.1  # in the air, as the ray says there


def test_a_ball_deflected_on_the_ground_restarts_at_a_far_robot_s_ground_point() -> None:
    """A rolling ball turned back by a robot, seen only by a robot 7 m away: its ground
    estimates are right, and two in a row 0.2 m apart (a ball's way in 50 ms) restart the
    track there, on the ground, not in the air where the ray passes the predicted track."""
    rng = np.random.default_rng(11)
    tr = BallisticTracker()
    for t in np.arange(0.0, 1.0, 1 / RATE_HZ):  # rolling at 2 m/s
        p = np.array([2.0 * t, 0.0, R]) + rng.normal(0.0, [0.01, 0.01, 0.0])
        tr.update(round(t * NS_PER_S), tuple(p), np.eye(3) * 1e-4)
    camera = np.array([8.0, 3.0, 0.85])
    answers = []
    for t in (0.1, 0.15):  # turned back at 1 s: -2 m/s
        ball = (2.0 - 2.0 * t, 0.0, R)
        point, cov = _far_robots_point(camera, ball)
        answers.append(tr.update(round((1.0 + t) * NS_PER_S), point, cov))
    assert answers == [False, True]
    assert tr.x is not None and math.dist(tr.x[:2], ball[:2]) < 0.05, (tr.x[:3], ball)
    assert not tr.airborne


def test_a_kick_seen_with_a_wide_height_takes_its_vertical_speed() -> None:
    """Two robots whose rays cross at a shallow angle: each point's height has a sigma of
    0.3 m, so the first point after a kick (0.5 m up) is not clearly in the air and the
    filter lifts the rolling track only part of the way. It must restart flying from that
    point, or it flies on at vz = 0 (held so while it rolled), falls short of the rising
    ball and, restarted later, from a wrong speed (0.3-0.4 m off from the fourth point on;
    within 0.17 m throughout when it restarts at the lift)."""
    rng = np.random.default_rng(9)
    cov = np.diag([0.02 ** 2, 0.02 ** 2, 0.3 ** 2])
    tr = BallisticTracker()
    for t in np.arange(0.0, 0.5, 1 / 10):  # rolling at 1 m/s, seen at 10 Hz
        p = np.array([t, 0.0, R]) + rng.normal(0.0, [0.02, 0.02, 0.0])
        tr.update(round(t * NS_PER_S), tuple(p), cov)
    v = (4.0, 0.0, 6.0)
    errors = []
    for t in np.arange(0.1, 0.8, 1 / 10):
        x, y, z = arc(t, v, start=(0.5, 0.0))
        tr.update(round((0.5 + t) * NS_PER_S), (x, y, z), cov)
        assert tr.x is not None
        errors.append(float(np.linalg.norm(tr.x[:3] - np.array([x, y, z]))))
    assert max(errors) < 0.2 and errors[-1] < 0.1, errors


CAMERAS = {"robot1": (-4.0, 2.0, 12.0), "robot2": (4.0, 3.0, 12.0)}


def _ray(robot: str, ball: tuple[float, float, float], rng: np.random.Generator,
         sigma_rad: float = 0.001) -> BallRay:
    """The robot's ray to ``ball``, its direction off by ``sigma_rad`` each way across."""
    o = np.array(CAMERAS[robot])
    u = np.array(ball) - o
    u /= np.linalg.norm(u)
    exact = BallRay(robot, tuple(o), tuple(u), sigma_rad, sigma_rad)
    e_az, e_el = exact.across()
    u = u + rng.normal(0.0, sigma_rad) * e_az + rng.normal(0.0, sigma_rad) * e_el
    u /= np.linalg.norm(u)
    return BallRay(robot, exact.origin, (float(u[0]), float(u[1]), float(u[2])),
                   sigma_rad, sigma_rad)


def test_rays_of_two_robots_at_their_own_stamps_give_the_lob_in_3d() -> None:
    """Free-running cameras: the robots' images alternate (each robot at 10 Hz, 50 ms after
    the other), so no two rays are of one instant. Started 0.3 m off with its velocity
    unknown, the track takes each ray at its stamp and within 0.3 s is within a few
    centimetres in 3-D."""
    rng = np.random.default_rng(12)
    v = (4.0, 1.0, 5.0)
    start = np.array(arc(0.1, v)) + np.array([0.2, -0.15, 0.15])
    tr = BallisticTracker()
    tr.update(round(0.1 * NS_PER_S), tuple(start), np.eye(3) * 0.3 ** 2)
    errors = []
    for k in range(1, 16):
        t = 0.1 + 0.05 * k
        robot = "robot1" if k % 2 else "robot2"
        assert tr.update_ray(round(t * NS_PER_S), _ray(robot, arc(t, v), rng))
        assert tr.x is not None
        errors.append(float(np.linalg.norm(tr.x[:3] - np.array(arc(t, v)))))
    assert max(errors[6:]) < 0.05, errors
    assert tr.x is not None and tr.x[5] == pytest.approx(v[2] - G_MPS2 * 0.85, abs=0.3)
    assert tr.airborne and tr.P[2, 2] < 0.05 ** 2


def test_one_robot_s_rays_alone_leave_the_height_unknown() -> None:
    """One robot's ray on a track whose height is unknown (its ground estimate, spread along
    the ray): the track does not take it as a ray (it has no height to correct) and its
    height variance stays wide."""
    rng = np.random.default_rng(13)
    first = _ray("robot1", (1.0, 0.0, 1.0), rng)
    u = np.array(first.direction)
    tr = BallisticTracker()
    tr.update(0, first.ground_point, np.outer(u, u) * 9.0 + np.eye(3) * 1e-4)
    for k in range(1, 20):
        t = 0.1 * k
        assert not tr.update_ray(round(t * NS_PER_S), _ray("robot1", (1.0 + t, 0.0, 1.0), rng))
    assert not tr.airborne and tr.P[2, 2] > 0.5


def test_a_flight_the_rays_take_above_3_5_m_is_given_up() -> None:
    """Rays that cross where no lob flies (the track pulled to 3.6 m, still rising): the
    flight is given up, its height unknown again, and it rolls."""
    rng = np.random.default_rng(14)
    tr = BallisticTracker()
    tr.update(0, (0.0, 0.0, 3.3), np.eye(3) * 0.05 ** 2)
    assert tr.airborne
    taken = [tr.update_ray(round(0.05 * k * NS_PER_S), _ray(robot, (0.0, 0.0, 3.3 + 0.3 * k),
                                                            rng))
             for k, robot in ((1, "robot1"), (2, "robot2"), (3, "robot1"))]
    assert not all(taken)
    assert not tr.airborne and tr.P[2, 2] > 0.5 and tr.x is not None and tr.x[2] == R


def test_a_crossing_no_ball_could_have_reached_restarts_without_its_speed() -> None:
    """A 3-D point the track refuses restarts it there, with the velocity of the way from the
    last accepted point; a way faster than ``max_speed_mps`` (far robots' rays crossed at a
    shallow angle, a metre out) tells no speed: the level velocity is kept, loosely, and the
    point's position is loosened too, so a near robot's ray brings the track back."""
    tr = BallisticTracker()
    for t in np.arange(0.0, 0.5, 1 / RATE_HZ):
        tr.update(round(t * NS_PER_S), (2.0 * t, 0.0, R), np.eye(3) * 1e-4)
    assert tr.x is not None and tr.x[3] == pytest.approx(2.0, abs=0.1)
    dt = 1 / RATE_HZ
    t_off = 0.45 + dt
    off = (2.0 * t_off + 0.8, 0.5, R + 0.05)  # 19 m/s from the last point
    assert tr.update(round(t_off * NS_PER_S), off, np.eye(3) * 1e-4)
    assert tr.x is not None
    assert tr.x[:2] == pytest.approx(off[:2], abs=0.01)  # restarted there
    assert math.hypot(tr.x[3], tr.x[4]) < tr.params.max_speed_mps
    assert tr.x[3] == pytest.approx(2.0, abs=0.3) and abs(tr.x[4]) < 0.3
    assert tr.P[3, 3] >= tr.params.initial_speed_sigma_mps ** 2 - 1e-9
    t = t_off + 0.5 * dt  # a robot 0.6 m from the ball, rolling on where it was, sees it
    camera = np.array([2.0 * t - 0.5, -0.3, 0.85])
    u = np.array([2.0 * t, 0.0, R]) - camera
    assert tr.update_ray(round(t * NS_PER_S), BallRay(
        "near", tuple(camera), tuple(u / np.linalg.norm(u)), 0.005, 0.005))
    assert tr.x is not None
    assert math.hypot(tr.x[0] - 2.0 * t, tr.x[1]) < 0.15  # brought back, not refused


KICK = (2.8, -6.2, 1.5)
"""A rolling ball kicked up at 1 s: its level and vertical speed [m/s]."""
ROLL = np.array([-1.7, 1.8])


def _kicked_up(t: float) -> tuple[float, float, float]:
    x, y, z = arc(t - 1.0, KICK, start=(float(ROLL[0]), float(ROLL[1])))
    return x, y, z


def _restarted_by_a_kick_up() -> BallisticTracker:
    """Rolling at 2.5 m/s on three robots' crossed points, then kicked up: the first crossed
    point after the kick, 8 ms after the last, restarts the track with no speed."""
    rng = np.random.default_rng(15)
    tr = BallisticTracker()
    for t in np.arange(0.0, 1.0, 1 / 60):
        p = np.concatenate([ROLL * t, [R]]) + rng.normal(0.0, [0.005, 0.005, 0.0])
        tr.update(round(t * NS_PER_S), tuple(p), np.eye(3) * 1e-4)
    assert tr.update(round(1.0083 * NS_PER_S), _kicked_up(1.0083), np.eye(3) * 1e-4)
    assert tr.x is not None and tr.P[3, 3] >= tr.params.initial_speed_sigma_mps ** 2 - 1e-9
    return tr


def test_one_robot_s_point_no_ball_could_roll_to_is_refused() -> None:
    """Just restarted, its speed unknown, the rolling track is shown a far robot's ground
    point 0.8 m out along its ray under the rising ball: taken, it would roll the track at
    14 m/s, faster than any ball runs. It is refused, and the track is as it was."""
    tr = _restarted_by_a_kick_up()
    camera = np.array([-11.0, -1.0, 0.85])
    point, cov = _far_robots_point(camera, _kicked_up(1.046))
    assert math.dist(point[:2], _kicked_up(1.046)[:2]) > 0.5  # the far robot's lifted view
    # a twin for which no speed is too fast takes it, and rolls at 14 m/s
    twin = copy.deepcopy(tr)
    twin.params = replace(tr.params, max_speed_mps=1e9)
    assert twin.update(round(1.046 * NS_PER_S), point, cov)
    assert twin.x is not None and math.hypot(twin.x[3], twin.x[4]) > 12.0
    assert tr.x is not None
    v = tr.x[3:5].copy()
    assert not tr.update(round(1.046 * NS_PER_S), point, cov)
    assert tr.x[3:5] == pytest.approx(v)


def test_a_kick_up_restarts_with_the_way_between_crossed_points() -> None:
    """A ball kicked up: the first crossed point after the kick restarts the track with no
    speed (the last point 8 ms before), and the next, 42 ms later, is refused too. Its
    restart takes the speed of the way from the first (both after the kick, each a few
    centimetres off), within 1 m/s of the kick's, where the old rule had no speed to go on
    (the last accepted point under 50 ms before) and kept the track's."""
    tr = _restarted_by_a_kick_up()
    assert tr.update(round(1.05 * NS_PER_S), _kicked_up(1.05), np.eye(3) * 1e-4)
    assert tr.x is not None and tr.x[:3] == pytest.approx(_kicked_up(1.05), abs=0.01)
    assert math.hypot(tr.x[3] - KICK[0], tr.x[4] - KICK[1]) < 1.0, tr.x[3:]
    assert tr.P[3, 3] == pytest.approx(tr.params.launch_sigma_mps ** 2)


def test_a_high_lob_under_the_top_is_followed_by_rays_to_its_apex() -> None:
    """Guards the apex (z + vz^2 / 2g): a lob thrown up at 7 m/s peaks at 2.6 m, under
    ``top_m`` (3.5 m); every ray of two robots is taken and the track stays in the air. An
    apex of vz^2 / g (5 m) would give the flight up as one no ball flies."""
    rng = np.random.default_rng(21)
    v = (3.0, 0.0, 7.0)
    assert R + v[2] ** 2 / (2 * G_MPS2) < BallisticParams().top_m < v[2] ** 2 / G_MPS2
    tr = BallisticTracker()
    tr.update(round(0.1 * NS_PER_S), arc(0.1, v), np.eye(3) * 0.02 ** 2)
    for k in range(1, 12):
        t = 0.1 + 0.05 * k
        robot = "robot1" if k % 2 else "robot2"
        assert tr.update_ray(round(t * NS_PER_S), _ray(robot, arc(t, v), rng)), k
        assert tr.airborne and tr.x is not None
    assert tr.x is not None and abs(tr.x[2] - arc(0.65, v)[2]) < 0.1  # near the apex


def _offset_ray(tr: BallisticTracker, robot: str, d2: float) -> BallRay:
    """A ray of ``robot`` that misses the track sideways by as much as gives the
    Mahalanobis distance ``d2`` (2 directions across the ray), its sigmas 1 mrad."""
    assert tr.x is not None
    p = tr.x[:3]
    u = p - np.array(CAMERAS[robot])
    length = float(np.linalg.norm(u))
    u /= length
    exact = BallRay(robot, CAMERAS[robot], (float(u[0]), float(u[1]), float(u[2])),
                    0.001, 0.001)
    e_az, e_el = exact.across()
    H = np.vstack([e_az, e_el])
    S = H @ tr.P[:3, :3] @ H.T + np.eye(2) * (length * 0.001) ** 2
    delta = math.sqrt(d2 / float(np.linalg.inv(S)[0, 0]))
    origin = p + delta * np.array(e_az) - length * u  # moved across: the ray misses by delta
    return BallRay(robot, (float(origin[0]), float(origin[1]), float(origin[2])),
                   exact.direction, 0.001, 0.001)


@pytest.mark.parametrize(("d2", "taken"), [(12.5, True), (15.0, False)])
def test_a_ray_is_gated_at_the_chi_square_of_its_two_directions(d2: float,
                                                                 taken: bool) -> None:
    """Guards the ray gate: a ray measures 2 directions, so it is refused past chi-square(2)
    at 99.9 % (13.82), not chi-square(3)'s 16.27: a miss of d^2 = 15 is refused."""
    tr = BallisticTracker()
    tr.update(0, (1.0, 0.5, 1.5), np.eye(3) * 0.05 ** 2)
    assert tr.airborne
    assert tr.update_ray(0, _offset_ray(tr, "robot1", d2)) is taken
