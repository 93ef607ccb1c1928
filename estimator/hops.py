"""Hops: the ball's height beside the ground tracker (``dsp-replay --fusion track --hops``).

A kicked ball often leaves the ground for a few tenths of a second (a hop of 5-10 cm in
the simulator's matches). Each robot places the ball where its ray meets the plane of a
ball on the ground (centre at z = R), so a ball at height R + h is placed farther out
along the ray by about ``d h / (H - R)`` (``d`` its range, ``H`` the camera's height):
1 m at 8 m for a 10 cm hop with a mirror at 0.85 m. The ground tracker
(:class:`~estimator.tracking.BallTracker`) takes these lifted estimates as they come and
the fused position follows the farthest robots outwards, or a kick it explains by one of
them; on the recorded realistic matches this was most of the fused error with true poses.

:class:`HopFollower` runs a :class:`~estimator.fusion.BallisticFusion` (a 3-D state through
flight, bounces and rolling, each robot's ray at its own stamp) beside the ground tracker,
on the estimates the ground tracker accepted and on those within ``near_m`` of either track
(a near robot's right estimate that the tracker refused in favour of a far robot's lifted
one: a false blob is metres off). The fused position is the 3-D track's, the velocity stays
the ground tracker's. The 3-D track is slow to see a kick along the robots' rays (a
one-robot point says nothing along its ray, and rays of different instants are crossed with
the velocity before the kick): when the ground tracker's velocity, which follows a kick at
the first estimate that shows it, is more than ``kick_mps`` from the rolling 3-D track's,
the 3-D track takes a kick of ``kick_sigma_mps`` before the step's estimates; and at each
such step, a ray crossed with another robot's from before the kick or from its first images
(moved with a velocity the 3-D track has not yet found) that puts the ball more than
``lob_m`` up is not taken for a lob: the rays kept are forgotten (two rays a few degrees
apart cross metres along them when one moved 0.2 m across, in the air in front of the
robots). It also takes
an estimate whose ray crosses another robot's recent ray that it took, within ``near_m`` of
the estimate and more than ``lob_m`` above a ball on the ground: in a lob the near robot
sees the ball in the air close to where it places it, and the far robot's ray passes
through the ball there, while the far robot's estimate, and the tracks that followed it,
are metres out (a far robot's false blob whose ray passes the ball low is no lob). The
ground tracker still decides which estimates are the ball and whether there is a track.
Where the two disagree by more than ``guard_m`` (more than a hop lifts an estimate), one of
them has gone astray. It is the ground track when the 3-D track, having been with it, took
within ``keep_ns`` an estimate the ground tracker refused, or took one while flying (its
height known from crossed rays: it places a far robot's lifted estimate in the air where
the ground tracker takes it for a kick): having taken a far robot's lifted estimate as a
kick, the ground tracker runs on along that kick and refuses the near robot that sees the
ball, whose estimates the 3-D track takes. Otherwise it is the 3-D track (rays crossed from
poses that disagree give a height, and a flight, that is not there; a ball lobbed away from
a far robot whose lifted estimates the 3-D track followed too, as the ground tracker did;
or, at the start, a box the ground tracker did not confirm): the ground track's position is
given and the 3-D track starts afresh. A false flight that keeps taking rays is kept too,
so the poses should be good ones (the lines' corrections, ``--localise lines``), or the
rays as unsure as the poses (``--pose-uncertainty``). The fused estimate carries the 3-D
track's height (z and its 3 x 3 covariance): a lob is given where it flies, not on the
ground under it.

Three rules give the ground track's position for a step while the 3-D track is kept: a 3-D
track that refused every estimate of its last step with estimates (the ground tracker took a
kick or a jump the 3-D track gates out: until the 3-D track takes one again, the ground
track is the surer), unless it is surely up (a flight its fits follow, or followed until
less than ``keep_ns`` ago, as at a bounce, or two sigmas more than ``lob_m`` up: a refused
ray leaves a lob in the air, where the ground tracker knows nothing; a track that rose a few
centimetres by itself is mostly a missed kick); a rolling 3-D track that takes nothing at a
step where its velocity is ``kick_mps`` from the ground track's (it would be moved on with a
velocity it has not yet found); and a rolling 3-D track whose largest position variance is
more than ``loose_ratio`` times the ground track's (begun on one robot's images it knows
little along their rays, where the ground tracker's motion model does). A flying track is
never given up for its looseness: the ground tracker knows nothing of a lob.

The estimates the 3-D track does not take still go to its flight fits
(:mod:`estimator.tracking.flights`, kept through its restarts): a lob's first images are
refused by the ground tracker. A flight the fits started is the ball's (it need not have
met the ground track first), and a flying 3-D track that sees nothing at a step (above the
lenses of cameras at robot height) still vouches for itself. Pure and deterministic.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TypeGuard

from estimator.constants import BALL_RADIUS_M
from estimator.estimates import BallEstimate, Covariance, FusedEstimate
from estimator.fusion import BallisticFusion
from estimator.noise import Noise
from estimator.tracking import TrackState

__all__ = ["HopFollower"]


@dataclass
class HopFollower:
    """The 3-D track beside the ground tracker (module docstring)."""

    noise: Noise
    near_m: float = 1.5
    """An estimate the ground tracker refused this close to its track is the ball's [m]."""
    guard_m: float = 2.0
    """The 3-D track is given up this far from the ground track [m]..."""
    keep_ns: int = 100_000_000
    """...unless, having been within it before, it took an estimate the ground tracker
    refused, or took one while flying, this recently [ns]."""

    lob_m: float = 0.1
    """A crossing of rays this high above a ball on the ground is a lob's; a lower one (a
    far robot's false estimate whose ray passes the ball) is not taken [m]."""
    kick_mps: float = 2.0
    """A rolling 3-D track whose level velocity is this far from the ground track's..."""
    kick_sigma_mps: float = 3.0
    """...takes a kick of this sigma each way before this step's estimates [m/s]."""
    loose_ratio: float = 4.0
    """A rolling 3-D track whose position variance (its largest) is this many times the
    ground track's gives the ground track's position."""

    def __post_init__(self) -> None:
        self._flight = BallisticFusion(self.noise)
        self._joined = False
        """The 3-D track has been within ``guard_m`` of the ground track."""
        self._own = False
        """It takes, at this step, an estimate the ground tracker refused."""
        self._vouched_ns: int | None = None
        """The last step at which it took an estimate the ground tracker refused, or took
        one while flying."""
        self._refusing = False
        """At the last step with estimates it refused them all."""
        self._loose = False
        """At the last step with estimates, rolling, it was looser than the ground track."""
        self._flew_ns: int | None = None
        """The last step at which the 3-D track flew a flight its fits follow."""

    @property
    def airborne(self) -> bool:
        """Whether the 3-D track has the ball in the air."""
        return bool(self._flight.tracker.airborne)

    def peek(self, stamp_ns: int, track: TrackState | None) -> FusedEstimate | None:
        """What :meth:`step` would give at ``stamp_ns`` with no estimates, changing
        nothing: a clock's tick (``dsp-replay --clock``) reads the track, as it reads the
        ground tracker's, and leaves what it does at the images as it is without one."""
        twin = copy.copy(self)
        twin._flight = copy.copy(self._flight)  # a step without estimates keeps its rays
        twin._flight.tracker = copy.deepcopy(self._flight.tracker)  # ...and moves this
        return twin.step(stamp_ns, [], track)

    def _lob(self, crossed: tuple[float, float, float] | None
             ) -> TypeGuard[tuple[float, float, float]]:
        """Whether a crossing of rays lies more than ``lob_m`` above a ball on the ground."""
        return crossed is not None and crossed[2] - BALL_RADIUS_M > self.lob_m

    def takes(self, estimate: BallEstimate, accepted: bool, track: TrackState | None,
              stamp_ns: int) -> bool:
        """Whether the 3-D track takes an estimate (an image at ``stamp_ns``): the ground
        tracker ``accepted`` it; or it lies within ``near_m`` of the ground ``track`` at
        its stamp or of the 3-D track's last position (the ground track may have gone
        astray, :meth:`step`); or its ray crosses another robot's recent ray that the 3-D
        track took within ``near_m`` of the estimate and ``lob_m`` above the ground (a lob:
        the near robot sees the ball in the air, close to where it places it, and the far
        robot's ray passes through it there, while its estimate and both tracks are metres
        out)."""
        if accepted:
            return True
        near = [(track.x_m, track.y_m)] if track is not None else []
        x = self._flight.tracker.x
        if x is not None:
            near.append((float(x[0]), float(x[1])))
        own = any(math.hypot(px - estimate.x_m, py - estimate.y_m) < self.near_m
                  for px, py in near)
        if not own and x is not None:
            crossed = self._flight.crossing(stamp_ns, estimate)
            own = self._lob(crossed) and (
                math.hypot(crossed[0] - estimate.x_m, crossed[1] - estimate.y_m) < self.near_m)
        self._own |= own
        if not own:  # a lob's first rays: the ground tracker refuses a ball kicked up
            self._flight.offer(estimate)
        return own

    def step(self, stamp_ns: int, taken: Sequence[BallEstimate],
             track: TrackState | None) -> FusedEstimate | None:
        """The 3-D track at ``stamp_ns`` after the ``taken`` estimates (each with its
        camera's height), as a 2-D fused estimate; None when it has none, or none within
        ``guard_m`` of the ground ``track`` unless, having been with it, the 3-D track
        took an estimate the ground tracker refused, or one while flying, within
        ``keep_ns`` (else it starts afresh). ``taken``: the estimates :meth:`takes` took
        since the last step. ``track`` None: the ground tracker has no confirmed track;
        the 3-D one still takes the estimates."""
        tracker = self._flight.tracker
        kick = track is not None and tracker.x is not None and not tracker.airborne and (
            math.hypot(track.vx_m_s - float(tracker.x[3]),
                       track.vy_m_s - float(tracker.x[4])) > self.kick_mps)
        if kick and taken:
            tracker.kicked(self.kick_sigma_mps)  # the ground tracker saw a kick
        if kick and len(taken) == 1:
            # the rays kept are from before the kick, or from its first images, moved with a
            # velocity the 3-D track has not yet found: a crossing with one in the air is
            # where the ball is not, no lob
            if self._lob(self._flight.crossing(stamp_ns, taken[0])):
                self._flight.pairs.forget()
        flight = self._flight.step(stamp_ns, taken)
        if taken:
            self._refusing = tracker.last_accepted_ns != stamp_ns
        if ((self._own or tracker.airborne) and tracker.last_accepted_ns == stamp_ns) or (
                tracker.airborne and not taken and self._vouched_ns is not None):
            self._vouched_ns = stamp_ns  # an unseen flight (above the lens) vouches on
        self._own = False
        if flight is None or track is None:
            return None
        fused = flight.fused
        if math.hypot(fused.x_m - track.x_m, fused.y_m - track.y_m) <= self.guard_m or (
                self._flight.flights.flying and tracker.airborne):
            self._joined = True  # (a flight fitted to rays of several images is the ball's)
        else:
            vouched = self._vouched_ns
            if not self._joined or vouched is None or stamp_ns - vouched > self.keep_ns:
                fresh = BallisticFusion(self.noise)
                fresh.flights = self._flight.flights.afresh()  # the rays seen stay seen
                self._flight, self._joined = fresh, False
                self._vouched_ns = self._flew_ns = None
                return None
        if taken:
            self._loose = not tracker.airborne and self._looser(
                fused.covariance, track.position_covariance)
        if tracker.airborne and self._flight.flights.flying:
            self._flew_ns = stamp_ns
        if (self._refusing and not self._surely_up(stamp_ns)) or self._loose or (
                kick and not taken and not tracker.airborne):
            return None  # the ground track's position, the 3-D track kept
        return FusedEstimate(fused.x_m, fused.y_m, fused.covariance, fused.robots,
                             z_m=fused.z_m, covariance_3d=fused.covariance_3d,
                             triangulated=fused.triangulated)

    def _surely_up(self, stamp_ns: int) -> bool:
        """Whether the 3-D track flew a flight its fits follow at most ``keep_ns`` ago (now,
        or just before a bounce, where the ground tracker knows nothing of the flight), or
        flies more than two sigmas above ``lob_m`` (a track that went up by itself and
        refuses what the ground tracker takes is mostly a kick it missed, a few centimetres
        off the ground)."""
        if self._flew_ns is not None and stamp_ns - self._flew_ns <= self.keep_ns:
            return True  # (step sets _flew_ns to this step's stamp while the fits follow)
        tracker = self._flight.tracker
        if not tracker.airborne or tracker.x is None:
            return False
        sigma = math.sqrt(max(float(tracker.P[2, 2]), 0.0))
        return float(tracker.x[2]) - BALL_RADIUS_M - self.lob_m > 2.0 * sigma

    def _looser(self, flight: Covariance, ground: Covariance) -> bool:
        """Whether the 3-D track's position variance (its largest) exceeds ``loose_ratio``
        times the ground track's."""
        return _largest(flight) > self.loose_ratio * _largest(ground)


def _largest(c: Covariance) -> float:
    """The largest eigenvalue of a 2 x 2 covariance."""
    (a, b), (_, d) = c
    return 0.5 * (a + d) + math.hypot(0.5 * (a - d), b)
