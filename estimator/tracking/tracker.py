"""The ball tracker: robots' estimates at their own stamps -> the ball's position and velocity.

A Kalman filter over ``x = [p_x, p_y, v_x, v_y]`` (the model and its equations:
:mod:`estimator.tracking.model`), fed one robot estimate at a time, each at its own stamp
[integer ns] with its own 2 x 2 covariance R (a :class:`~estimator.noise.Noise` model, by
default :class:`~estimator.noise.CalibratedNoise`). Cameras need not be synchronised: the
filter predicts to each stamp, so a moving ball is not smeared over a fusion window.

- **Gate.** An estimate whose Mahalanobis distance ``d^2 = nu^T S^-1 nu`` exceeds ``gate``
  (chi-square, 2 degrees of freedom) is rejected: a false blob off the ball does not pull it.
- **Manoeuvres** (kicks, bounces change the velocity within a frame). A rejected estimate
  waits ``manoeuvre_ns`` for a later rejected one to corroborate it (another robot's, or the
  same robot's with nothing accepted between) under a free velocity (``|dz|`` within
  ``max_speed dt`` and their noise). The track is then re-run from the last accepted
  estimate before them with the velocity covariance inflated by ``kick_sigma^2 I`` (an
  impulse of unknown size); the kick is kept if both then pass the gate. When only one
  robot sees the ball, nothing corroborates: a lone rejected estimate explains a kick by
  itself when the last accepted one is at most ``lone_kick_ns`` old, a ball at most
  ``max_speed`` fast could have gone there, and it does not fall where rejected estimates
  keep falling (a still false blob: :class:`~estimator.tracking.clutter.ClutterMap`); the
  kick goes after the last accepted one, or a frame or two earlier where that would make
  the ball faster than ``max_speed`` (:mod:`estimator.tracking.lone_kick`).
- **A kick the gate missed**: accepted estimates that all lean one way are tried with a
  kick before them (:mod:`estimator.tracking.lean`).
- **Friction**: velocity decays at ``friction_per_s`` (linear rolling friction).
- **Velocity**: the track's velocity is that of a filter run beside it on the estimates it
  accepts, with each robot's offset from the others in its state
  (:mod:`estimator.tracking.offsets`): robots that disagree by a few centimetres, their
  estimates alternating, do not read as motion. The position stays the tracker's own.
- **Initialisation**: the first estimate starts a *tentative* track (position from it,
  velocity 0 with sigma ``kick_sigma``), confirmed once it has accepted estimates from two
  robots (or from the same robot when no other reports), and when a robot disagreed with it,
  once these span ``confirm_ns``; by one robot, over ``confirm_ns``, once it has travelled
  (the ball moves) and each other robot's last estimate falls where rejected estimates pile
  up (a still false blob). While tentative, two rejected estimates consistent with each
  other start the track afresh from them.
- **Re-acquisition**: rejected estimates of the last ``reacquire_ns`` that agree on one
  ball at constant velocity restart the track (confirmed) when the track heard nothing since
  they began, or more robots support them (:mod:`estimator.tracking.reacquire`); never from
  where rejected estimates keep falling (clutter: a still false blob that two robots report
  at once) while the track moves, nor once it has travelled ``TRAVELLED_M`` from where it
  began (a ball come to rest after rolling, that one robot sees, against a box two others
  keep reporting: a false blob never travels; a track that hears nothing is lost instead).
- **Loss**: after ``lost_after_ns`` without an accepted estimate the track is lost
  (:meth:`BallTracker.state_at` gives None); the next estimate starts anew.
- **Late estimates**: the last ``memory_ns`` of estimates are kept with the filter's state
  after each, so an estimate stamped before the newest is inserted in stamp order and the
  track re-run from there. Causal: a state at t uses only estimates received so far.
- **Offline**: with ``record=True`` the filter's states are kept and :meth:`BallTracker.smoothed`
  runs the RTS smoother over them (:mod:`estimator.tracking.smoother`).

Deterministic: no randomness; estimates with equal stamps are processed in arrival order.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

import numpy as np

from estimator.constants import NS_PER_S
from estimator.errors import FusionError
from estimator.tracking.clutter import ClutterMap
from estimator.tracking.lean import lean_kick
from estimator.tracking.lone_kick import lone_kick
from estimator.tracking.model import Gaussian, Matrix, innovation, predict, update
from estimator.tracking.offsets import OffsetFilter
from estimator.tracking.params import TrackerParams
from estimator.tracking.reacquire import (
    STILL_M_S,
    Candidate,
    reachable,
    reacquire_from,
    travelled,
)
from estimator.tracking.smoother import FilterNode, SmoothedTrack
from estimator.tracking.state import Measurement, TrackState, track_state

__all__ = ["BallTracker"]


@dataclass(eq=False)
class _Entry:
    """A measurement in the tracker's memory and the filter's state after it."""

    m: Measurement
    seq: int
    z: Matrix
    r: Matrix
    kick: bool = False
    accepted: bool = False
    state: Gaussian | None = None
    """Posterior when accepted, else the prediction to its stamp."""
    prior: Gaussian | None = None
    """The prediction to its stamp (kick included), for the smoother."""
    offsets: Gaussian | None = None
    """The ball and the robots' offsets after it (:mod:`~estimator.tracking.offsets`)."""

    @property
    def key(self) -> tuple[int, int]:
        return (self.m.stamp_ns, self.seq)


def _candidate(e: _Entry) -> Candidate:
    shared = e.m.shared_covariance
    return Candidate(e.m.stamp_ns, e.m.robot, e.z, e.r, e.accepted,
                     None if shared is None else np.asarray(shared, np.float64))


@dataclass
class _Track:
    """The filter's state at ``anchor_ns`` and the entries after it, in (stamp, seq) order."""

    anchor_ns: int
    anchor: Gaussian
    entries: list[_Entry] = field(default_factory=list)
    confirmed: bool = False
    robots: set[str] = field(default_factory=set)
    """Robots whose estimates this track has accepted."""
    anchor_accepted_ns: int = 0
    anchor_robot: str | None = None
    """The robot whose estimate is the anchor (a new track's first), None once pruned."""
    start_ns: int = 0
    """The stamp of the track's first estimate."""
    contested: bool = False
    """A robot's estimate disagreed with the track while it was tentative."""
    origin: Gaussian | None = None
    """The track's first estimate (z, R)."""
    travelled: bool = False
    """The track has been ``TRAVELLED_M`` and more than its noise from its first estimate."""
    offsets: Gaussian | None = None
    """The ball and the robots' offsets at ``anchor_ns``."""


class BallTracker:
    """The causal ball tracker (module docstring). Feed :meth:`update` with estimates in
    (about) stamp order; read :meth:`state_at` at any stamp."""

    def __init__(self, params: TrackerParams | None = None, *, record: bool = False) -> None:
        self.params = params or TrackerParams()
        self.record = record
        """Keep the filter's state at every estimate, for :meth:`smoothed` (offline)."""
        self._nodes: list[FilterNode] = []
        self._segment = -1
        self._track: _Track | None = None
        self._seq = 0
        self._clutter = ClutterMap()
        self._offsets = OffsetFilter(self.params)
        self.late = 0
        """Estimates dropped because they were older than the tracker's memory."""

    # --- feeding --------------------------------------------------------------------------
    def update(self, m: Measurement) -> bool:
        """Add one estimate; True when the track accepted it (it started the track, passed
        the gate, or a manoeuvre explained it)."""
        r = np.array(m.covariance, dtype=np.float64)
        e = _Entry(m, self._seq, np.array([m.x_m, m.y_m]), 0.5 * (r + r.T))
        self._seq += 1
        track = self._track
        if track is not None and m.stamp_ns - self._last_accepted_ns(track) > (
                self.params.lost_after_ns):
            self._fold(track, len(track.entries))
            track = self._track = None  # lost: start afresh
        if track is None:
            self._track = self._new_track(e, [])
            return True
        if m.stamp_ns < track.anchor_ns:
            self.late += 1
            return False
        i = bisect.bisect_right([x.key for x in track.entries], e.key)
        track.entries.insert(i, e)
        self._rerun(track, i)
        if not e.accepted:
            if track.confirmed:
                self._explain_by_kick(track, e)
                if not e.accepted:
                    self._explain_alone(track, e)
            else:
                track.contested = True  # a robot disagrees with a tentative track
                self._restart_from_pair(track, e)
            if not e.accepted and self._track is track:
                self._reacquire(track, e)
        track = self._track
        assert track is not None
        prm, now = self.params, track  # (now: the track as the lambda sees it)
        if e.accepted and now.confirmed and prm.lean_count:  # a kick the gate missed
            lean_kick(now.entries, lambda i: self._rerun(now, i), count=prm.lean_count,
                      sigma=prm.lean_sigma, keep_ratio=prm.lean_keep)
        self._note_travel(track, e)
        self._confirm(track, e)
        self._prune(track, m.stamp_ns)
        if not e.accepted:
            self._clutter.add(m.stamp_ns, *m.still_xy)
        return e.accepted

    def _initial(self, e: _Entry) -> Gaussian:
        """A new track at an estimate: its position and R, velocity 0 with sigma kick."""
        p = np.zeros((4, 4))
        p[:2, :2] = e.r
        p[2, 2] = p[3, 3] = self.params.kick_sigma_m_s**2
        return np.array([e.z[0], e.z[1], 0.0, 0.0]), p

    def _rerun(self, track: _Track, start: int) -> None:
        """Re-run the filter over entries[start:] from the state before them."""
        prm = self.params
        prev = track.entries[start - 1] if start > 0 else None
        t_prev, state = (prev.m.stamp_ns, prev.state) if prev else (track.anchor_ns, track.anchor)
        offsets = prev.offsets if prev else track.offsets
        assert state is not None and offsets is not None
        for e in track.entries[start:]:
            x, p = state
            if e.kick:  # an impulse of unknown size just before this estimate
                p = p + np.diag([0.0, 0.0, 1.0, 1.0]) * prm.kick_sigma_m_s**2
            dt = (e.m.stamp_ns - t_prev) / NS_PER_S
            prior = predict((x, p), dt, q=prm.accel_noise_m2_s3,
                            friction_per_s=prm.friction_per_s)
            _, _, d2 = innovation(prior, e.z, e.r)
            e.accepted = d2 <= prm.gate
            e.state = update(prior, e.z, e.r) if e.accepted else prior
            e.prior = prior
            e.offsets = offsets = self._offsets.step(offsets, dt, kick=e.kick, robot=e.m.robot,
                                                     z=e.z, r=e.r, accepted=e.accepted)
            t_prev, state = e.m.stamp_ns, e.state

    def _consistent(self, a: _Entry, b: _Entry) -> bool:
        """Could one ball at a free velocity (|v| <= max_speed) give both estimates?"""
        return reachable(_candidate(a), _candidate(b), max_speed_m_s=self.params.max_speed_m_s,
                         gate=self.params.gate)

    def _partners(self, track: _Track, e: _Entry, window_ns: int) -> list[_Entry]:
        """Rejected entries before ``e`` within ``window_ns`` that may corroborate it, the
        most recent first: another robot's, or the same robot's when no entry between them
        was accepted."""
        out = []
        accepted_between = False
        i = track.entries.index(e)
        for f in reversed(track.entries[:i]):
            if e.m.stamp_ns - f.m.stamp_ns > window_ns:
                break
            if f.accepted:
                accepted_between = True
                continue
            if (f.m.robot != e.m.robot or not accepted_between) and self._consistent(f, e):
                out.append(f)
        return out

    def _explain_by_kick(self, track: _Track, e: _Entry) -> None:
        """Try each corroborating rejected estimate f as the first after a kick; keep the
        first try under which both f and e pass the gate."""
        for f in self._partners(track, e, self.params.manoeuvre_ns):
            i = track.entries.index(f)
            while i > 0 and not track.entries[i - 1].accepted:
                i -= 1  # the kick came after the last accepted estimate
            k = track.entries[i]
            was, k.kick = k.kick, True
            self._rerun(track, i)
            if f.accepted and e.accepted:
                return
            k.kick = was  # a kick found before stays
            self._rerun(track, i)

    def _explain_alone(self, track: _Track, e: _Entry) -> None:
        """A lone rejected estimate as the first after a kick (module docstring): kept when
        it then passes the gate and no estimate before it changes its verdict."""
        prm = self.params
        i = track.entries.index(e)
        j = next((j for j in range(i - 1, -1, -1) if track.entries[j].accepted), -1)
        if j < 0 or e.m.stamp_ns - track.entries[j].m.stamp_ns > prm.lone_kick_ns:
            return
        if self._clutter.covers(e.m.stamp_ns, *e.m.still_xy):
            return
        last = track.entries[j]
        assert last.state is not None
        x, p = last.state
        reach = prm.max_speed_m_s * (e.m.stamp_ns - last.m.stamp_ns) / NS_PER_S
        dz = e.z - x[:2]
        if float(dz @ np.linalg.solve(p[:2, :2] + e.r + reach**2 * np.eye(2), dz)) > prm.gate:
            return  # farther than a ball could have gone
        lone_kick(track.entries, i, j, lambda k: self._rerun(track, k),
                  max_speed=prm.max_speed_m_s)

    def _restart_from_pair(self, track: _Track, e: _Entry) -> None:
        """A tentative track that two consistent rejected estimates contradict starts
        afresh from the earlier of them; the entries after it are re-run."""
        others = {f.m.robot for f in track.entries if f.m.robot != e.m.robot}
        for f in self._partners(track, e, self.params.memory_ns):
            if f.m.robot == e.m.robot and others:
                continue  # one robot alone may not overrule the others
            self._restart_at(track, f).contested = True  # it overruled a robot
            return

    def _restart_at(self, track: _Track, f: _Entry) -> _Track:
        """A new track from ``f``; the entries after it are re-run."""
        i = track.entries.index(f)
        later = track.entries[i + 1:]
        for x in later:
            x.kick = False
        self._fold(track, i)  # the old track's record ends before f
        fresh = self._new_track(f, later)
        self._rerun(fresh, 0)
        self._track = fresh
        return fresh

    def _reacquire(self, track: _Track, e: _Entry) -> None:
        """Restart from rejected estimates that agree on another path, when
        :func:`~estimator.tracking.reacquire.reacquire_from` says so (a bounce the gate
        missed, or a track started on a false blob)."""
        prm = self.params
        i = track.entries.index(e)
        before = track.entries[i - 1].state if i > 0 else track.anchor
        assert before is not None
        speed = math.hypot(before[0][2], before[0][3])
        if (speed >= STILL_M_S or track.travelled) and self._clutter.covers(
                e.m.stamp_ns, *e.m.still_xy):
            return  # a still false blob that robots keep reporting never displaces the ball
        first = reacquire_from(
            [_candidate(x) for x in track.entries[:i + 1]],
            track_speed_m_s=speed,
            window_ns=prm.reacquire_ns, count=prm.reacquire_count,
            max_speed_m_s=prm.max_speed_m_s, gate=prm.gate, tentative=not track.confirmed)
        if first is not None:
            self._restart_at(track, track.entries[first]).confirmed = True

    def _confirm(self, track: _Track, e: _Entry) -> None:
        """A tentative track is confirmed once it has accepted estimates of two robots (or
        of its only robot, when no other robot reports); when a robot disagreed with it, only
        once they span ``confirm_ns`` too (two robots that take the same box for the ball at
        once, against the one that sees the ball, do not confirm it at once). A track that
        has travelled is confirmed by one robot once they span ``confirm_ns``, when each
        other robot's last estimate is rejected where rejected estimates pile up (the ball
        one robot follows across the field, against a still box the others report)."""
        if not e.accepted:
            return
        track.robots.add(e.m.robot)
        if track.confirmed:
            return
        spans = e.m.stamp_ns - track.start_ns >= self.params.confirm_ns
        if (len(track.robots) > 1 or all(x.m.robot == e.m.robot for x in track.entries)) and (
                not track.contested or spans):
            track.confirmed = True
        elif track.travelled and spans:
            last = {x.m.robot: x for x in track.entries if x.m.robot not in track.robots}
            track.confirmed = all(not x.accepted and self._clutter.covers(
                x.m.stamp_ns, *x.m.still_xy) for x in last.values())

    def _note_travel(self, track: _Track, e: _Entry) -> None:
        """Mark a track that an accepted estimate puts far from its first estimate
        (:func:`~estimator.tracking.reacquire.travelled`): it follows the ball."""
        if not track.travelled and e.accepted and track.origin is not None:
            assert e.state is not None
            track.travelled = travelled(e.state, track.origin, gate=self.params.gate)

    def _new_track(self, e: _Entry, entries: list[_Entry]) -> _Track:
        """A tentative track anchored at ``e`` (a new segment of the record)."""
        initial = self._initial(e)
        self._segment += 1
        if self.record:
            self._nodes.append(FilterNode(e.m.stamp_ns, initial, initial, self._segment))
        return _Track(e.m.stamp_ns, initial, entries, robots={e.m.robot},
                      anchor_accepted_ns=e.m.stamp_ns, anchor_robot=e.m.robot,
                      start_ns=e.m.stamp_ns, origin=(e.z, e.r),
                      offsets=self._offsets.start(initial, e.m.robot, e.m.stamp_ns))

    def _prune(self, track: _Track, now_ns: int) -> None:
        """Fold entries older than memory_ns into the anchor."""
        limit = now_ns - self.params.memory_ns
        self._fold(track, sum(1 for e in track.entries if e.m.stamp_ns < limit))

    def _fold(self, track: _Track, count: int) -> None:
        """Fold the first ``count`` entries into the anchor (they are final: recorded)."""
        for first in track.entries[:count]:
            assert first.state is not None and first.prior is not None
            track.anchor_ns, track.anchor = first.m.stamp_ns, first.state
            assert first.offsets is not None
            track.offsets = first.offsets
            self._offsets.settle(first.offsets, first.m.stamp_ns)
            track.anchor_robot = None
            if first.accepted:
                track.anchor_accepted_ns = first.m.stamp_ns
            if self.record:
                self._nodes.append(FilterNode(first.m.stamp_ns, first.prior, first.state,
                                              self._segment))
        del track.entries[:count]

    @staticmethod
    def _last_accepted_ns(track: _Track) -> int:
        for e in reversed(track.entries):
            if e.accepted:
                return e.m.stamp_ns
        return track.anchor_accepted_ns

    def finish(self) -> None:
        """Make every estimate so far final (no late estimate can reach them any more)."""
        if self._track is not None:
            self._fold(self._track, len(self._track.entries))

    def smoothed(self) -> SmoothedTrack:
        """The fixed-interval smoother over the record (after :meth:`finish`); requires
        ``record=True``."""
        if not self.record:
            raise FusionError("smoothed() needs BallTracker(record=True)")
        return SmoothedTrack(self._nodes, friction_per_s=self.params.friction_per_s)

    # --- reading --------------------------------------------------------------------------
    @property
    def confirmed(self) -> bool:
        return self._track is not None and self._track.confirmed

    def state_at(self, stamp_ns: int) -> TrackState | None:
        """The track predicted to ``stamp_ns`` from the last state at or before it; None
        when there is no track or it is lost by then."""
        track = self._track
        if track is None or stamp_ns - self._last_accepted_ns(track) > self.params.lost_after_ns:
            return None
        t_prev, state, offsets = track.anchor_ns, track.anchor, track.offsets
        for e in reversed(track.entries):
            if e.m.stamp_ns <= stamp_ns:
                assert e.state is not None
                t_prev, state, offsets = e.m.stamp_ns, e.state, e.offsets
                break
        prm = self.params
        dt = (stamp_ns - t_prev) / NS_PER_S
        x, p = (a.copy() for a in predict(state, dt, q=prm.accel_noise_m2_s3,
                                          friction_per_s=prm.friction_per_s))
        assert offsets is not None  # the velocity is the offset filter's (module docstring)
        x[2:4], p[2:4, 2:4] = self._offsets.velocity(offsets, dt)
        return track_state(stamp_ns, (x, p), track.confirmed)

    def offsets(self) -> dict[str, tuple[float, float]]:
        """Each robot's offset from the others (x, y) [m] at the newest estimate, as the
        velocity's filter holds it (:mod:`~estimator.tracking.offsets`); empty, no track."""
        track = self._track
        g = None if track is None else track.entries[-1].offsets if track.entries else (
            track.offsets)
        return {} if g is None else self._offsets.of(g)

    def accepted_at(self, stamp_ns: int) -> tuple[str, ...]:
        """Robots whose estimates stamped ``stamp_ns`` the track accepted, in arrival order."""
        track = self._track
        if track is None:
            return ()
        first = (track.anchor_robot,) if (
            track.anchor_robot is not None and track.anchor_ns == stamp_ns) else ()
        return first + tuple(e.m.robot for e in track.entries
                             if e.m.stamp_ns == stamp_ns and e.accepted)

