"""The ``match`` scenario's parts: robots driving loops, the kicks and passes, distractors.

A match is three (or ``--robot-count``) of our robots driving smooth closed paths while the
ball is kicked and passed between them at 2-8 m/s. The ball is a pybullet body: between
kicks it rolls, slows by rolling friction and damping, and bounces off robots, goals,
distractors and the walls at the carpet's edge. A kick is data (when, how fast, towards
what); its direction is taken from where the ball is when the kick happens, so the same
seed always gives the same match. Optional distractors are boxes of the ball's colour in
the border strip beside the field, each turned its own way: a colour threshold may take one
for the ball when the ball itself is out of sight (a ball in sight looks rounder and wins).

Lobs: with ``lob_fraction`` F each kick is, with probability F (its own seeded stream, so
F = 0 leaves every match as it was), a :class:`LobKick`: the ball leaves the ground at
20-50 deg and 6-10 m/s, drawn so that its flight (without drag) peaks 1.1-3.0 m above the
ground (the ball's centre). The ``lobs`` scenario kicks only lobs, 2.4-3.6 s apart, so each
lands, bounces and rolls before the next (:mod:`recorder.flight` flies them).

Pure data and arithmetic: no pybullet here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dsp.contract import robot_name

__all__ = [
    "KICK_SPEED_MPS",
    "LOB_APEX_M",
    "LOB_ELEVATION_DEG",
    "LOB_SPEED_MPS",
    "MATCH_POSE_RATE_HZ",
    "Distractor",
    "Kick",
    "LobKick",
    "MatchPlay",
    "PathTrack",
    "draw_lob",
    "match_parts",
]

KICK_SPEED_MPS = (2.0, 8.0)
"""Speed range of kicks and passes."""
MATCH_POSE_RATE_HZ = 240.0
"""Poses, /tf and ground truth of a match at the physics rate: every image stamp (a physics
step) has its exact truth, even in the step the ball bounces."""
_KICK_GAP_S = (1.2, 2.6)
_LOB_GAP_S = (2.4, 3.6)
"""Between the kicks of the ``lobs`` scenario: a lob's flight and bounces take 1.5-2.5 s."""
LOB_ELEVATION_DEG = (20.0, 50.0)
LOB_SPEED_MPS = (6.0, 10.0)
LOB_APEX_M = (1.1, 3.0)
"""The drawn flight's peak height of the ball's centre without drag (air drag takes 3-6 %
off it: :mod:`recorder.flight`), so the flown peak is 1.0-3.0 m."""
_GRAVITY_MPS2 = 9.81
_PLAY_SPAN_S = 60.0
"""Kicks are drawn for this long; a longer recording sees the ball roll out."""
_DISTRACTOR_SIZE_M = (0.18, 0.3)


@dataclass(frozen=True)
class PathTrack:
    """A robot driving a smooth closed loop (a Lissajous figure about a centre) while its
    heading swings about ``yaw_rad``:

    x(t) = cx + ax sin(wx t + px),  y(t) = cy + ay sin(wy t + py),
    yaw(t) = yaw0 + yaw_amp sin(w_yaw t).
    """

    name: str
    centre_x_m: float
    centre_y_m: float
    amp_x_m: float
    amp_y_m: float
    omega_x_radps: float
    omega_y_radps: float
    phase_x_rad: float
    phase_y_rad: float
    yaw_rad: float
    yaw_amp_rad: float = 0.0
    yaw_omega_radps: float = 0.0
    opponent: bool = False

    def pose_at(self, t_s: float) -> tuple[float, float, float]:
        """(x_m, y_m, yaw_rad) at sim time ``t_s``; yaw wrapped to (-pi, pi]."""
        x = self.centre_x_m + self.amp_x_m * math.sin(self.omega_x_radps * t_s + self.phase_x_rad)
        y = self.centre_y_m + self.amp_y_m * math.sin(self.omega_y_radps * t_s + self.phase_y_rad)
        yaw = self.yaw_rad + self.yaw_amp_rad * math.sin(self.yaw_omega_radps * t_s)
        return (x, y, math.atan2(math.sin(yaw), math.cos(yaw)))

    @property
    def moving(self) -> bool:
        return bool(self.amp_x_m or self.amp_y_m or self.yaw_amp_rad)


@dataclass(frozen=True)
class Kick:
    """At ``t_s`` the ball is struck to ``speed_mps`` towards ``target``: a robot's position
    at that moment (a pass) or a fixed point ``target_xy_m`` (a shot or a clearance)."""

    t_s: float
    speed_mps: float
    target_robot: str | None = None
    target_xy_m: tuple[float, float] | None = None


@dataclass(frozen=True)
class LobKick(Kick):
    """A kick into the air: ``speed_mps`` along a direction ``elevation_deg`` above the
    ground, towards the target (turned towards the field's centre at the kick if the first
    landing would be outside the lines)."""

    elevation_deg: float = 35.0


@dataclass(frozen=True)
class Distractor:
    """A box of the ball's colour beside the field (centre x, y and side, metres; yaw)."""

    x_m: float
    y_m: float
    size_m: float
    yaw_rad: float = 0.0


@dataclass(frozen=True)
class MatchPlay:
    """What moves the ball in a match and what else stands around."""

    kicks: tuple[Kick, ...]
    distractors: tuple[Distractor, ...] = ()
    walls: bool = True
    """Collision-only (invisible) walls at the carpet's edge keep the ball in play."""


def _path(rng: np.random.Generator, name: str, centre: tuple[float, float],
          reach: tuple[float, float], yaw: float) -> PathTrack:
    """A loop of the given reach (half extents) about ``centre``, driven at 0.4-1.4 m/s."""
    ax = float(rng.uniform(0.5, 1.0)) * reach[0]
    ay = float(rng.uniform(0.5, 1.0)) * reach[1]
    speed = float(rng.uniform(0.4, 1.4))
    # angular rates so the fastest leg is about ``speed``; distinct x/y rates give a figure
    wx = speed / max(ax, 0.2)
    wy = wx * float(rng.choice([0.5, 1.0, 2.0]))
    return PathTrack(
        name, round(centre[0], 3), round(centre[1], 3), round(ax, 3), round(ay, 3),
        round(wx, 4), round(wy, 4), round(float(rng.uniform(0, 2 * math.pi)), 4),
        round(float(rng.uniform(0, 2 * math.pi)), 4), round(yaw, 4),
        round(float(rng.uniform(0.2, 0.8)), 4), round(float(rng.uniform(0.2, 0.8)), 4))


def _robots(rng: np.random.Generator, n: int, hl: float, hw: float) -> list[PathTrack]:
    """Robot 1 keeps goal (a short path along its goal line), the others roam the field."""
    tracks = [_path(rng, robot_name(1), (-hl + 0.8, 0.0), (0.25, 1.2), 0.0)]
    for i in range(1, n):
        cx = float(rng.uniform(-hl + 3.0, hl - 3.0))
        cy = float(rng.uniform(-hw + 2.5, hw - 2.5))
        reach = (min(2.5, hl - abs(cx) - 0.6), min(2.0, hw - abs(cy) - 0.6))
        tracks.append(_path(rng, robot_name(i + 1), (cx, cy), reach,
                            float(rng.uniform(-math.pi, math.pi))))
    return tracks


def draw_lob(rng: np.random.Generator, radius_m: float = 0.11) -> tuple[float, float]:
    """(elevation_deg, speed_mps) of a lob: uniform in LOB_ELEVATION_DEG x LOB_SPEED_MPS,
    kept when the flight's peak (without drag) is within LOB_APEX_M."""
    while True:
        elevation = float(rng.uniform(*LOB_ELEVATION_DEG))
        speed = float(rng.uniform(*LOB_SPEED_MPS))
        vz = speed * math.sin(math.radians(elevation))
        if LOB_APEX_M[0] <= radius_m + vz * vz / (2 * _GRAVITY_MPS2) <= LOB_APEX_M[1]:
            return round(elevation, 3), round(speed, 3)


def _lobbed(kicks: tuple[Kick, ...], rng: np.random.Generator, fraction: float
            ) -> tuple[Kick, ...]:
    """Each kick a lob with probability ``fraction`` (1: every kick), its target kept."""
    out: list[Kick] = []
    for kick in kicks:
        if fraction > 0 and (fraction >= 1 or rng.uniform() < fraction):
            elevation, speed = draw_lob(rng)
            out.append(LobKick(kick.t_s, speed, kick.target_robot, kick.target_xy_m,
                               elevation_deg=elevation))
        else:
            out.append(kick)
    return tuple(out)


def _kicks(rng: np.random.Generator, robots: list[PathTrack], hl: float,
           hw: float, gap_s: tuple[float, float] = _KICK_GAP_S) -> tuple[Kick, ...]:
    """A kick at t = 0 (the ball starts rolling), then one every ``gap_s`` (1.2-2.6 s): a
    pass to a robot (two in three) or a shot at a point on the field."""
    kicks = []
    t = 0.0
    while t < _PLAY_SPAN_S:
        speed = round(float(rng.uniform(*KICK_SPEED_MPS)), 3)
        if rng.uniform() < 2 / 3:
            target = robots[int(rng.integers(len(robots)))].name
            kicks.append(Kick(round(t, 3), speed, target_robot=target))
        else:
            xy = (round(float(rng.uniform(-hl + 0.5, hl - 0.5)), 3),
                  round(float(rng.uniform(-hw + 0.5, hw - 0.5)), 3))
            kicks.append(Kick(round(t, 3), speed, target_xy_m=xy))
        t += float(rng.uniform(*gap_s))
    return tuple(kicks)


def _distractors(rng: np.random.Generator, count: int, hl: float, hw: float,
                 border: float) -> tuple[Distractor, ...]:
    """``count`` orange boxes in the border strip, 0.4 m or more outside the field lines."""
    out = []
    for _ in range(count):
        size = float(rng.uniform(*_DISTRACTOR_SIZE_M))
        off = float(rng.uniform(0.4, border - 0.4))
        side = int(rng.integers(4))
        if side < 2:  # beside a touch line
            x, y = float(rng.uniform(-hl, hl)), (hw + off) * (1 if side == 0 else -1)
        else:  # behind a goal line, clear of the goal
            y = float(rng.uniform(1.5, hw)) * float(rng.choice([-1.0, 1.0]))
            x = (hl + off) * (1 if side == 2 else -1)
        yaw = float(rng.uniform(0.0, math.pi / 2))
        out.append(Distractor(round(x, 3), round(y, 3), round(size, 3), round(yaw, 4)))
    return tuple(out)


def match_parts(seed: int, n: int, hl: float, hw: float, border: float, distractors: int,
                *, lob_fraction: float = 0.0, lobs_only: bool = False,
                ) -> tuple[list[PathTrack], tuple[float, float], MatchPlay]:
    """Robots, the ball's start and the play of a match, all from ``seed``. Distractors
    and lobs come from their own streams, so adding them leaves the robots and the kicks'
    times and targets unchanged. ``lobs_only``: the ``lobs`` scenario (every kick a lob,
    longer gaps)."""
    rng = np.random.default_rng([seed, 10])
    robots = _robots(rng, n, hl, hw)
    ball = (round(float(rng.uniform(-hl + 2.0, hl - 2.0)), 3),
            round(float(rng.uniform(-hw + 1.5, hw - 1.5)), 3))
    kicks = _kicks(rng, robots, hl, hw, _LOB_GAP_S if lobs_only else _KICK_GAP_S)
    kicks = _lobbed(kicks, np.random.default_rng([seed, 13]), 1.0 if lobs_only else lob_fraction)
    extra = _distractors(np.random.default_rng([seed, 11]), distractors, hl, hw, border)
    return robots, ball, MatchPlay(kicks, extra)
