"""Flights fitted to many rays, each at its own stamp: the 3-D track's start, check and bounce.

Free-running cameras never give two rays of one instant; a flight under gravity is still
fixed by rays of different instants (:mod:`estimator.tracking.flight_fit`).
:class:`FlightFollower` keeps the last two seconds of rays (those the 3-D track was given
and those only offered to it, :meth:`FlightFollower.offer_all`) and after each step of
one robot's rays (a step of two robots' rays of one instant, cameras in sync, is the
filter's: they cross, and it takes the point) does this:

- **no flight followed**, at a step with a ray more than ``off_sigma`` off the track (as it
  was at the last step, moved on), another robot's too within ``window_s``: it fits the last
  ``window_s`` of rays as a kick up from the ground at some instant, the ball rolling before
  it, or falling before it (kicked, or bouncing, as it landed; two rays at least before the
  kick: :func:`~estimator.tracking.flight_fit.contact_time`), and as one flight through them
  all (a ball already in the air, or coming down from above the lens). The best fit, each
  ray it dropped counted at the gate and each value it fitted at Akaike's 2 (a kink's two
  pieces fit a few rays of one flight closer than the flight does), none faster up or down
  than ``top_mps``, is a flight when its rays after the kick are two or more of two robots
  or more (``free_rays`` through one flight: five rays fix its six values; one robot's rays
  over 0.3 s fix a flight's height to decimetres only), it is ``launch_m`` up by now, rising
  at ``launch_mps`` to ``top_mps`` (one flight: no faster either way), fits to
  ``fit_per_dof`` per degree of freedom, and beats a kick along the ground (rolling after
  it) by ``margin_chi2``. The 3-D track takes the fitted state at the step, with its
  covariance: a flight from the first rays a ball on the ground does not explain, with no
  simultaneous pair. The kicks and hops of a ground match set this search off often, so it
  begins with rough fits (each gap at its middle, one pass:
  :func:`~estimator.tracking.flight_fit.fit_jobs`) and ends there unless one of them passes
  the test above loosened by ``near`` (heights, rises and fits that far off).
- **in flight, before the landing the track predicts**: one flight through the last
  ``window_s`` of rays since the kick (``check_rays`` or more of two robots) is the check of
  the track's filter (fewer than that, the kick fitted again with the rays since, a lob by
  the test above: a flight begun from the kick's first two rays is put right at the third):
  when the track is off it beyond ``agree_chi2`` (3 degrees of freedom, 99.9 %: a flight
  begun wrong, the filter lagging), or, looser than ``loose_m`` each way, less sure of its
  position than the fit (a flight that came down unseen from above the lenses, its variance
  grown on the way), it takes the fit's state. Air drag bends long flights off one parabola:
  the filter, with its process noise, follows them, and the fit looks back no further than
  ``window_s``.
- **past the landing**: the track's own bounce carries the ball until ``bounce_rays`` rays
  after it (two: a ball kicked on as it lands is flown again at the second); then the
  contact is fitted between the flight before and the one after (within ``retry_ns`` of the
  landing). A ball leaving it surely slower than ``launch_mps`` upwards (two sigmas) is
  handed back to the ground (rolling at the fitted level velocity), a surely faster one
  flies on from the contact; an unsure one waits for more rays, up to ``window_s``.

Pure and deterministic.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from estimator.constants import BALL_RADIUS_M, NS_PER_S
from estimator.estimates import Matrix
from estimator.rays import BallRay
from estimator.tracking.ballistic import G_MPS2, GATE_CHI2_3DOF_999, BallisticTracker
from estimator.tracking.flight_fit import (
    RAY_GATE_CHI2,
    Job,
    Kink,
    StampedRay,
    best_of,
    contact_time,
    fit_jobs,
    fit_kink,
    gap_spans,
    height_at,
    middles,
    per_dof,
    ray_rows,
    refine,
)

__all__ = ["FlightFollower"]

_KEEP_NS = 2 * NS_PER_S
"""Rays are kept this long [ns]."""


@dataclass
class FlightFollower:
    """Flights fitted to the rays of several images (module docstring)."""

    window_s: float = 0.3
    off_sigma: float = 3.0
    launch_m: float = 0.08
    launch_mps: float = 1.0
    top_mps: float = 12.0
    fit_per_dof: float = 3.0
    margin_chi2: float = 10.0
    check_rays: int = 6
    free_rays: int = 5
    near: float = 0.4
    agree_chi2: float = GATE_CHI2_3DOF_999
    loose_m: float = 0.05
    bounce_rays: int = 2
    retry_ns: int = 40_000_000
    _rays: list[StampedRay] = field(default_factory=list)
    _offered: list[BallRay] = field(default_factory=list)
    _kink: Kink | None = None
    """The flight followed: its kick (or bounce) fitted."""
    _landing_ns: int | None = None
    """When the track, at the last step before it, predicted the landing."""
    _prior: tuple[int, Matrix, bool] | None = None
    """The track after the last step: its stamp, state and whether it flew."""
    _surprises: dict[str, int] = field(default_factory=dict)
    """Each robot's last ray that surprised the track (``off_sigma``): its stamp."""

    @property
    def flying(self) -> bool:
        """Whether a flight is followed."""
        return self._kink is not None

    def afresh(self) -> FlightFollower:
        """A follower for a new track: no flight, the rays (and their surprises) kept."""
        return replace(self, _rays=list(self._rays), _offered=list(self._offered), _kink=None,
                       _landing_ns=None, _prior=None, _surprises=dict(self._surprises))

    def offer_all(self, rays: Sequence[BallRay]) -> None:
        """Rays of images the 3-D track was not given (the ground tracker refused a ball
        kicked up): the fits see them at the next step, and drop those that are off."""
        self._offered += rays

    def step(self, stamp_ns: int, rays: Sequence[BallRay], tracker: BallisticTracker) -> bool:
        """After a step's ``rays`` went into ``tracker``: find, check or bounce a flight
        (module docstring); True when the tracker took a fitted state."""
        rays = [*self._offered, *rays]
        if not rays:
            return False
        self._offered = []
        old = 0  # the rays come in order of their stamps: the old ones first
        while old < len(self._rays) and self._rays[old][0] < stamp_ns - _KEEP_NS:
            old += 1
        del self._rays[:old]
        self._rays += [(stamp_ns, r) for r in rays]
        if len({r.robot for r in rays}) >= 2:  # rays of one instant: crossed, the filter's
            self._prior = None if tracker.x is None else (
                stamp_ns, tracker.x.copy(), tracker.airborne)
            return False
        window_ns = round(self.window_s * NS_PER_S)
        surprised = self._surprised(stamp_ns, rays)
        for robot in surprised:
            self._surprises[robot] = stamp_ns
        self._prior = None if tracker.x is None else (
            stamp_ns, tracker.x.copy(), tracker.airborne)
        if self._kink is None and (not surprised or sum(
                1 for t in self._surprises.values() if t > stamp_ns - window_ns) < 2):
            return False  # the rays as the track foresaw them: no lob to look for
        kink = self._launch(stamp_ns) if self._kink is None else self._follow(stamp_ns, tracker)
        if kink is None:
            return False
        x, P = kink.state_at(stamp_ns)
        if kink.after == "roll":  # on the ground: no height nor vertical speed to keep
            x[2], x[5] = BALL_RADIUS_M, 0.0
            P[[2, 5], :] = P[:, [2, 5]] = 0.0
            P[2, 2] = float(tracker.P[2, 2])
        tracker.reset_to(stamp_ns, x, P)
        return True

    def _surprised(self, stamp_ns: int, rays: Sequence[BallRay]) -> list[str]:
        """The robots of the rays more than ``off_sigma`` off the track as it was at the
        last step, moved on to this one (a rolling ball on, a flying one under gravity
        too); every ray's without a track."""
        if self._prior is None:
            return [r.robot for r in rays]
        t0, x, flying = self._prior
        dt = (stamp_ns - t0) / NS_PER_S
        p = x[:3] + x[3:] * dt
        if flying:
            p[2] -= 0.5 * G_MPS2 * dt * dt
        return [r.robot for r in rays if _residual(r, p) > self.off_sigma]

    def _window(self, stamp_ns: int) -> list[StampedRay]:
        lo = stamp_ns - round(self.window_s * NS_PER_S)
        return [(t, r) for t, r in self._rays if t >= lo]

    def _launch(self, stamp_ns: int) -> Kink | None:
        """A lob in the window, if its rays say so (module docstring). Rough fits first
        (each gap at its middle, the distances along the rays those of their ground
        points): when none comes near a lob (``near``), the search ends there."""
        window = self._window(stamp_ns)
        if len(window) < 5:
            return None
        lo, n = window[0][0], len(window)
        spans = gap_spans(window, lo, stamp_ns, min_before=2)
        jobs = [(middles(spans), "roll", "fly"), (middles(spans), "fly", "fly"),
                ([stamp_ns], "free", "fly")]
        if not any(self._lob(k, window, stamp_ns, self.near) for k in _kicks(
                window, spans, jobs, rough=True)):
            return None  # no fit comes near a lob, however placed in its gap
        fly = self._best(_kicks(window, spans, jobs, rough=False), n)
        if fly is None or not self._lob(fly, window, stamp_ns):
            return None
        roll = contact_time(window, lo, stamp_ns, "roll", "roll", min_before=2)
        if roll is not None and _score(roll, n) < _score(fly, n) + self.margin_chi2:
            return None
        self._kink, self._landing_ns = fly, fly.landing_ns()
        return fly

    def _best(self, found: Sequence[Kink], rays: int) -> Kink | None:
        """The fit of ``rays`` rays with the best score, its parameters counted against it
        (Akaike's 2 each: a kink's two pieces fit five rays of one flight closer than the
        flight does), of those no faster up or down than ``top_mps``."""
        found = [k for k in found if abs(float(k.velocity_after[2])) <= self.top_mps]
        return min(found, key=lambda k: _score(k, rays) + _penalty(k), default=None)

    def _lob(self, kink: Kink, window: Sequence[StampedRay], stamp_ns: int,
             slack: float = 1.0) -> bool:
        """Whether ``kink`` is a lob (module docstring); with ``slack`` below 1, whether it
        comes near one (its height, rise and fit looser by that factor)."""
        free = kink.before == "free"
        after = sum(1 for t, _ in window if t >= kink.contact_ns or free)
        vz = float(kink.velocity_after[2])
        top = self.top_mps / slack
        rising = -top <= vz if free else self.launch_mps * slack <= vz
        return kink.robots >= 2 and after >= (self.free_rays if free else 2) and (
            height_at(kink, stamp_ns) - BALL_RADIUS_M >= self.launch_m * slack) and (
            rising and vz <= top and per_dof(kink) <= self.fit_per_dof / slack)

    def _follow(self, stamp_ns: int, tracker: BallisticTracker) -> Kink | None:
        """The flight checked, or its bounce fitted (module docstring)."""
        if not tracker.airborne:  # the track landed on its own, or was restarted
            self._kink = self._landing_ns = None
            return None
        land = self._landing_ns
        if land is None or stamp_ns <= land:
            landing = tracker.landing()
            self._landing_ns = None if landing is None else landing.stamp_ns
            return self._checked(stamp_ns, tracker)
        rays = [(t, r) for t, r in self._rays
                if t >= land - round(self.window_s * NS_PER_S)]
        if sum(1 for t, _ in rays if t > land) < self.bounce_rays:
            return None  # the track's own bounce until the rays show the next flight
        bounce = contact_time(rays, land - self.retry_ns, land + self.retry_ns, "fly", "fly",
                              min_after=self.bounce_rays)
        if bounce is not None and per_dof(bounce) <= self.fit_per_dof:
            vz = float(bounce.velocity_after[2])
            sigma = 2.0 * math.sqrt(max(float(bounce.cov[-1, -1]), 0.0))
            if vz + sigma < self.launch_mps:  # it rolls on
                self._kink = self._landing_ns = None
                return fit_kink(rays, bounce.contact_ns, "fly", "roll")
            if vz - sigma >= self.launch_mps:  # it flies on from the contact
                self._kink, self._landing_ns = bounce, None
                return bounce
        if stamp_ns - land > self.window_s * NS_PER_S:
            self._landing_ns = None  # no sure bounce: the track's own stands
        return None

    def _checked(self, stamp_ns: int, tracker: BallisticTracker) -> Kink | None:
        """One flight through the last ``window_s`` of rays since the kick, when the track
        is off it (module docstring)."""
        kink = self._kink
        assert kink is not None and tracker.x is not None
        window = self._window(stamp_ns)
        rays = [(t, r) for t, r in window if t >= kink.contact_ns]
        if len(rays) >= self.check_rays:
            fit = fit_kink(rays, stamp_ns, "free", "fly")
        elif kink.before != "free" and len(rays) > 2:  # the kick again, with the rays since
            fit = contact_time(window, kink.contact_ns - self.retry_ns,
                               kink.contact_ns + self.retry_ns, kink.before, "fly",
                               min_before=2)
            if fit is not None and not self._lob(fit, window, stamp_ns):
                return None
        else:
            return None
        if fit is None or fit.robots < 2 or per_dof(fit) > self.fit_per_dof:
            return None
        x, P = fit.state_at(stamp_ns)
        d = tracker.x[:3] - x[:3]
        loose = float(np.trace(tracker.P[:3, :3]))
        if float(d @ np.linalg.solve(tracker.P[:3, :3] + P[:3, :3], d)) <= self.agree_chi2 and (
                loose <= 3 * self.loose_m ** 2 or np.trace(P[:3, :3]) >= loose):
            return None
        if fit.before != "free":
            self._kink = fit  # the kick refitted: its rays since are counted from it
        return fit


def _residual(ray: BallRay, point: Matrix) -> float:
    """:func:`~estimator.tracking.ray_pairs.ray_residual`, from the ray's row of the fits."""
    row = ray_rows(ray)
    v = point - row[0:3]
    length = max(float(row[3:6] @ v), 1e-6)
    return math.hypot(float(row[6:9] @ v) / (length * row[12]),
                      float(row[9:12] @ v) / (length * row[13]))


def _kicks(window: Sequence[StampedRay], spans: Sequence[tuple[int, int]],
           jobs: Sequence[Job], rough: bool) -> list[Kink]:
    """A kick up from the ground in the best gap, from a fall in the best gap, and one flight
    through the window, as far as each fits (``rough``: at the gaps' middles)."""
    roll, fall, (free,) = fit_jobs(window, jobs, rough)
    gaps = [best_of(roll, spans), best_of(fall, spans)]
    kicks = [g[0] if rough else refine(window, g) for g in gaps if g is not None]
    return kicks + ([] if free is None else [free])


def _penalty(kink: Kink) -> float:
    """Akaike's penalty of a fit: 2 a value fitted, a kink's contact time one of them."""
    return 2.0 * (kink.theta.size + (kink.before != "free"))


def _score(kink: Kink, rays: int) -> float:
    """A fit's chi-square, each of the ``rays`` it dropped counted at the gate."""
    return kink.chi2 + RAY_GATE_CHI2 * (rays - kink.rays)
