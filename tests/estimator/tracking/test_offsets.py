"""The track's velocity from the filter that holds each robot's offset
(:mod:`estimator.tracking.offsets`): robots that disagree by centimetres, their estimates
alternating, are not motion; a kick is followed; the offsets carry on to the next track."""

from __future__ import annotations

import math

import numpy as np
import pytest

from estimator.tracking import BallTracker, Measurement, TrackerParams
from estimator.tracking.model import predict, update
from estimator.tracking.offsets import OffsetFilter

MS = 1_000_000
ROBOTS = ("robot1", "robot2", "robot3")
PHASES_MS = (0, 17, 34)  # free-running 20 Hz cameras
OFFSETS = {"robot1": (0.04, -0.02), "robot2": (-0.03, 0.03), "robot3": (0.0, -0.03)}
SIGMA = 0.03  # each estimate's stated sigma [m]: the robots' offsets lie within it
R = np.eye(2) * SIGMA**2
R_ROWS = ((SIGMA**2, 0.0), (0.0, SIGMA**2))


def _seen(robot: str, t: float, rng: np.random.Generator, bounce_s: float | None) -> np.ndarray:
    """Where ``robot`` places the ball at ``t``: the truth plus its offset and 5 mm noise."""
    x, y = _truth(t, bounce_s)[0]
    ox, oy = OFFSETS[robot]
    return np.array([x + ox + rng.normal(0, 0.005), y + oy + rng.normal(0, 0.005)])


def _truth(t: float, bounce_s: float | None) -> tuple[tuple[float, float], tuple[float, float]]:
    if bounce_s is None or t < bounce_s:
        return (1.0 + 3.0 * t, 0.5 - 1.0 * t), (3.0, -1.0)
    x0, y0 = 1.0 + 3.0 * bounce_s, 0.5 - 1.0 * bounce_s
    dt = t - bounce_s
    return (x0 - 2.0 * dt, y0 - 2.0 * dt), (-2.0, -2.0)


def _velocity_errors(seed: int, *, bounce_s: float | None = None, frames: int = 60
                     ) -> tuple[list[tuple[float, float]], list[float]]:
    """(t, the tracker's velocity error) per estimate, and a plain Kalman filter's (the
    tracker's motion model without the offsets) on the same estimates."""
    rng = np.random.default_rng(seed)
    prm = TrackerParams(friction_per_s=0.0)
    tracker = BallTracker(prm)
    plain: tuple[np.ndarray, np.ndarray] | None = None
    t_prev = 0.0
    ours, theirs = [], []
    for k in range(frames):
        for robot, phase in zip(ROBOTS, PHASES_MS, strict=True):
            ns = (k * 50 + phase) * MS
            t = ns / 1e9
            z = _seen(robot, t, rng, bounce_s)
            tracker.update(Measurement(ns, robot, float(z[0]), float(z[1]), R_ROWS))
            state = tracker.state_at(ns)
            assert state is not None
            v = _truth(t, bounce_s)[1]
            ours.append((t, math.hypot(state.vx_m_s - v[0], state.vy_m_s - v[1])))
            if plain is None:
                p0 = np.zeros((4, 4))
                p0[:2, :2], p0[2, 2], p0[3, 3] = R, 36.0, 36.0
                plain = (np.array([z[0], z[1], 0.0, 0.0]), p0)
            else:
                plain = update(predict(plain, t - t_prev, q=prm.accel_noise_m2_s3,
                                       friction_per_s=0.0), z, R)
            t_prev = t
            theirs.append(math.hypot(plain[0][2] - v[0], plain[0][3] - v[1]))
    return ours, theirs


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_robots_that_disagree_by_centimetres_are_not_motion(seed: int) -> None:
    """Three robots 3-5 cm apart, each estimate in turn: the plain filter reads the gaps as
    motion (about 0.1 m/s off), the track's velocity stays within a few cm/s."""
    ours, theirs = _velocity_errors(seed)
    settled = [e for t, e in ours if t >= 1.0]
    assert float(np.median(theirs[60:])) > 0.08  # what the offsets are there for
    assert float(np.median(settled)) < 0.04 and max(settled) < 0.12


def test_a_kick_is_followed() -> None:
    """A bounce at 1.5 s (3, -1) -> (-2, -2) m/s: the tracker finds the kick, the offsets'
    filter takes it too and is within 0.1 m/s half a second later."""
    ours, _ = _velocity_errors(0, bounce_s=1.5, frames=50)
    after = [e for t, e in ours if 2.0 <= t]
    assert float(np.median(after)) < 0.05 and max(after) < 0.15


def test_the_offsets_carry_on_to_the_next_track_and_fade() -> None:
    """A new track starts from the offsets made final before it, faded over the gap by
    exp(-gap / tau) towards the prior: the ball where the first robot sees it less its
    offset."""
    f = OffsetFilter(TrackerParams())
    initial = (np.array([1.0, 2.0, 0.0, 0.0]), np.diag([1e-4, 1e-4, 36.0, 36.0]))
    g = f.start(initial, "a", 0)
    g = f.update(f.predict(g, 0.01), "b", np.array([1.05, 2.0]), np.eye(2) * 1e-4)
    x = np.array(g[0], copy=True)
    x[4:] = [0.0, 0.0, 0.05, 0.0]  # robot b sits 5 cm off in x
    p = np.array(g[1], copy=True)
    p[4:, 4:] = np.eye(4) * 1e-6
    f.settle((x, p), 0)
    gap_ns = int(f.tau_s * 1e9)  # one time constant later
    x2, p2 = f.start(initial, "b", gap_ns)
    assert f.robots == {"a": 0, "b": 1}
    assert x2[6] == pytest.approx(0.05 / math.e)
    assert x2[0] == pytest.approx(1.0 - 0.05 / math.e)  # the ball: b's estimate less b's offset
    a2 = math.exp(-2.0)
    assert p2[6, 6] == pytest.approx(a2 * 1e-6 + f.sigma_m**2 * (1 - a2))
    # a robot first seen later gets the prior
    x3, p3 = f.start(initial, "c", gap_ns)
    assert x3[8:10].tolist() == [0.0, 0.0] and p3[8, 8] == pytest.approx(f.sigma_m**2)


def test_the_tracker_tells_each_robots_offset_from_the_others() -> None:
    """What the velocity's filter came to hold: how far each robot's estimates sit from
    the others' (what all share no estimate can tell from the ball)."""
    rng = np.random.default_rng(3)
    tracker = BallTracker(TrackerParams(friction_per_s=0.0))
    assert tracker.offsets() == {}
    for k in range(80):
        for robot, phase in zip(ROBOTS, PHASES_MS, strict=True):
            ns = (k * 50 + phase) * MS
            z = _seen(robot, ns / 1e9, rng, None)
            tracker.update(Measurement(ns, robot, float(z[0]), float(z[1]), R_ROWS))
    held = tracker.offsets()
    assert list(held) == list(ROBOTS)  # in the order first seen
    first = ROBOTS[0]
    for robot in ROBOTS[1:]:  # 4-8 cm apart, told within a centimetre
        told = np.subtract(held[robot], held[first])
        assert np.allclose(told, np.subtract(OFFSETS[robot], OFFSETS[first]), atol=0.01)
