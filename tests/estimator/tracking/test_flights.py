"""Flights fitted to rays of different instants (estimator.tracking.flight_fit, .flights):
a synthetic ball, three robots' rays at their own stamps (free-running cameras)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest

from estimator.constants import BALL_RADIUS_M, NS_PER_S
from estimator.rays import BallRay
from estimator.tracking import flights
from estimator.tracking.ballistic import G_MPS2, BallisticTracker
from estimator.tracking.flight_fit import (
    Job,
    Kink,
    StampedRay,
    contact_time,
    fit_jobs,
    fit_kink,
    fit_kinks,
    per_dof,
    ray_rows,
)
from estimator.tracking.flights import FlightFollower

CAMERAS = {"robot1": (0.0, 0.0, 0.8), "robot2": (6.0, 4.0, 0.8), "robot3": (-3.0, 5.0, 0.8)}
KICK_S = 0.3
START = np.array([1.0, 1.0, BALL_RADIUS_M])
ROLL = np.array([0.5, 0.0, 0.0])
LOB = np.array([3.0, 1.0, 4.5])


def ball(t: float, up: np.ndarray = LOB) -> np.ndarray:
    """Rolling at 0.5 m/s until KICK_S, then kicked: up (a lob) or along the ground."""
    kick = START + ROLL * KICK_S
    if t < KICK_S:
        return START + ROLL * t
    tau = t - KICK_S
    if up[2] == 0.0:
        return kick + up * tau
    return kick + up * tau + np.array([0.0, 0.0, -0.5 * G_MPS2 * tau * tau])


def ray(robot: str, p: np.ndarray, rng: np.random.Generator, sigma: float = 0.003) -> BallRay:
    """The robot's ray to ``p``, off by ``sigma`` each way across it."""
    c = np.array(CAMERAS[robot])
    u = (p - c) / np.linalg.norm(p - c)
    exact = BallRay(robot, tuple(c), tuple(u), sigma, sigma)
    e_az, e_el = exact.across()
    u = u + rng.normal(0.0, sigma) * e_az + rng.normal(0.0, sigma) * e_el
    u /= np.linalg.norm(u)
    return BallRay(robot, exact.origin, (float(u[0]), float(u[1]), float(u[2])), sigma, sigma)


def images(until_s: float, up: np.ndarray = LOB, seed: int = 1
           ) -> list[tuple[int, BallRay, np.ndarray]]:
    """Three robots' images in turn, 60 a second together: (stamp, ray, true centre)."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(round(until_s * 60)):
        t = k / 60
        p = ball(t, up)
        out.append((round(t * NS_PER_S), ray(f"robot{k % 3 + 1}", p, rng), p))
    return out


def test_rays_of_their_own_instants_fix_the_kick_and_the_flight() -> None:
    """Rays of three robots, no two of one instant, 0.15 s either side of a lob's kick:
    the fitted kick is within 5 ms, the ball at the last ray within 2 cm (and within its
    covariance), its speed up within 0.2 m/s, and a kick along the ground fits far worse."""
    shots = images(0.45)
    rays = [(t, r) for t, r, _ in shots]
    kink = contact_time(rays, 0, shots[-1][0])
    assert kink is not None
    assert kink.contact_ns / NS_PER_S == pytest.approx(KICK_S, abs=0.005)
    x, P = kink.state_at(shots[-1][0])
    err = x[:3] - shots[-1][2]
    assert np.linalg.norm(err) < 0.02
    assert float(err @ np.linalg.solve(P[:3, :3], err)) < 16.27  # its covariance says so
    tau = shots[-1][0] / NS_PER_S - KICK_S
    assert x[5] == pytest.approx(LOB[2] - G_MPS2 * tau, abs=0.2)
    assert per_dof(kink) < 2.0
    roll = contact_time(rays, 0, shots[-1][0], "roll", "roll")
    assert roll is not None and roll.chi2 > 10 * kink.chi2 + 100


def test_a_false_blob_s_ray_is_dropped_from_the_fit() -> None:
    """One ray of a false blob, a metre off the ball: the fit drops it and still places
    the ball within 2 cm."""
    shots = images(0.45)
    rays = [(t, r) for t, r, _ in shots]
    t, good = rays[20]
    rays[20] = (t, ray(good.robot, shots[20][2] + np.array([1.0, -0.5, 0.0]),
                       np.random.default_rng(5)))
    kink = fit_kink(rays, round(KICK_S * NS_PER_S))
    assert kink is not None and kink.rays == len(rays) - 1
    x, _ = kink.state_at(shots[-1][0])
    assert np.linalg.norm(x[:3] - shots[-1][2]) < 0.02


def test_one_flight_through_rays_of_a_ball_already_in_the_air() -> None:
    """No contact among the rays (all after the kick): one flight through them all."""
    shots = [s for s in images(0.6) if s[0] >= 0.35 * NS_PER_S]
    free = fit_kink([(t, r) for t, r, _ in shots], shots[-1][0], "free", "fly")
    assert free is not None
    x, _ = free.state_at(shots[-1][0])
    assert np.linalg.norm(x[:3] - shots[-1][2]) < 0.02


def _follow(shots: list[tuple[int, BallRay, np.ndarray]]
            ) -> tuple[BallisticTracker, list[tuple[int, bool, float]]]:
    """The 3-D track fed as the replay feeds it: a rolling track the ground points, a
    flying one each ray; the follower after each. (stamp, airborne, 3-D error) each step."""
    tracker, follower, out = BallisticTracker(), FlightFollower(), []
    for stamp, r, p in shots:
        if tracker.airborne:
            tracker.update_ray(stamp, r)
        else:
            u = np.array(r.direction)
            tracker.update(stamp, r.ground_point, np.outer(u, u) * 9.0 + np.eye(3) * 1e-3)
        follower.step(stamp, [r], tracker)
        assert tracker.x is not None
        out.append((stamp, tracker.airborne, float(np.linalg.norm(tracker.x[:3] - p))))
    return tracker, out


def test_a_lob_is_flown_from_its_first_rays_with_no_pair_of_one_instant() -> None:
    """The kick up is seen within four images (67 ms), and from then on the track is within
    3 cm of the ball in 3-D; one robot's ground points alone could not lift it."""
    land = KICK_S + 2 * LOB[2] / G_MPS2
    _, steps = _follow(images(land - 0.05))
    flying = [s for s in steps if s[1]]
    assert flying and flying[0][0] / NS_PER_S <= KICK_S + 0.067
    assert max(e for t, _, e in steps if t >= flying[0][0]) < 0.03


def test_a_kick_along_the_ground_starts_no_flight() -> None:
    """A ball kicked along the ground at 4 m/s: never taken for a lob."""
    _, steps = _follow(images(0.6, up=np.array([4.0, -1.0, 0.0])))
    assert not any(airborne for _, airborne, _ in steps)


def test_a_reset_state_is_the_track_s() -> None:
    tracker = BallisticTracker()
    x = np.array([1.0, 2.0, 0.5, 3.0, 0.0, 2.0])
    tracker.reset_to(5, x, np.eye(6) * 1e-4)
    assert tracker.airborne and tracker.last_accepted_ns == 5
    assert tracker.x is not None and np.allclose(tracker.x, x)


def test_a_ball_coming_down_from_above_the_lens_is_flown_with_no_track_before() -> None:
    """Cameras at robot height lose a lob above their lens: its first rays are of a ball
    already falling, and there is no track (every ray went to the fits alone). One flight
    through five rays of three robots starts the track, 6 cm off three rays on (each taken
    by the flying track); one made afresh (for a new track) keeps the rays seen."""
    shots = [s for s in images(KICK_S + 2 * LOB[2] / G_MPS2 - 0.05)
             if s[0] >= (KICK_S + 0.6) * NS_PER_S]
    tracker, follower = BallisticTracker(), FlightFollower()
    for k, (stamp, r, _) in enumerate(shots[:8]):
        if tracker.airborne:
            assert tracker.update_ray(stamp, r)
            follower.step(stamp, [r], tracker)
            continue
        follower.offer_all([r])
        taken = follower.step(stamp, [], tracker)
        assert taken == (k == 4), k  # the fifth ray: a flight, coming down
        if k == 3:
            follower = follower.afresh()
    assert tracker.x is not None and tracker.airborne and tracker.x[5] < -2.0
    assert np.linalg.norm(tracker.x[:3] - shots[7][2]) < 0.06


def test_one_robot_s_rays_fix_a_flight_s_height_over_enough_of_it() -> None:
    """Gravity is known, so one camera's rays fix a flight's scale (a flight c + s (p - c)
    falls s g): over 0.85 s of a lob, 18 images of one robot place the ball within 0.1 m
    of the truth, while over 0.3 s the fit's own covariance says decimetres (along the
    ray)."""
    def fitted(span_s: float, seed: int) -> tuple[float, float]:
        rng = np.random.default_rng(seed)
        times = [KICK_S + 0.05 + k / 20 for k in range(round(span_s * 20) + 1)]
        rays = [(round(t * NS_PER_S), ray("robot1", ball(t), rng)) for t in times]
        free = fit_kink(rays, rays[-1][0], "free", "fly")
        assert free is not None and free.robots == 1
        x, P = free.state_at(rays[-1][0])
        return (float(np.linalg.norm(x[:3] - ball(times[-1]))),
                float(np.sqrt(np.linalg.eigvalsh(P[:3, :3])[-1])))

    long_errors = [fitted(0.85, seed)[0] for seed in range(5)]
    assert max(long_errors) < 0.1, long_errors
    assert min(fitted(0.3, seed)[1] for seed in range(5)) > 0.1


def test_fits_solved_together_are_the_fits_made_one_by_one() -> None:
    """Kinds of different sizes in one batch (padded to the largest), a false blob's ray
    dropped: each fit is the one made alone, to rounding."""
    shots = images(0.45)
    rays = [(t, r) for t, r, _ in shots]
    t, good = rays[20]
    rays[20] = (t, ray(good.robot, shots[20][2] + np.array([1.0, -0.5, 0.0]),
                       np.random.default_rng(5)))
    contacts = [round(s * NS_PER_S) for s in (0.2, 0.3, 0.35)]
    jobs = [(contacts, "roll", "fly"), (contacts[:2], "fly", "fly"),
            ([shots[-1][0]], "free", "fly"), (contacts[1:], "roll", "roll")]
    for (at, before, after), fits in zip(jobs, fit_jobs(rays, jobs), strict=True):
        for contact, together in zip(at, fits, strict=True):
            alone = fit_kinks(rays, [contact], before, after)[0]
            assert together is not None and alone is not None
            assert together.theta.size == alone.theta.size
            assert np.allclose(together.theta, alone.theta, atol=1e-9)
            assert np.allclose(together.cov, alone.cov, rtol=1e-6, atol=1e-12)
            assert (together.rays, together.robots) == (alone.rays, alone.robots)
            assert together.chi2 == pytest.approx(alone.chi2, rel=1e-9)


def test_a_ray_s_row_is_its_camera_direction_and_the_vectors_across_it() -> None:
    """The fits' row of a ray (made in floats) agrees with BallRay's own geometry."""
    for _, r, _ in images(0.2, seed=3):
        row = ray_rows(r)
        e_az, e_el = r.across()
        ground = np.linalg.norm(np.array(r.ground_point) - np.array(r.origin))
        assert np.allclose(row[:6], [*r.origin, *r.direction])
        assert np.allclose(row[6:12], [*e_az, *e_el], atol=1e-12)
        assert row[14] == pytest.approx(ground, rel=1e-12)


def test_a_kick_along_the_ground_ends_the_search_at_its_rough_fits(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A ball kicked along the ground sets off launch searches, but no rough fit comes near
    a lob, so none asks for the full fits; a lob's search does, and starts the flight."""
    asked: list[bool] = []

    def counted(rays: Sequence[StampedRay], jobs: Sequence[Job], rough: bool = False
                ) -> list[list[Kink | None]]:
        asked.append(rough)
        return fit_jobs(rays, jobs, rough)

    monkeypatch.setattr(flights, "fit_jobs", counted)
    _, steps = _follow(images(0.6, up=np.array([4.0, -1.0, 0.0])))
    assert asked and all(asked) and not any(airborne for _, airborne, _ in steps)
    asked.clear()
    _, steps = _follow(images(0.5))
    assert not all(asked) and any(airborne for _, airborne, _ in steps)


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_a_ball_rising_at_a_log_s_first_rays_is_flown_from_the_fifth(seed: int) -> None:
    """A log that begins with the ball already rising (kicked before its first image): the
    fifth ray of three robots starts one flight through them all (five rays of two robots
    or more fix a flight's six values), its speed up within 0.5 m/s of the ball's."""
    shots = [s for s in images(KICK_S + 0.25, seed=seed) if s[0] >= (KICK_S + 0.1) * NS_PER_S]
    tracker, follower = BallisticTracker(), FlightFollower()
    for k, (stamp, r, _) in enumerate(shots[:5]):
        follower.offer_all([r])
        assert follower.step(stamp, [], tracker) == (k == 4), k
    t_last = shots[4][0] / NS_PER_S - KICK_S
    assert tracker.x is not None
    assert abs(tracker.x[5] - (LOB[2] - G_MPS2 * t_last)) < 0.5
    assert np.linalg.norm(tracker.x[:3] - shots[4][2]) < 0.15


def _kink(before: str, vz: float, chi2: float) -> Kink:
    """A fit of five rays: one flight (``free``) or a fall and a flight on (``fly``)."""
    head = {"free": [1.0, 1.0, 0.5], "fly": [1.0, 1.0, 0.0, 0.0, -2.0]}[before]
    theta = np.array([*head, 3.0, 1.0, vz])
    return Kink(0, before, "fly", theta, np.eye(theta.size) * 1e-4, chi2, 5, 3)


def test_the_flight_chosen_pays_for_its_parameters_and_flies_no_faster_than_a_ball() -> None:
    """Five rays fit a kink (eight values and its instant) closer than one flight (six):
    the closer fit is chosen only when it is closer by more than Akaike's two a value;
    a fit rising faster than any ball (``top_mps``) is never chosen."""
    follower = FlightFollower()
    free, kink = _kink("free", 5.6, 5.0), _kink("fly", 11.5, 0.7)
    assert follower._best([kink, free], 5) is free
    assert follower._best([kink, _kink("free", 5.6, 15.0)], 5) is kink
    assert follower._best([_kink("fly", 40.0, 0.0), free], 5) is free
    assert follower._best([_kink("fly", 40.0, 0.0)], 5) is None


def test_a_flight_begun_wrong_is_refitted_from_its_kick_before_six_rays_follow() -> None:
    """A flight started from the kick's first two rays with the level speed wrong (here:
    none) and sure of it: the third ray after the kick, refused by the filter, refits the
    kick with it; the track takes that fit and is within 3 cm of the ball a ray later, long
    before the six rays a flight of its own needs."""
    shots = images(KICK_S + 0.2)
    after = [k for k, s in enumerate(shots) if s[0] > KICK_S * NS_PER_S]
    tracker, follower = BallisticTracker(), FlightFollower()
    for stamp, r, _ in shots[:after[1] + 1]:
        follower._rays.append((stamp, r))
    lo = round((KICK_S - 0.04) * NS_PER_S)
    kink = contact_time(follower._rays, lo, shots[after[1]][0], "roll", "fly")
    assert kink is not None
    x, P = kink.state_at(shots[after[1]][0])
    x[3:5] = 0.0  # begun wrong, and sure of it: the filter refuses the rays after
    tracker.reset_to(shots[after[1]][0], x, P * 0.01)
    follower._kink = kink
    taken = []
    for stamp, r, _ in shots[after[2]:after[4]]:
        tracker.update_ray(stamp, r)
        taken.append(follower.step(stamp, [r], tracker))
    assert taken[0] and tracker.x is not None
    assert np.linalg.norm(tracker.x[:3] - shots[after[4] - 1][2]) < 0.03
