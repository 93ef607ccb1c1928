"""What makes a recording less than ideal: a drifting localisation bias and camera effects.

- :class:`PoseDrift`: each robot's localisation error as a slowly drifting bias, an
  Ornstein-Uhlenbeck process per axis (stationary standard deviation ``pose_bias_m`` /
  ``yaw_bias_deg``, time constant ``tau_s``), sampled at every pose tick. Consecutive
  messages share most of their error, as a real self-localisation's do; white noise on top
  stays the ``pose_noise_m`` / ``yaw_noise_deg`` options.
- :class:`ImageEffects`: exposure blur (the average of the sub-frames rendered at every
  physics step of the exposure), a gain that wanders per robot (an OU process in log gain
  with stationary standard deviation ``gain_jitter``, time constant 1 s, updated per image)
  and Gaussian pixel noise (standard deviation ``image_noise`` grey levels).

Each uses its own seeded random streams, so switching one on leaves every other draw (and
so the bytes of a recording without it) unchanged.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["GAIN_TAU_S", "ImageEffects", "PoseDrift", "ou_step"]

GAIN_TAU_S = 1.0
"""Time constant of the gain's wandering [s]."""


def ou_step(x: np.ndarray, sigma: float, tau_s: float, dt_s: float,
            rng: np.random.Generator) -> np.ndarray:
    """One exact step of an Ornstein-Uhlenbeck process with stationary std ``sigma``:
    x' = a x + sigma sqrt(1 - a^2) n, a = exp(-dt / tau), n ~ N(0, 1)."""
    a = math.exp(-dt_s / tau_s)
    return a * x + sigma * math.sqrt(1.0 - a * a) * rng.normal(0.0, 1.0, x.shape)


class PoseDrift:
    """Per robot a drifting (x, y, yaw) bias; inactive (no draws) when both sigmas are 0."""

    def __init__(self, robots: Sequence[str], seed: int, *, pose_bias_m: float,
                 yaw_bias_deg: float, tau_s: float, dt_s: float) -> None:
        self.robots = list(robots)
        self.sigma = np.array([pose_bias_m, pose_bias_m, math.radians(yaw_bias_deg)])
        self.tau_s = tau_s
        self.dt_s = dt_s
        self.active = bool(pose_bias_m or yaw_bias_deg)
        self._rng = np.random.default_rng([seed, 2])
        # start from the stationary distribution, so the error is as large at t = 0 as later
        self._state = (self._rng.normal(0.0, 1.0, (len(self.robots), 3)) * self.sigma
                       if self.active else np.zeros((len(self.robots), 3)))
        self._started = False

    def step(self) -> dict[str, tuple[float, float, float]]:
        """The bias at the next pose tick, robot -> (dx_m, dy_m, dyaw_rad); {} if inactive."""
        if not self.active:
            return {}
        if self._started:
            a = math.exp(-self.dt_s / self.tau_s)
            noise = self._rng.normal(0.0, 1.0, self._state.shape)
            self._state = a * self._state + math.sqrt(1.0 - a * a) * noise * self.sigma
        self._started = True
        return {r: (float(s[0]), float(s[1]), float(s[2]))
                for r, s in zip(self.robots, self._state, strict=True)}


class ImageEffects:
    """Exposure blur, gain and noise applied to each robot's images; a no-op when all are 0."""

    def __init__(self, robots: Sequence[str], seed: int, *, image_noise: float,
                 gain_jitter: float, exposure_steps: int, frame_dt_s: float) -> None:
        self.image_noise = image_noise
        self.gain_jitter = gain_jitter
        self.exposure_steps = exposure_steps
        self.frame_dt_s = frame_dt_s
        self._rng = {r: np.random.default_rng([seed, 3, i]) for i, r in enumerate(robots)}
        self._log_gain = {r: np.zeros(1) for r in robots}
        self._sub: dict[str, list[np.ndarray]] = {r: [] for r in robots}

    def add_subframe(self, robot: str, img: np.ndarray) -> None:
        """An earlier moment of the exposure that ends at the robot's next image."""
        self._sub[robot].append(img)

    def gain(self, robot: str) -> float:
        """The robot's gain for its next image (drawn once per image)."""
        rng = self._rng[robot]
        self._log_gain[robot] = ou_step(self._log_gain[robot], self.gain_jitter, GAIN_TAU_S,
                                        self.frame_dt_s, rng)
        return float(math.exp(float(self._log_gain[robot][0])))

    def finish(self, robot: str, img: np.ndarray) -> np.ndarray:
        """The image as the camera delivers it: sub-frames averaged, gain, noise, uint8."""
        subs = self._sub[robot]
        if not (subs or self.gain_jitter or self.image_noise):
            return img
        acc = img.astype(np.float32)
        if subs:
            for s in subs:
                acc += s
            acc /= len(subs) + 1
            subs.clear()
        if self.gain_jitter:
            acc *= self.gain(robot)
        if self.image_noise:
            acc += self._rng[robot].normal(0.0, self.image_noise, acc.shape).astype(np.float32)
        # keep the black outside the image circle black (a real sensor's dark area is dark)
        out: np.ndarray = np.clip(np.rint(acc), 0, 255).astype(np.uint8)
        out[img.max(axis=2) == 0] = 0
        return out
