"""The ball tracker: constant velocity, bounces, outliers, loss and re-acquisition, friction,
late estimates, and the calibrated noise that makes ``robust`` fusion differ from ``weighted``."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from estimator.calibration.models import MirrorCalibration
from estimator.errors import FusionError
from estimator.estimates import BallEstimate
from estimator.fusion import RobustFusion, WeightedFusion, get_fusion
from estimator.noise import CalibratedNoise, NoiseModel
from estimator.tracking import BallTracker, Measurement, TrackerParams, TrackState
from estimator.tracking.model import predict, process_noise, transition, update
from estimator.tracking.smoother import FilterNode, rts_smooth

MS = 1_000_000
SIGMA = 0.003  # measurement noise [m]
R = ((SIGMA**2, 0.0), (0.0, SIGMA**2))
ROBOTS = ("robot1", "robot2", "robot3")
PHASES_MS = (0, 17, 34)  # free-running 20 Hz cameras, no two stamps alike

Path = Callable[[float], tuple[tuple[float, float], tuple[float, float]]]


def feed(tracker: BallTracker, path: Path, *, frames: int, noise: float = SIGMA,
         seed: int = 0, skip: Callable[[str, float], bool] = lambda robot, t: False,
         observe: Callable[[str, float], tuple[float, float] | None] = lambda robot, t: None,
         ) -> list[tuple[float, str, bool, TrackState | None]]:
    """Three robots at 20 Hz with phases 0/17/34 ms see the ball on ``path`` (or what
    ``observe`` says they see); returns (t, robot, accepted, state at t) per estimate."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(frames):
        for robot, phase in zip(ROBOTS, PHASES_MS, strict=True):
            t_ns = k * 50 * MS + phase * MS
            t = t_ns / 1e9
            if skip(robot, t):
                continue
            seen = observe(robot, t) or path(t)[0]
            z = (seen[0] + rng.normal(0, noise), seen[1] + rng.normal(0, noise))
            accepted = tracker.update(Measurement(t_ns, robot, z[0], z[1], R))
            out.append((t, robot, accepted, tracker.state_at(t_ns)))
    return out


def error(state: TrackState | None, path: Path, t: float) -> tuple[float, float]:
    assert state is not None
    (x, y), (vx, vy) = path(t)
    return (math.hypot(state.x_m - x, state.y_m - y),
            math.hypot(state.vx_m_s - vx, state.vy_m_s - vy))


def straight(t: float) -> tuple[tuple[float, float], tuple[float, float]]:
    return (1.0 + 3.0 * t, 0.5 - 1.0 * t), (3.0, -1.0)


def test_constant_velocity_converges_to_the_exact_motion() -> None:
    exact = TrackerParams(friction_per_s=0.0)
    steps = feed(BallTracker(exact), straight, frames=40, noise=0.0)
    t, _, _accepted, state = steps[-1]
    assert all(a for _, _, a, _ in steps)
    pos, vel = error(state, straight, t)
    # noise-free: the position is exact, the velocity (the offsets' filter, which lets each
    # robot's first estimates sit a little off the others' and forgets that over seconds)
    # within 0.1 mm/s
    assert pos < 1e-9 and vel < 1e-4
    # with 3 mm noise: after the first frames within millimetres and centimetres a second
    noisy = feed(BallTracker(exact), straight, frames=40)
    errors = np.array([error(s, straight, t) for t, _, _, s in noisy[9:]])
    assert np.sqrt(np.mean(errors[:, 0] ** 2)) < 0.004 and np.max(errors[:, 0]) < 0.012
    assert np.median(errors[:, 1]) < 0.15 and np.max(errors[:, 1]) < 0.4
    assert noisy[-1][3] is not None and noisy[-1][3].confirmed


def bounce(t: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """+x at 4 m/s, then off a robot at t = 0.5 s: (-3, -2) m/s."""
    if t < 0.5:
        return (4.0 * t, 0.0), (4.0, 0.0)
    return (2.0 - 3.0 * (t - 0.5), -2.0 * (t - 0.5)), (-3.0, -2.0)


def test_a_bounce_is_followed_within_two_frames() -> None:
    steps = feed(BallTracker(), bounce, frames=30)
    after = [s for s in steps if s[0] >= 0.5]
    # the first estimate after the bounce may wait for corroboration; by the second the
    # track has turned; every estimate after the bounce ends up accepted or explained
    for t, robot, _accepted, state in after[2:12]:
        pos, vel = error(state, bounce, t)
        assert pos < 0.012, (t, robot, pos)
        assert vel < 0.8, (t, robot, vel)
    assert sum(not a for _, _, a, _ in after) <= 1
    t, _, _, state = after[-1]
    assert error(state, bounce, t)[1] < 0.3


def kicked_back(t: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """+x at 4 m/s, then kicked straight back at t = 0.5 s (just after robot1's estimate at
    0.5 s) to -8 m/s: a change of velocity of 12 m/s."""
    if t <= 0.5:
        return (4.0 * t, 0.0), (4.0, 0.0)
    return (2.0 - 8.0 * (t - 0.5), 0.0), (-8.0, 0.0)


def test_a_corroborated_kick_inflates_the_velocity_variance_by_kick_sigma_squared() -> None:
    """Guards the kick's inflation ``P_v + kick_sigma^2 I``: at the default kick_sigma of
    6 m/s a kick of 12 m/s is 2 sigma and both estimates after it pass the gate; with
    ``P_v + kick_sigma I`` (a variance of 6) it would be 4.9 sigma and both stay rejected.
    Re-acquisition and lone kicks are off, so only the corroborated kick can follow it."""
    params = TrackerParams(friction_per_s=0.0, reacquire_count=1_000, lone_kick_ns=0)
    assert params.kick_sigma_m_s == 6.0
    tracker = BallTracker(params)
    steps = feed(tracker, kicked_back, frames=16)
    after = [s for s in steps if s[0] > 0.5]
    assert [(round(t * 1e3), robot) for t, robot, _, _ in after[:2]] == [
        (517, "robot2"), (534, "robot3")]
    assert not after[0][2]  # nothing corroborates the first estimate after the kick yet
    assert after[1][2]  # the second does: a kick explains both
    assert tracker.accepted_at(517 * MS) == ("robot2",)
    for t, _, accepted, state in after[1:]:
        pos, vel = error(state, kicked_back, t)
        assert accepted and pos < 0.01 and vel < 0.5, (t, pos, vel)


def test_a_false_blob_one_metre_off_never_pulls_the_track() -> None:
    def distractor(robot: str, t: float) -> tuple[float, float] | None:
        (x, y), _ = straight(t)
        return (x + 0.6, y + 0.8) if robot == "robot2" and t > 0.1 else None  # 1 m off

    steps = feed(BallTracker(), straight, frames=40, observe=distractor)
    rejected = [(t, a) for t, robot, a, _ in steps if robot == "robot2" and t > 0.1]
    assert rejected and not any(a for _, a in rejected)
    assert max(error(s, straight, t)[0] for t, _, _, s in steps[3:]) < 0.01


def test_a_static_false_blob_beside_the_field_is_rejected_even_when_alone() -> None:
    # the others lose the ball for 0.5 s: robot2's blob still cannot capture the track
    def blob(robot: str, t: float) -> tuple[float, float] | None:
        return (2.5, 1.5) if robot == "robot2" and t > 0.2 else None

    steps = feed(BallTracker(), straight, frames=30, observe=blob,
                 skip=lambda robot, t: robot != "robot2" and 0.6 < t < 1.1)
    assert not any(a for t, robot, a, _ in steps if robot == "robot2" and t > 0.2)
    t, _, _, state = steps[-1]
    assert error(state, straight, t)[0] < 0.01


def test_loss_and_reacquisition() -> None:
    params = TrackerParams(lost_after_ns=500 * MS)
    tracker = BallTracker(params)
    steps = feed(tracker, straight, frames=10)  # 0 .. 0.5 s
    assert steps[-1][3] is not None
    last_ns = round(steps[-1][0] * 1e9)
    assert tracker.state_at(last_ns + 400 * MS) is not None  # coasting
    assert tracker.state_at(last_ns + 600 * MS) is None  # lost
    # the ball comes back 2 s later, elsewhere and slower: a new track from the first
    # estimates, confirmed by a second robot, and accurate again after a few frames

    def back(t: float) -> tuple[tuple[float, float], tuple[float, float]]:
        return (-2.0 + 1.0 * t, 1.0), (1.0, 0.0)

    t0 = 2.5
    rng = np.random.default_rng(1)
    states = []
    for k in range(12):
        for robot, phase in zip(ROBOTS, PHASES_MS, strict=True):
            t = t0 + k * 0.05 + phase / 1e3
            (x, y), _ = back(t)
            t_ns = round(t * 1e9)
            assert tracker.update(Measurement(t_ns, robot, x + rng.normal(0, SIGMA),
                                              y + rng.normal(0, SIGMA), R))
            states.append((t, tracker.state_at(t_ns)))
    assert states[0][1] is not None and not states[0][1].confirmed  # tentative
    assert states[1][1] is not None and states[1][1].confirmed
    for t, state in states[9:]:
        pos, vel = error(state, back, t)
        assert pos < 0.008 and vel < 0.4


def test_friction_slows_the_predicted_ball() -> None:
    beta = 0.8

    def rolling(t: float) -> tuple[tuple[float, float], tuple[float, float]]:
        v = 5.0 * math.exp(-beta * t)
        return (5.0 * (1.0 - math.exp(-beta * t)) / beta, 0.0), (v, 0.0)

    with_friction = BallTracker(TrackerParams(friction_per_s=beta))
    without = BallTracker(TrackerParams(friction_per_s=0.0))
    for tracker in (with_friction, without):
        feed(tracker, rolling, frames=20, noise=0.0)  # the last estimate at 0.984 s
    ahead_ns = 1_884 * MS  # predicting 0.9 s past the last estimate
    (x, _), (vx, _) = rolling(ahead_ns / 1e9)
    good, bad = with_friction.state_at(ahead_ns), without.state_at(ahead_ns)
    assert good is not None and bad is not None
    assert abs(good.x_m - x) < 0.01 and abs(good.vx_m_s - vx) < 0.01
    assert abs(bad.x_m - x) > 0.4  # constant velocity overshoots a slowing ball
    # F(dt) is the exact solution of the friction model
    f = transition(1.0, beta)
    assert f[2, 2] == pytest.approx(math.exp(-beta))
    assert f[0, 2] == pytest.approx((1.0 - math.exp(-beta)) / beta)


def test_a_late_estimate_is_put_in_stamp_order() -> None:
    in_order, shuffled = BallTracker(), BallTracker()
    ms = [Measurement(k * 17 * MS, ROBOTS[k % 3], *straight(k * 0.017)[0], R) for k in range(30)]
    for m in ms:
        in_order.update(m)
    for a, b in zip(ms[::2], ms[1::2], strict=True):  # pairs arrive swapped
        shuffled.update(b)
        shuffled.update(a)
    end = ms[-1].stamp_ns
    assert shuffled.state_at(end) == pytest.approx(in_order.state_at(end)) or (
        _close(shuffled.state_at(end), in_order.state_at(end)))
    tracker = BallTracker(TrackerParams(memory_ns=100 * MS, manoeuvre_ns=50 * MS))
    for m in ms:
        tracker.update(m)
    assert not tracker.update(ms[0])  # older than the tracker's memory: dropped
    assert tracker.late == 1


def _close(a: TrackState | None, b: TrackState | None) -> bool:
    assert a is not None and b is not None
    # the shuffled tracker drops the first estimate (older than its anchor): the offsets'
    # filter still shows it at a few micrometres per second
    return abs(a.x_m - b.x_m) < 1e-9 and abs(a.vx_m_s - b.vx_m_s) < 1e-5


def test_deterministic() -> None:
    a = feed(BallTracker(), bounce, frames=20)
    b = feed(BallTracker(), bounce, frames=20)
    assert a == b


def test_parameters_are_checked() -> None:
    with pytest.raises(FusionError, match="gate"):
        TrackerParams(gate=0.0)
    with pytest.raises(FusionError, match="manoeuvre_ns <= memory_ns"):
        TrackerParams(manoeuvre_ns=2, memory_ns=1)


def test_predict_grows_the_uncertainty_only_forward() -> None:
    x = np.array([0.0, 0.0, 1.0, 0.0])
    p = np.eye(4) * 1e-4
    x1, p1 = predict((x, p), 0.5, q=1.0, friction_per_s=0.0)
    assert x1[0] == pytest.approx(0.5)
    assert np.all(np.linalg.eigvalsh(p1) > 0) and p1[0, 0] > p[0, 0]


# --- the calibrated noise model, and robust vs weighted ----------------------------------------


def est(robot: str, rx: float, ry: float, bx: float, by: float, **kw: float) -> BallEstimate:
    return BallEstimate(robot, rx, ry, math.hypot(bx - rx, by - ry), 0.0, bx, by, **kw)


def test_calibrated_noise_grows_with_range_as_the_calibration_does() -> None:
    mirror = MirrorCalibration(a_m=1.569, b_rad_per_px=0.007088)
    noise = CalibratedNoise(calibrations={"r": mirror}, position_sigma_m=0.0,
                            yaw_sigma_rad=0.0)
    near, far = (noise.covariance(est("r", 0.0, 0.0, d, 0.0)) for d in (1.0, 5.0))
    # along the bearing: d'(r) sigma_px, and d'(r) of a mirror grows steeply with range
    assert far[0, 0] / near[0, 0] > 10.0
    # the range law is the calibration's: sigma_r = d'(r) * 0.5 px
    r = math.atan(5.0 / 1.569) / 0.007088
    slope = 1.569 * 0.007088 / math.cos(0.007088 * r) ** 2
    assert math.sqrt(far[0, 0]) == pytest.approx(slope * 0.5, rel=1e-3)
    # a known r_px gives the same covariance without inverting the calibration
    known = noise.covariance(est("r", 0.0, 0.0, 5.0, 0.0, r_px=r))
    assert known == pytest.approx(far, rel=1e-6)
    # the fit's residual RMS adds to the range sigma
    fitted = CalibratedNoise(calibrations={"r": mirror}, fit_rms_m=0.02)
    assert fitted.covariance(est("r", 0.0, 0.0, 1.0, 0.0))[0, 0] > 0.02**2
    with pytest.raises(FusionError, match="sigmas >= 0"):
        CalibratedNoise(centroid_sigma_px=-1.0)


SCENE = [est("robot1", -3.0, 0.0, 0.500, 0.300), est("robot2", -1.0, 2.0, 0.503, 0.298),
         est("robot3", -2.0, -1.5, 0.498, 0.301)]


def test_robust_differs_from_weighted_with_calibrated_noise() -> None:
    outlier = [*SCENE, est("robot4", 4.0, 0.3, 0.80, 0.30)]  # 0.3 m off along its range
    # CAMBADA's sigma_r(3.5 m) = 0.13 m: the outlier is within 3 sigma, robust = weighted
    cambada = NoiseModel()
    assert RobustFusion(cambada).fuse(outlier) == WeightedFusion(cambada).fuse(outlier)
    # calibrated sigmas of about a centimetre: robust drops it, weighted is pulled away
    noise = CalibratedNoise()
    robust, weighted = RobustFusion(noise).fuse(outlier), WeightedFusion(noise).fuse(outlier)
    assert robust is not None and weighted is not None
    assert robust.robots == ("robot1", "robot2", "robot3")
    assert abs(robust.x_m - 0.5) < 0.005 and abs(weighted.x_m - 0.5) > 0.02
    # the track fusion gates it out the same way
    track = get_fusion("track").fuse(outlier)
    assert track is not None and "robot4" not in track.robots
    assert abs(track.x_m - 0.5) < 0.005


# --- the offline smoother -----------------------------------------------------------------------


def test_the_smoother_beats_the_causal_track_offline() -> None:
    tracker = BallTracker(record=True)
    steps = feed(tracker, bounce, frames=30, seed=3)
    tracker.finish()
    smooth = tracker.smoothed()
    assert len(smooth) == len(steps)  # one node per estimate, the first is the start
    causal, smoothed = [], []
    for t, _, _, state in steps[6:]:
        causal.append(error(state, bounce, t)[0])
        g = smooth.state_at(round(t * 1e9))
        assert g is not None
        (x, y), _ = bounce(t)
        smoothed.append(math.hypot(g[0][0] - x, g[0][1] - y))
        assert np.all(np.linalg.eigvalsh(g[1]) > 0)
    rms = [float(np.sqrt(np.mean(np.square(e)))) for e in (causal, smoothed)]
    assert rms[1] < 0.75 * rms[0]  # the noise and the bounce's first estimate both shrink
    assert smooth.state_at(-1) is None
    with pytest.raises(FusionError, match="record=True"):
        BallTracker().smoothed()


def test_the_smoother_keeps_segments_apart_across_a_loss() -> None:
    tracker = BallTracker(TrackerParams(lost_after_ns=200 * MS), record=True)
    feed(tracker, straight, frames=6)  # 0 .. 0.3 s at (1, 0.5) + (3, -1) t
    far = (-4.0, 2.0)
    for k in range(6):  # 1 s later, a still ball elsewhere: a new segment
        tracker.update(Measurement(1_300 * MS + k * 17 * MS, ROBOTS[k % 3], *far, R))
    tracker.finish()
    smooth = tracker.smoothed()
    early, late = smooth.state_at(200 * MS), smooth.state_at(1_380 * MS)
    assert early is not None and late is not None
    assert abs(early[0][0] - straight(0.2)[0][0]) < 0.01  # not pulled towards the new ball
    assert abs(late[0][0] - far[0]) < 0.01


def _batch_posterior(x0: np.ndarray, p0: np.ndarray, stamps_ns: list[int],
                     measured: dict[int, tuple[np.ndarray, np.ndarray]], beta: float,
                     q: float) -> tuple[np.ndarray, np.ndarray]:
    """The mean and covariance of all states (x_0, ..., x_(n-1)) stacked, given the
    measurements ``measured[k] = (z_k, R_k)``: the joint Gaussian of x_0 ~ N(x0, p0),
    x_k = F_k x_(k-1) + w_k (w_k ~ N(0, Q_k)) and z_k = H x_k + v_k (v_k ~ N(0, R_k)),
    conditioned on every z at once (no filter, no smoother)."""
    n = len(stamps_ns)
    mean = [x0]
    cov = np.zeros((4 * n, 4 * n))
    cov[:4, :4] = p0
    for k in range(1, n):
        dt = (stamps_ns[k] - stamps_ns[k - 1]) / 1e9
        f, now, before = transition(dt, beta), slice(4 * k, 4 * k + 4), slice(4 * k - 4, 4 * k)
        mean.append(f @ mean[-1])
        cov[now, :4 * k] = f @ cov[before, :4 * k]
        cov[:4 * k, now] = cov[now, :4 * k].T
        cov[now, now] = f @ cov[before, before] @ f.T + process_noise(dt, q)
    m = np.concatenate(mean)
    g = np.zeros((2 * len(measured), 4 * n))
    r_all = np.zeros((2 * len(measured), 2 * len(measured)))
    for i, (k, (_, r)) in enumerate(sorted(measured.items())):
        g[2 * i:2 * i + 2, 4 * k:4 * k + 2] = np.eye(2)
        r_all[2 * i:2 * i + 2, 2 * i:2 * i + 2] = r
    z = np.concatenate([z for _, (z, _) in sorted(measured.items())])
    gain = cov @ g.T @ np.linalg.inv(g @ cov @ g.T + r_all)
    return m + gain @ (z - g @ m), cov - gain @ g @ cov


def test_the_smoother_is_the_batch_posterior_of_the_whole_record() -> None:
    """Guards the smoother's gain ``C = P_f F^T P_p^-1`` (the transpose matters: F is not
    symmetric): on a record of four nodes (correlated prior, rolling friction, unequal
    steps and noises, one estimate rejected), the RTS smoother's (x, P) at every node equal
    the textbook posterior of that state given every accepted measurement, from
    conditioning the joint Gaussian of all states at once (:func:`_batch_posterior`)."""
    beta, q = 0.5, 2.0
    a = np.random.default_rng(7).normal(size=(4, 4))
    x0, p0 = np.array([0.3, -0.2, 2.0, 1.0]), a @ a.T + 0.1 * np.eye(4)
    stamps_ns = [0, 40 * MS, 90 * MS, 170 * MS]
    measured = {0: (np.array([0.35, -0.15]), np.array([[0.02, 0.005], [0.005, 0.01]])),
                1: (np.array([0.4, 0.1]), np.diag([0.01, 0.03])),
                3: (np.array([0.6, 0.3]), np.array([[0.015, -0.004], [-0.004, 0.02]]))}
    # the filter's record; the estimate at 90 ms was rejected: its posterior is its prior
    nodes, state = [], (x0, p0)
    for k, t_ns in enumerate(stamps_ns):
        prior = state if k == 0 else predict(state, (t_ns - stamps_ns[k - 1]) / 1e9, q=q,
                                             friction_per_s=beta)
        state = update(prior, *measured[k]) if k in measured else prior
        nodes.append(FilterNode(t_ns, prior, state, 0))
    post_mean, post_cov = _batch_posterior(x0, p0, stamps_ns, measured, beta, q)
    smoothed = rts_smooth(nodes, beta)
    assert len(smoothed) == len(nodes)
    for k, (x_s, p_s) in enumerate(smoothed):
        now = slice(4 * k, 4 * k + 4)
        assert x_s == pytest.approx(post_mean[now], abs=1e-9), k
        assert p_s == pytest.approx(post_cov[now, now], abs=1e-9), k
    # the last node is the filter's own posterior; the first moved with what came later
    assert np.array_equal(smoothed[-1][0], nodes[-1].posterior[0])
    assert not np.allclose(smoothed[0][0], nodes[0].posterior[0], atol=1e-3)
