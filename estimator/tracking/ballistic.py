"""A 3-D ball tracker that flies: rolling on the ground, ballistic flight, bounces.

The state is (x, y, z, vx, vy, vz) of the ball's centre in the field frame; a Kalman filter
over 3-D measurements with their 3 x 3 covariances (:class:`~estimator.fusion.TriangulateFusion`'s:
crossed rays, or one robot's ground estimate whose covariance spreads along its ray, so a
single robot's view moves the track along that ray and not up or down at will).

Between measurements the ball moves:

- **in the air** (centre above R + ``airborne_m`` or rising, and its height known:
  variance below ``unknown_variance_m2``): under gravity, x' = x + v dt,
  z' = z + vz dt - g dt^2 / 2, vz' = vz - g dt (air drag neglected: a few centimetres over
  the 0.3 s a landing is predicted ahead);
- **at a bounce** (the flight reaches z = R going down): the step is split at the contact;
  vz turns to -``restitution`` vz (0 when that is below ``rest_mps``: it rolls on), and the
  covariance of vz grows by (``bounce_sigma`` vz)^2;
- **on the ground**: z = R, vz = 0, constant velocity (the rolling ball).

Process noise: white acceleration noise, ``accel_sigma`` horizontally and vertically. A
measurement's covariance directions wider than ``unknown_variance_m2`` are not measured: one
robot's ground estimate, whose covariance spreads along its ray, moves the track across the
ray only (a bearing), so its height stays as unknown as it is; one that would set a rolling
track rolling faster than ``max_speed_mps`` is refused (a far robot's view of a ball kicked
up, out along its ray, met while the speed is unknown). Measurements farther than the
chi-square gate (99.9 %, of the directions measured) are refused; after two refusals in a
row the track restarts at the second, its velocity from the two (the ball hit a robot or a
post; two one-robot points further apart than any ball runs count where their rays pass
nearest the predicted track, not at their ground points: a far robot sees a hop metres
beyond the ball along its ray), and a refused point that fixes all three directions (crossed
rays, ``restart_on_fixed``) restarts it at once; after ``max_misses`` the next measurement
restarts it. A rolling track that is shown a ball clearly in the air restarts flying at once
(a kick up), its velocity from the way from the last measurement; so does one that a 3-D
point lifts off the ground when the filter takes it (a point whose height is wide, rays
crossing at a shallow angle: the rolling track, its vertical speed held at 0 with no
variance, would otherwise fly on at 0 and fall short of the rising ball).

Free-running cameras give one robot's ray at a time, never two of one instant:
:meth:`BallisticTracker.update_ray` takes a ray at its own stamp into a flying track (the
offset across the ray, 2 directions), so rays of several robots over a few images fix the
3-D state. A rolling track lifted by the filter itself (two robots' height-unknown points
that cross in it) takes an unknown velocity: it was held at vz = 0 while it rolled.

:meth:`BallisticTracker.landing` predicts where and when a flying ball next meets the
ground: t = (vz + sqrt(vz^2 + 2 g (z - R))) / g from now, (x + vx t, y + vy t).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from estimator.constants import BALL_RADIUS_M, NS_PER_S
from estimator.estimates import Matrix
from estimator.rays import BallRay
from estimator.tracking.params import BallisticParams

__all__ = ["GATE_CHI2_3DOF_999", "G_MPS2", "BallisticParams", "BallisticTracker", "Landing"]

G_MPS2 = 9.81
GATE_CHI2_3DOF_999 = 16.27
"""The chi-square of 3 degrees of freedom at 99.9 %."""
_LAUNCH_ABOVE_M = 0.1
"""A measurement the rolling track refuses starts a flight when it is this high."""
_GATE_CHI2 = {1: 10.83, 2: 13.82, 3: GATE_CHI2_3DOF_999}
"""The gate by the measured directions' count (99.9 %)."""
_MIN_RAY_LENGTH_M = 0.1
"""A ray's sigmas are scaled by at least this distance from its camera."""


@dataclass(frozen=True)
class Landing:
    """Where and when a flying ball is predicted to meet the ground."""

    stamp_ns: int
    x_m: float
    y_m: float


class BallisticTracker:
    """The ball in 3-D, through flight, bounces and rolling (see the module doc)."""

    def __init__(self, params: BallisticParams | None = None) -> None:
        self.params = params or BallisticParams()
        self.x: Matrix | None = None
        self.P: Matrix = np.zeros((6, 6))
        self.stamp_ns = 0
        self.misses = 0
        self._last: tuple[int, Matrix] | None = None
        """The last accepted measurement's stamp and the track's position after it."""
        self._last_airborne = False
        self._restart: tuple[int, Matrix] | None = None
        """The last restart at crossed rays (``_restart_fixed``), while no other crossed rays
        have been taken since: its stamp and point."""
        self._refused: tuple[int, Matrix, Matrix] | None = None
        """The last refused measurement, while refusals run in a row: its stamp, the point
        and the point moved along its unmeasured directions (:meth:`_on_the_ray`)."""
        self._ray_misses: dict[str, int] = {}
        """Each robot's rays refused in a row (one robot's taken rays do not vouch for a
        track the others' miss: along its ray it may be anywhere)."""

    @property
    def last_accepted_ns(self) -> int | None:
        """The stamp of the last measurement the track took (or restarted at)."""
        return None if self._last is None else self._last[0]

    @property
    def airborne(self) -> bool:
        """Flying: above the ground or rising, and the height known (a track whose height
        variance is past ``unknown_variance_m2``, one robot's, rolls: one ray invents no
        flight, bounce nor landing)."""
        return self.x is not None and bool(
            self.x[2] > BALL_RADIUS_M + self.params.airborne_m
            or self.x[5] > self.params.rest_mps) and bool(
            self.P[2, 2] < self.params.unknown_variance_m2)

    def _flight(self, dt: float) -> None:
        """Move state and covariance dt seconds under gravity, or rolling."""
        assert self.x is not None
        F = np.eye(6)
        F[0:3, 3:6] = np.eye(3) * dt
        x = F @ self.x
        if self.airborne:
            x[2] -= 0.5 * G_MPS2 * dt * dt
            x[5] -= G_MPS2 * dt
        else:  # rolling: z = R, vz = 0; z's variance kept (a single ray says no height)
            x[2], x[5] = BALL_RADIUS_M, 0.0
            F[2, 5] = 0.0
            F[5, :] = 0.0
        q = self.params.accel_sigma_mps2 ** 2
        G = np.vstack([np.eye(3) * 0.5 * dt * dt, np.eye(3) * dt])
        Q = G @ G.T * q
        if not self.airborne:
            Q[5, :] = 0.0
            Q[:, 5] = 0.0
        self.x = x
        self.P = F @ self.P @ F.T + Q

    def _bounce(self) -> None:
        assert self.x is not None
        p = self.params
        vz = float(self.x[5])
        kept = -p.restitution * vz
        J = np.eye(6)
        self.x[2] = BALL_RADIUS_M
        if kept < p.rest_mps:
            self.x[5] = 0.0
            J[5, 5] = 0.0
            J[2, 2] = 0.0
        else:
            self.x[5] = kept
            J[5, 5] = -p.restitution
            J[2, 2] = 0.0
        self.P = J @ self.P @ J.T
        self.P[5, 5] += (p.bounce_sigma * vz) ** 2
        # friction at the contact trades level speed for spin: a share of it is lost
        level = float(np.hypot(self.x[3], self.x[4]))
        self.P[3, 3] += (p.bounce_level_sigma * level) ** 2
        self.P[4, 4] += (p.bounce_level_sigma * level) ** 2

    def predict(self, stamp_ns: int) -> None:
        """Move the track to ``stamp_ns`` (no-op before the first measurement or backwards)."""
        if self.x is None or stamp_ns <= self.stamp_ns:
            return
        dt = (stamp_ns - self.stamp_ns) / NS_PER_S
        while dt > 1e-9:
            contact = self._contact_in() if self.airborne else None
            if contact is not None and contact < dt:
                self._flight(contact)
                self._bounce()
                dt -= contact
            else:
                self._flight(dt)
                dt = 0.0
        self.stamp_ns = stamp_ns

    def _contact_in(self) -> float | None:
        """Seconds until a flight meets z = R going down (None: not flying)."""
        assert self.x is not None
        h = float(self.x[2]) - BALL_RADIUS_M
        vz = float(self.x[5])
        disc = vz * vz + 2.0 * G_MPS2 * max(h, 0.0)
        t = (vz + math.sqrt(disc)) / G_MPS2
        return t if t > 1e-6 else None

    def update(self, stamp_ns: int, position: tuple[float, float, float],
               covariance: Matrix) -> bool:
        """One 3-D measurement; False when the gate refused it."""
        z = np.array(position, dtype=np.float64)
        Rm = np.asarray(covariance, dtype=np.float64)
        if self.x is None or self.misses >= self.params.max_misses:
            self._start(stamp_ns, z, Rm)
            self._remember(stamp_ns)
            return True
        rolling = not self.airborne
        self.predict(stamp_ns)
        assert self.x is not None
        if rolling and z[2] - BALL_RADIUS_M > 3.0 * math.sqrt(max(Rm[2, 2], 0.0)) + 0.05 and (
                self._launched(stamp_ns, z, Rm)):
            return True  # clearly in the air: kicked up
        w, V = np.linalg.eigh(0.5 * (Rm + Rm.T))
        keep = w < self.params.unknown_variance_m2
        if not keep.any():
            return False
        H = np.zeros((int(keep.sum()), 6))
        H[:, :3] = V[:, keep].T
        S = H @ self.P @ H.T + np.diag(w[keep])
        innovation = H[:, :3] @ (z - self.x[:3])
        d2 = float(innovation @ np.linalg.solve(S, innovation))
        if d2 > _GATE_CHI2[int(keep.sum())]:
            if rolling and z[2] - BALL_RADIUS_M > _LAUNCH_ABOVE_M and (
                    self._launched(stamp_ns, z, Rm)):
                return True  # the rolling ball does not explain it, a flying one may
            if self.params.restart_on_fixed and keep.all():
                return self._restart_fixed(stamp_ns, z, Rm)
            moved = self._on_the_ray(z, V[:, ~keep])
            if self._refused is not None and self._restarted(stamp_ns, z, moved, Rm):
                return True
            self._refused = (stamp_ns, z.copy(), moved)
            self.misses += 1
            return False
        before = (self.x.copy(), self.P.copy()) if rolling and not keep.all() else None
        self._correct(H, S, innovation)
        if before is not None and math.hypot(self.x[3], self.x[4]) > self.params.max_speed_mps:
            self.x, self.P = before  # one robot's point that no ball could roll to
            self.misses += 1
            return False
        if keep.all():
            self._restart = None  # the track's velocity is the crossed points' since
        if rolling and self.airborne:
            if keep.all() and self._launched(stamp_ns, z, Rm):
                return True
            if not keep.all():  # rays of two robots crossed in the filter: a kick up,
                self._loosen(0.0)  # its velocity unknown
        self.misses = 0
        self._refused = None
        self._remember(stamp_ns)
        return True

    def update_ray(self, stamp_ns: int, ray: BallRay) -> bool:
        """One robot's ray at its own stamp (free-running cameras: no other ray of that
        instant to cross it with). The measurement is the track's offset across the ray,
        r = E' (c - p) with E the ray's two unit vectors across it and c the camera; its
        covariance the ray's angular sigmas times the distance along the ray to the track.
        Only for a track whose height is known (:attr:`airborne`: a rolling one takes
        points); False when there is none, or the gate (2 directions, 99.9 %) refused it.
        ``max_misses`` rays refused in a row, or as many of one robot's (the others' taken
        rays do not vouch for the track along them), make the track lost:
        it is loosened (``lost_sigma_m``, the velocity unknown) and takes the ray."""
        if self.x is None or not self.airborne:
            return False
        self.predict(stamp_ns)
        if max([self.misses, *self._ray_misses.values()]) >= self.params.max_misses:
            self._loosen(self.params.lost_sigma_m)  # lost: the velocity and where, loosened
            self._ray_misses.clear()
            self.misses = 0
        c = np.array(ray.origin)
        e_az, e_el = ray.across()
        H = np.zeros((2, 6))
        H[0, :3], H[1, :3] = e_az, e_el
        length = max(float(np.array(ray.direction) @ (self.x[:3] - c)), _MIN_RAY_LENGTH_M)
        Rm = np.diag([(length * ray.sigma_azimuth_rad) ** 2,
                      (length * ray.sigma_elevation_rad) ** 2])
        S = H @ self.P @ H.T + Rm
        innovation = H[:, :3] @ (c - self.x[:3])
        if float(innovation @ np.linalg.solve(S, innovation)) > _GATE_CHI2[2]:
            self._ray_misses[ray.robot] = self._ray_misses.get(ray.robot, 0) + 1
            self.misses += 1
            return False
        self._correct(H, S, innovation)
        if self._apex() > self.params.top_m:
            self._drop_height()
            return False
        self._ray_misses[ray.robot] = 0
        self.misses = 0
        self._refused = None
        self._remember(stamp_ns)
        return True

    def reset_to(self, stamp_ns: int, x: Matrix, P: Matrix) -> None:
        """Take a state fitted to many rays (:mod:`estimator.tracking.flights`) at ``stamp_ns``."""
        self.x, self.P = np.array(x, np.float64), 0.5 * (P + P.T)
        self.stamp_ns = stamp_ns
        self.misses = 0
        self._refused = self._restart = None
        self._ray_misses.clear()
        self._remember(stamp_ns)

    def kicked(self, sigma_mps: float) -> None:
        """An impulse of unknown size: the level velocity's variance grows by
        ``sigma_mps``^2 each way."""
        self.P[3, 3] += sigma_mps ** 2
        self.P[4, 4] += sigma_mps ** 2

    def _correct(self, H: Matrix, S: Matrix, innovation: Matrix) -> None:
        """The Kalman update of a measurement taken (``H``, its innovation and covariance
        ``S``); the ball's centre kept at or above the ground."""
        assert self.x is not None
        K = np.linalg.solve(S, H @ self.P).T
        self.x = self.x + K @ innovation
        self.P = (np.eye(6) - K @ H) @ self.P
        self.P = 0.5 * (self.P + self.P.T)
        self.x[2] = max(float(self.x[2]), BALL_RADIUS_M)

    def _apex(self) -> float:
        """The highest the track's flight goes (its height now if falling)."""
        assert self.x is not None
        vz = max(float(self.x[5]), 0.0)
        return float(self.x[2]) + vz * vz / (2.0 * G_MPS2)

    def _drop_height(self) -> None:
        """A flight no ball flies (above ``top_m``): rays crossed where the ball is not, at
        a shallow angle. Its height is unknown again (on the ground, the variance of a
        spread up to ``top_m``), and it rolls until rays of two robots lift it."""
        assert self.x is not None
        self.x[2], self.x[5] = BALL_RADIUS_M, 0.0
        self.P[[2, 5], :] = self.P[:, [2, 5]] = 0.0
        self.P[2, 2] = (self.params.top_m - BALL_RADIUS_M) ** 2 / 3.0

    def _loosen(self, sigma_m: float) -> None:
        """The velocity unknown (``initial_speed_sigma_mps``, uncorrelated), the position's
        covariance widened by ``sigma_m`` each way."""
        self.P[3:, :] = self.P[:, 3:] = 0.0
        self.P[3:, 3:] = np.eye(3) * self.params.initial_speed_sigma_mps ** 2
        self.P[:3, :3] += np.eye(3) * sigma_m ** 2

    def _remember(self, stamp_ns: int) -> None:
        assert self.x is not None
        position = self.x[:3].copy()
        self._last_airborne = self.airborne
        if not self._last_airborne:  # rolling: on the ground, whatever the filter lifted
            position[2] = BALL_RADIUS_M
        self._last = (stamp_ns, position)

    def _launched(self, stamp_ns: int, z: Matrix, Rm: Matrix) -> bool:
        """A rolling track shown a ball clearly in the air (3 sigma and 5 cm above the
        ground), or refusing one above 0.1 m: it was kicked up. Restart it flying from
        where it rolled, launched at the last measurement: v from the way there (a flight
        under gravity), its sigma ``launch_sigma_mps``."""
        assert self.x is not None
        rolled_at = self._last
        if rolled_at is None or self._last_airborne:
            return False
        dt = (stamp_ns - rolled_at[0]) / NS_PER_S
        if dt <= 0.0:
            return False
        return self._fly_from(rolled_at[1], dt, stamp_ns, z, Rm)

    def _on_the_ray(self, z: Matrix, unknown: Matrix) -> Matrix:
        """A refused measurement with directions it does not measure (one robot's ray: where
        along it the ball is), moved along them to the point nearest the predicted track,
        but not below the ground: the ray's ground point is where a ball on the ground
        would be, and a far robot's ray meets the ground metres beyond a ball in the air."""
        assert self.x is not None
        if not unknown.shape[1]:
            return z
        moved = z + unknown @ (unknown.T @ (self.x[:3] - z))
        return moved if moved[2] >= z[2] else z

    def _restarted(self, stamp_ns: int, z: Matrix, moved: Matrix, Rm: Matrix) -> bool:
        """Two refusals in a row (the ball hit something): restart at the second, its
        velocity from the two (a flight between them, when the second is in the air). When
        the way between the two points is faster than ``max_speed_mps`` (over at least
        ``min_way_s``) no ball ran it: they are far robots' views of a hop, each metres out
        along its ray, and the restart takes them where their rays pass nearest the track
        (``moved``; the same points when they fix every direction)."""
        assert self._refused is not None
        t0, z0, moved0 = self._refused
        dt = (stamp_ns - t0) / NS_PER_S
        if not 0.0 < dt < 0.5:
            return False
        if float(np.linalg.norm(z - z0)) > self.params.max_speed_mps * max(
                dt, self.params.min_way_s):
            z, z0 = moved, moved0
        return self._fly_from(z0, dt, stamp_ns, z, Rm)

    def _restart_fixed(self, stamp_ns: int, z: Matrix, Rm: Matrix) -> bool:
        """A refused measurement that fixes a point: restart there, the velocity from the
        way since the last accepted measurement (when within 0.5 s, else unknown), or since
        the last restart at crossed rays (``restart_way_s``)."""
        p = self.params
        last, before = self._last, self._restart
        if before is not None and last is not None and (
                stamp_ns - last[0] < p.min_way_s * NS_PER_S) and (
                p.restart_way_s[0] <= (dt := (stamp_ns - before[0]) / NS_PER_S)
                < p.restart_way_s[1]) and float(np.linalg.norm(z - before[1])) <= (
                p.max_speed_mps * dt):
            self._fly_from(before[1], dt, stamp_ns, z, Rm, min_way_s=p.restart_way_s[0])
        elif last is not None and 0.0 < (dt := (stamp_ns - last[0]) / NS_PER_S) < 0.5:
            self._fly_from(last[1], dt, stamp_ns, z, Rm)
        else:
            self._start(stamp_ns, z, Rm)
            self._remember(stamp_ns)
        assert self.x is not None
        self._restart = (stamp_ns, self.x[:3].copy())
        return True

    def _fly_from(self, z0: Matrix, dt: float, stamp_ns: int, z: Matrix, Rm: Matrix,
                  min_way_s: float | None = None) -> bool:
        """Restart at ``z`` with the velocity of the way from ``z0`` dt seconds ago (a flight
        under gravity when ``z`` is in the air: vz now = dz / dt - g dt / 2). A way shorter
        than ``min_way_s`` tells no speed, nor does one faster than ``max_speed_mps`` (a point
        is off: far rays crossed at a shallow angle): the level velocity is kept, sigma
        ``initial_speed_sigma_mps``, vz 0 with ``short_way_vz_sigma_mps``; after a way too
        fast the new point's level position is loosened by ``lost_sigma_m`` (it may be off)."""
        p = self.params
        shortest = p.min_way_s if min_way_s is None else min_way_s
        sigma = np.full(3, p.launch_sigma_mps)
        too_fast = dt >= shortest and float(np.linalg.norm(z - z0)) > p.max_speed_mps * dt
        if dt < shortest or too_fast:
            v = np.zeros(3) if self.x is None else np.array([self.x[3], self.x[4], 0.0])
            sigma = np.array([p.initial_speed_sigma_mps, p.initial_speed_sigma_mps,
                              p.short_way_vz_sigma_mps])
        else:
            v = (z - z0) / dt
            if z[2] - BALL_RADIUS_M > _LAUNCH_ABOVE_M:
                v[2] -= 0.5 * G_MPS2 * dt
        self._start(stamp_ns, z, Rm)
        assert self.x is not None
        self.x[3:] = v
        self.P[3:, 3:] = np.diag(sigma ** 2)
        if too_fast:
            self.P[:2, :2] += np.eye(2) * p.lost_sigma_m ** 2
        self._remember(stamp_ns)
        return True

    def _start(self, stamp_ns: int, z: Matrix, Rm: Matrix) -> None:
        self.x = np.concatenate([z, np.zeros(3)])
        self.x[2] = max(self.x[2], BALL_RADIUS_M)
        self.P = np.zeros((6, 6))
        self.P[:3, :3] = Rm
        self.P[3:, 3:] = np.eye(3) * self.params.initial_speed_sigma_mps ** 2
        self.stamp_ns = stamp_ns
        self.misses = 0
        self._refused = None
        self._restart = None

    def landing(self) -> Landing | None:
        """Where and when the ball next meets the ground, if it is flying."""
        if self.x is None or not self.airborne:
            return None
        t = self._contact_in()
        if t is None:
            return None
        return Landing(self.stamp_ns + round(t * NS_PER_S), float(self.x[0] + self.x[3] * t),
                       float(self.x[1] + self.x[4] * t))
