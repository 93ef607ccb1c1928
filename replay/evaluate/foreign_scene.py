"""The motion of a foreign log (:mod:`replay.evaluate.foreign`): robots, the ball, the poses.

Everything is drawn from one seeded :class:`numpy.random.Generator`, in a fixed order, so a
seed gives the same scene on every machine. Times are integer nanoseconds from the log's
start (the writer adds the Unix epoch); positions in metres in the field frame (origin at
the centre, x to the opponent goal, y left), yaw in radians.

- **Robots** drive slowly along smooth random paths: each axis a centre plus a sum of
  three sines of random amplitude, frequency and phase (speeds below about 1 m/s), kept
  1 m inside the field's lines; the heading likewise.
- **The ball** is kicked every 1.5-3.5 s to 1-5 m/s, passed towards a random point of the
  field's middle (robots play there; a ball left in a corner no camera reaches is no
  test of the pipeline), rolls with a
  constant deceleration, bounces off the field's outer lines (it stays inside them, losing
  a fifth of its speed) and, after some kicks, hops: a ballistic flight of up to
  :data:`MAX_HOP_M`, bouncing with a restitution of 0.5 until it rolls again. It is
  integrated at 1 kHz and read off the nearest step.
- **Poses** are what a team's localiser reports: exact, or with a drifting bias per axis
  (x, y, yaw) that is a first-order Gauss-Markov process of a given stationary sigma and
  time constant, plus a small white noise (:class:`PoseError`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from dsp.field import FieldSpec

__all__ = [
    "BALL_RADIUS_M",
    "GRAVITY_M_S2",
    "MAX_HOP_M",
    "PoseError",
    "Scene",
    "make_scene",
    "pose_errors",
]

BALL_RADIUS_M = 0.11
GRAVITY_M_S2 = 9.81
MAX_HOP_M = 0.5
"""The highest a hop lifts the ball's bottom [m]."""
MAX_KICK_M_S = 5.0
ROLL_DECELERATION_M_S2 = 0.6
HOP_CHANCE = 0.25
"""The share of kicks that lift the ball."""
RESTITUTION = 0.5
WALL_KEEP = 0.8
"""The share of its speed the ball keeps when it bounces off the border."""
STEP_NS = 1_000_000
"""The ball's integration step: 1 ms."""
ROBOT_MARGIN_M = 1.0


@dataclass(frozen=True)
class PoseError:
    """How a log's poses differ from the truth: a Gauss-Markov bias per axis of stationary
    sigma ``sigma_m`` (x and y) and ``sigma_deg`` (yaw) and time constant ``tau_s``, plus a
    white noise of ``white_m`` / ``white_deg``. All zero: exact poses."""

    sigma_m: float = 0.0
    sigma_deg: float = 0.0
    tau_s: float = 3.0
    white_m: float = 0.0
    white_deg: float = 0.0

    @property
    def exact(self) -> bool:
        return not (self.sigma_m or self.sigma_deg or self.white_m or self.white_deg)

    @staticmethod
    def drift(sigma_m: float, sigma_deg: float, tau_s: float = 3.0) -> PoseError:
        """A drifting localiser: the white noise a fifth of the bias's sigma."""
        return PoseError(sigma_m, sigma_deg, tau_s, sigma_m / 5.0, sigma_deg / 5.0)

    def stated_sigma(self) -> tuple[float, float]:
        """The honest total sigma (m, rad) of a pose's error: bias and noise together."""
        return (math.hypot(self.sigma_m, self.white_m),
                math.radians(math.hypot(self.sigma_deg, self.white_deg)))


@dataclass(frozen=True)
class _Path:
    """One smooth random path: centre + sum of a_k sin(w_k t + p_k), per coordinate."""

    centre: float
    amplitude: npt.NDArray[np.float64]
    omega: npt.NDArray[np.float64]
    phase: npt.NDArray[np.float64]

    def at(self, t_s: npt.ArrayLike) -> npt.NDArray[np.float64]:
        t = np.asarray(t_s, np.float64)[..., None]
        return np.asarray(self.centre + np.sum(
            self.amplitude * np.sin(self.omega * t + self.phase), axis=-1), np.float64)


def _path(rng: np.random.Generator, centre: float, reach: float, omega_max: float) -> _Path:
    amplitude = rng.uniform(0.2, 1.0, 3)
    amplitude *= reach / amplitude.sum()  # never beyond centre +- reach
    return _Path(centre, amplitude, rng.uniform(0.05, omega_max, 3),
                 rng.uniform(0.0, math.tau, 3))


@dataclass(frozen=True)
class _Robot:
    x: _Path
    y: _Path
    yaw: _Path


@dataclass(frozen=True)
class Scene:
    """A foreign log's motion: the robots' paths and the ball's 1 kHz trajectory."""

    field: FieldSpec
    robots: tuple[str, ...]
    duration_ns: int
    _paths: tuple[_Robot, ...]
    ball: npt.NDArray[np.float64]
    """(steps, 3): the ball's centre (x, y, z) at every :data:`STEP_NS`."""

    def robot_pose(self, index: int, t_ns: int | npt.NDArray[np.int64]
                   ) -> tuple[npt.NDArray[np.float64], ...]:
        """The robot's true (x, y, yaw) at ``t_ns`` (arrays of its shape)."""
        p, t = self._paths[index], np.asarray(t_ns, np.float64) * 1e-9
        return p.x.at(t), p.y.at(t), np.remainder(p.yaw.at(t) + math.pi, math.tau) - math.pi

    def ball_at(self, t_ns: int) -> tuple[float, float, float]:
        """The ball's centre (x, y, z) at ``t_ns``."""
        x, y, z = self.ball[self._step(t_ns)]
        return float(x), float(y), float(z)

    def ball_velocity_at(self, t_ns: int) -> tuple[float, float, float]:
        """The ball's velocity (vx, vy, vz) [m/s] at ``t_ns``: the central difference over
        two steps of the track (one-sided at its ends)."""
        i = self._step(t_ns)
        a, b = max(i - 1, 0), min(i + 1, len(self.ball) - 1)
        v = (self.ball[b] - self.ball[a]) / (max(b - a, 1) * STEP_NS * 1e-9)
        return float(v[0]), float(v[1]), float(v[2])

    def _step(self, t_ns: int) -> int:
        return min(max(round(t_ns / STEP_NS), 0), len(self.ball) - 1)


def make_scene(rng: np.random.Generator, field: FieldSpec, robots: int,
               duration_ns: int, *, ball: bool = True) -> Scene:
    """``robots`` robots named r1, r2, ... and a ball, for ``duration_ns``; without ``ball``
    the ball's track is its first step alone (the robots are the same: drawn first)."""
    hl, hw = field.half_length_m - ROBOT_MARGIN_M, field.half_width_m - ROBOT_MARGIN_M
    paths = []
    lanes = np.linspace(-0.6 * hl, 0.6 * hl, robots + 1)
    for i in range(robots):  # each robot about its own lane of the field, so they spread out
        cx, cy = rng.uniform(lanes[i], lanes[i + 1]), rng.uniform(-0.6 * hw, 0.6 * hw)
        paths.append(_Robot(_path(rng, cx, hl - abs(cx), 0.35), _path(rng, cy, hw - abs(cy), 0.35),
                            _path(rng, rng.uniform(-math.pi, math.pi), 1.2, 0.5)))
    track = _ball_track(rng, field, duration_ns // STEP_NS + 1 if ball else 1)
    return Scene(field, tuple(f"r{i + 1}" for i in range(robots)), duration_ns, tuple(paths),
                 track)


def _kick(rng: np.random.Generator, pos: npt.NDArray[np.float64], lim: tuple[float, float]
          ) -> tuple[float, float, float, float]:
    """(vx, vy, vz, seconds to the next kick) of a kick: a pass towards a random point of
    the field's middle (where the robots play), sometimes lifted."""
    speed = rng.uniform(1.0, MAX_KICK_M_S)
    tx, ty = rng.uniform(-0.6 * lim[0], 0.6 * lim[0]), rng.uniform(-0.6 * lim[1], 0.6 * lim[1])
    heading = math.atan2(ty - pos[1], tx - pos[0]) + rng.normal(0.0, 0.3)
    hop = rng.uniform(0.05, MAX_HOP_M) if rng.random() < HOP_CHANCE else 0.0
    return (speed * math.cos(heading), speed * math.sin(heading),
            math.sqrt(2.0 * GRAVITY_M_S2 * hop), rng.uniform(1.5, 3.5))


def _ball_track(rng: np.random.Generator, field: FieldSpec, steps: int
                ) -> npt.NDArray[np.float64]:
    """The ball's centre at every 1 ms step: kicks, rolling, hops, bounces off the lines."""
    dt = STEP_NS * 1e-9
    lim = (field.half_length_m - BALL_RADIUS_M, field.half_width_m - BALL_RADIUS_M)
    pos = np.array([rng.uniform(-0.5 * lim[0], 0.5 * lim[0]),
                    rng.uniform(-0.5 * lim[1], 0.5 * lim[1]), BALL_RADIUS_M])
    vel = np.zeros(3)
    next_kick = rng.uniform(0.0, 1.0)
    out = np.empty((steps, 3))
    for i in range(steps):
        out[i] = pos
        if i * dt >= next_kick:
            vx, vy, vz, wait = _kick(rng, pos, lim)
            vel[:] = (vx, vy, vz)
            next_kick = i * dt + wait
        _advance(pos, vel, dt, lim)
    return out


def _advance(pos: npt.NDArray[np.float64], vel: npt.NDArray[np.float64], dt: float,
             lim: tuple[float, float]) -> None:
    """One step of the ball, in place: flight or rolling, then the border."""
    if pos[2] > BALL_RADIUS_M or vel[2] > 0.0:  # in the air
        vel[2] -= GRAVITY_M_S2 * dt
        pos += vel * dt
        if pos[2] <= BALL_RADIUS_M:
            pos[2] = BALL_RADIUS_M
            vel[2] = -RESTITUTION * vel[2] if -vel[2] > 0.5 else 0.0
    else:
        speed = math.hypot(vel[0], vel[1])
        if speed > 0.0:
            slower = max(speed - ROLL_DECELERATION_M_S2 * dt, 0.0) / speed
            vel[:2] *= slower
        pos[:2] += vel[:2] * dt
    for axis in (0, 1):
        if abs(pos[axis]) > lim[axis]:
            pos[axis] = math.copysign(2.0 * lim[axis] - abs(pos[axis]), pos[axis])
            vel[axis] *= -1.0
            vel[:2] *= WALL_KEEP


def pose_errors(rng: np.random.Generator, error: PoseError, t_ns: npt.NDArray[np.int64]
                ) -> npt.NDArray[np.float64]:
    """(len(t_ns), 3) errors (x [m], y [m], yaw [rad]) of one robot's poses at the increasing
    stamps ``t_ns``: b_k = a b_(k-1) + sqrt(1 - a^2) sigma w_k, a = exp(-dt / tau), b_0 drawn
    from the stationary law, plus white noise. Exact: zeros (and no draw)."""
    n = len(t_ns)
    if error.exact:
        return np.zeros((n, 3))
    sigma = np.array([error.sigma_m, error.sigma_m, math.radians(error.sigma_deg)])
    white = np.array([error.white_m, error.white_m, math.radians(error.white_deg)])
    w = rng.standard_normal((n, 3))
    noise = rng.standard_normal((n, 3)) * white
    dt = np.diff(np.asarray(t_ns, np.float64), prepend=float(t_ns[0])) * 1e-9
    a = np.exp(-dt / error.tau_s)
    bias = np.empty((n, 3))
    bias[0] = sigma * w[0]
    for k in range(1, n):
        bias[k] = a[k] * bias[k - 1] + math.sqrt(1.0 - a[k] ** 2) * sigma * w[k]
    return np.asarray(bias + noise, np.float64)
