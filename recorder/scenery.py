"""What stands around the ball and how the hall is lit: people, robot covers, light pools.

The trouble a real venue brings, in the simulator (each off unless asked, each drawn from
its own seeded stream, so asking for one leaves every other draw of the scenario as it was):

- **people** in shirts of the ball's colour beside the field: figures of 1.6-1.9 m standing,
  or crouching as team members do at the field's edge, on the hall floor 0.3-1.5 m beyond
  the carpet's edge (outside the lines and the border strip), facing the field. A lens
  0.85 m up sees a standing figure's shirt only near or above its horizon, a crouching one's
  below it; the ideal camera's virtual view from 12 m sees both from above.
- **covers**: some robots carry a skirt of the ball's colour around their base (0.05-0.25 m
  above the ground), as robots with orange or yellow covers do: a ball-coloured blob near
  the ground beside the robot's dark body.
- **light pools**: the hall's lamps light the field unevenly. The light at a point is a dim
  base (0.55) plus a few Gaussian pools (peak 0.35-0.7, 1.5-3.5 m wide) of their own colour
  temperature (3000-6500 K), clipped to 1.35; every channel of what stands there is scaled
  by it. The carpet's texture, the goals, the people and the distractor boxes are lit once
  where they stand; the ball and the covers are lit again before every image at their
  current place. Robot bodies keep their colour (pybullet cannot re-tint one shape of a
  many-shape body; they are nearly black anyway).

Shadows are left out: pybullet's EGL renderer draws none in this setup and TinyRenderer's
are wrong (a dark half-plane across the field) and 1.5-1.7x slower per omni image.

Pure data and arithmetic: no pybullet here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "LIGHT_BASE",
    "LIGHT_MAX",
    "LightPool",
    "Person",
    "Scenery",
    "colour_temperature_rgb",
    "light_at",
    "make_scenery",
]

LIGHT_BASE = 0.55
"""The light between the pools (1 is the even light of every earlier log)."""
LIGHT_MAX = 1.35
_POOL_PEAK = (0.35, 0.7)
_POOL_SIGMA_M = (1.5, 3.5)
_POOL_KELVIN = (3000.0, 6500.0)
_PERSON_HEIGHT_M = (1.6, 1.9)
_PERSON_OFFSET_M = (0.3, 1.5)
"""Beyond the carpet's edge (the border strip's outer side)."""
CROUCH_FRACTION = 0.5


@dataclass(frozen=True)
class LightPool:
    """A lamp's pool of light: centre (x, y) [m], width (Gaussian sigma) [m], peak added to
    the base light, and its colour as RGB multipliers (luminance 1)."""

    x_m: float
    y_m: float
    sigma_m: float
    peak: float
    kelvin: float
    rgb: tuple[float, float, float]


@dataclass(frozen=True)
class Person:
    """A figure beside the field: where it stands, which way it faces, its height and
    whether it crouches."""

    x_m: float
    y_m: float
    yaw_rad: float
    height_m: float
    crouching: bool


@dataclass(frozen=True)
class Scenery:
    """The people, the robots that wear a cover, and the light pools of a scene."""

    people: tuple[Person, ...] = ()
    covers: tuple[str, ...] = ()
    """Names of the robots with a ball-coloured cover."""
    light_pools: tuple[LightPool, ...] = ()

    @property
    def empty(self) -> bool:
        return not (self.people or self.covers or self.light_pools)


def colour_temperature_rgb(kelvin: float) -> tuple[float, float, float]:
    """RGB multipliers of black-body light at ``kelvin`` relative to 6500 K, scaled to
    luminance 1 (Rec. 601 weights). Tanner Helland's fit of the Planckian locus in sRGB."""
    def rgb(k: float) -> tuple[float, float, float]:
        t = k / 100.0
        r = 255.0 if t <= 66 else 329.698727446 * (t - 60) ** -0.1332047592
        g = (99.4708025861 * math.log(t) - 161.1195681661 if t <= 66
             else 288.1221695283 * (t - 60) ** -0.0755148492)
        b = 255.0 if t >= 66 else (0.0 if t <= 19 else
                                   138.5177312231 * math.log(t - 10) - 305.0447927307)
        return (min(r, 255.0), min(g, 255.0), min(b, 255.0))
    c, w = rgb(kelvin), rgb(6500.0)
    rel = [c[i] / w[i] for i in range(3)]
    lum = 0.299 * rel[0] + 0.587 * rel[1] + 0.114 * rel[2]
    return (round(rel[0] / lum, 4), round(rel[1] / lum, 4), round(rel[2] / lum, 4))


def light_at(pools: tuple[LightPool, ...], x_m: np.ndarray | float, y_m: np.ndarray | float
             ) -> np.ndarray:
    """The light's RGB multipliers at (x, y), shape (..., 3); all ones without pools."""
    x, y = np.asarray(x_m, dtype=np.float64), np.asarray(y_m, dtype=np.float64)
    if not pools:
        return np.ones((*np.broadcast_shapes(x.shape, y.shape), 3))
    out = np.full((*np.broadcast_shapes(x.shape, y.shape), 3), LIGHT_BASE)
    for pool in pools:
        w = pool.peak * np.exp(-((x - pool.x_m) ** 2 + (y - pool.y_m) ** 2)
                               / (2.0 * pool.sigma_m ** 2))
        out += w[..., None] * np.array(pool.rgb)
    return np.asarray(np.clip(out, 0.0, LIGHT_MAX))


def _pools(rng: np.random.Generator, count: int, hl: float, hw: float
           ) -> tuple[LightPool, ...]:
    out = []
    for _ in range(count):
        kelvin = round(float(rng.uniform(*_POOL_KELVIN)), 1)
        out.append(LightPool(round(float(rng.uniform(-hl - 1.0, hl + 1.0)), 3),
                             round(float(rng.uniform(-hw - 1.0, hw + 1.0)), 3),
                             round(float(rng.uniform(*_POOL_SIGMA_M)), 3),
                             round(float(rng.uniform(*_POOL_PEAK)), 3), kelvin,
                             colour_temperature_rgb(kelvin)))
    return tuple(out)


def _people(rng: np.random.Generator, count: int, hl: float, hw: float, border: float
            ) -> tuple[Person, ...]:
    """``count`` figures beyond the carpet's edge: three in four along a touch line, the
    rest behind a goal line (clear of the goal), facing the field's centre."""
    out = []
    for _ in range(count):
        off = border + float(rng.uniform(*_PERSON_OFFSET_M))
        if rng.uniform() < 0.75:
            x = float(rng.uniform(-hl, hl))
            y = (hw + off) * float(rng.choice([-1.0, 1.0]))
        else:
            x = (hl + off) * float(rng.choice([-1.0, 1.0]))
            y = float(rng.uniform(1.5, hw)) * float(rng.choice([-1.0, 1.0]))
        yaw = math.atan2(-y, -x) + float(rng.uniform(-0.5, 0.5))
        out.append(Person(round(x, 3), round(y, 3), round(yaw, 4),
                          round(float(rng.uniform(*_PERSON_HEIGHT_M)), 3),
                          bool(rng.uniform() < CROUCH_FRACTION)))
    return tuple(out)


def make_scenery(seed: int, *, people: int, covers: int, light_pools: int,
                 robots: tuple[str, ...], hl: float, hw: float, border: float) -> Scenery:
    """The scenery of a scene, from ``seed`` (its own streams: [seed, 20..22]). ``covers``
    of ``robots`` (every robot in the scene, in order) wear a cover, picked by the seed."""
    chosen: tuple[str, ...] = ()
    if covers:
        pick = np.random.default_rng([seed, 21]).choice(len(robots), size=covers, replace=False)
        chosen = tuple(robots[int(i)] for i in sorted(pick))
    return Scenery(
        people=_people(np.random.default_rng([seed, 20]), people, hl, hw, border),
        covers=chosen,
        light_pools=_pools(np.random.default_rng([seed, 22]), light_pools, hl, hw),
    )
