"""The ball in the air: lobs launched, flown and bounced by pybullet's physics.

Why pybullet and not an analytic arc: the flight has to meet what stands on the field (a
lob hits a robot, a post or the crossbar, lands on a robot's top) and its bounces have to
trade speed for spin by friction as a real ball's do; pybullet does both, and its flight
between contacts *is* a parabola: semi-implicit Euler under constant gravity puts every
step on the exact parabola of a launch velocity lower by ``g dt / 2`` (0.02 m/s), so the
rendered ball and the truth follow one curve. What had to be set right for the air:

- **Drag.** pybullet's multibody damping slows the ball by ``d (1 + |v|) v``. On the
  ground ``d = 0.05`` is the rolling ball's friction and damping (every earlier log). In the
  air that would be 3-4 times real air drag, ``k |v| v`` with ``k = rho Cd A / (2 m) =
  0.0139 / m`` (air 1.2 kg/m^3, Cd 0.25, a 0.22 m ball of 0.41 kg), so while the ball is
  airborne (its centre more than :data:`AIRBORNE_M` above its resting height) the damping
  is ``d = 0.012``: within 5 % of ``k |v|`` over 5-10 m/s. A lob's peak comes 3-6 % below
  its drag-free height and its first landing 4-10 % short (measured over 20-50 deg,
  6-10 m/s).
- **Restitution.** pybullet multiplies the restitutions of the two bodies in contact; the
  ball's is 0.6 and the carpet's 0.5 (0.3: a dead bounce) in every earlier log. With lobs
  the carpet's is 0.95 and the ball's contact processing threshold 0 (with pybullet's
  default a contact is resolved up to a step early and one bounce in three loses a
  quarter of its speed), so a bounce keeps 0.57-0.64 of the normal speed, 0.60 on average
  (measured from the rebound heights of drops from 1.0-2.7 m), as a football does on
  artificial turf (FIFA's turf test: 0.6-1.0 m from 2 m, e = 0.55-0.71). Bounces die
  below pybullet's restitution threshold and the ball rolls on.
- **Walls.** The collision-only walls at the carpet's edge are 4 m high (0.5 m without
  lobs), so a bounce never leaves the carpet over them, and hidden (the 0.5 m walls of a
  match without lobs show as a band at the carpet's edge, as they always have).

A lob is struck without spin (pybullet has no Magnus force; spin matters only at the
bounces). A kick that falls due while the ball is in the air waits until it is down.

No pybullet here (the :class:`Flight` drives a :class:`recorder.world.World` it is given,
through the few methods :class:`FlightWorld` names, so this module imports no world).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

from dsp.field import FieldSpec
from estimator.constants import BALL_RADIUS_M
from recorder.match import LobKick

__all__ = ["AIRBORNE_M", "AIR_DAMPING", "GROUND_DAMPING", "LOB_FLIGHT", "Flight",
           "FlightParams", "FlightWorld"]

GROUND_DAMPING = 0.05
"""The ball's linear damping on the ground (every log's): its rolling friction and drag."""
AIR_DAMPING = 0.012
"""The ball's linear damping in the air (see the module doc)."""
AIRBORNE_M = 0.01
"""The ball is airborne when its centre is this far above its resting height."""
_GRAVITY_MPS2 = 9.81
_LANDING_MARGIN_M = 0.3


@dataclass(frozen=True)
class FlightParams:
    """The physics of the ball in the air, as the scenario records it."""

    restitution: float
    """A bounce on the carpet keeps about this much of the normal speed (measured)."""
    ground_restitution: float
    """The carpet body's restitution in pybullet (the ball's is 0.6)."""
    contact_threshold_m: float
    """The ball's contact processing threshold in pybullet."""
    air_damping: float
    """pybullet's linear damping d while airborne: the ball slows by d (1 + |v|) v."""
    ground_damping: float
    airborne_above_m: float
    wall_height_m: float


LOB_FLIGHT = FlightParams(restitution=0.6, ground_restitution=0.95, contact_threshold_m=0.0,
                          air_damping=AIR_DAMPING,
                          ground_damping=GROUND_DAMPING, airborne_above_m=AIRBORNE_M,
                          wall_height_m=4.0)
"""The flight of every scenario with lobs."""


class FlightWorld(Protocol):
    """What a :class:`Flight` needs of the world (:class:`recorder.world.World` has it)."""

    @property
    def field(self) -> FieldSpec: ...

    def ball_position(self) -> tuple[float, float, float]: ...

    def set_ball_damping(self, linear: float) -> None: ...

    def set_bounce(self, ground_restitution: float, contact_threshold_m: float) -> None: ...

    def launch_ball(self, vx_mps: float, vy_mps: float, vz_mps: float) -> None: ...


class Flight:
    """Sets the world up for lobs and keeps the ball's damping to its place (air or ground)."""

    def __init__(self, world: FlightWorld, params: FlightParams = LOB_FLIGHT) -> None:
        self.world = world
        self.params = params
        self._in_air = False
        world.set_bounce(params.ground_restitution, params.contact_threshold_m)

    def airborne(self) -> bool:
        """The ball's centre is more than ``airborne_above_m`` above its resting height."""
        return self.world.ball_position()[2] > BALL_RADIUS_M + self.params.airborne_above_m

    def step(self) -> None:
        """After a physics step: the damping of where the ball is now."""
        in_air = self.airborne()
        if in_air != self._in_air:
            self.world.set_ball_damping(self.params.air_damping if in_air
                                        else self.params.ground_damping)
            self._in_air = in_air

    def launch(self, kick: LobKick, dx: float, dy: float) -> None:
        """Strike the ball into the air towards (dx, dy) from where it is (turned towards
        the field's centre if the drag-free first landing would fall outside the lines)."""
        bx, by, _ = self.world.ball_position()
        n = math.hypot(dx, dy)
        ux, uy = dx / n, dy / n
        elevation = math.radians(kick.elevation_deg)
        reach = kick.speed_mps ** 2 * math.sin(2 * elevation) / _GRAVITY_MPS2
        field = self.world.field
        lx, ly = bx + reach * ux, by + reach * uy
        if (abs(lx) > field.half_length_m - _LANDING_MARGIN_M
                or abs(ly) > field.half_width_m - _LANDING_MARGIN_M) and math.hypot(bx, by) > 0:
            ux, uy = -bx / math.hypot(bx, by), -by / math.hypot(bx, by)
        horizontal = kick.speed_mps * math.cos(elevation)
        self.world.launch_ball(horizontal * ux, horizontal * uy,
                               kick.speed_mps * math.sin(elevation))
