"""The trackers' parameters (:mod:`estimator.tracking.tracker`, and the 3-D track's of
:mod:`estimator.tracking.ballistic`), units in the names."""

from __future__ import annotations

from dataclasses import dataclass

from estimator.constants import NS_PER_S
from estimator.errors import FusionError

__all__ = ["GATE_CHI2_999", "BallisticParams", "TrackerParams"]

GATE_CHI2_999 = 13.815510557964274
"""chi-square quantile, 2 degrees of freedom, 0.999: -2 ln(0.001)."""


@dataclass(frozen=True)
class TrackerParams:
    """The tracker's tuning (units in the names)."""

    accel_noise_m2_s3: float = 1.0
    """q: spectral density of the white acceleration noise [m^2/s^3]: small, since kicks
    and bounces are handled apart (velocity sigma grows by sqrt(q dt), 0.13 m/s in 17 ms)."""
    friction_per_s: float = 0.5
    """beta: the rolling ball's velocity decays as exp(-beta t) [1/s]. Measured on the
    simulator's match logs (true velocities): a ball at 1-2 m/s loses about 30 % of its speed
    per second, at 2-3 m/s 45 %, faster (just after a kick, still sliding) more; 0.5 is the
    middle. (pybullet's linear damping alone would be 0.05.)"""
    gate: float = GATE_CHI2_999
    """Largest accepted Mahalanobis distance squared d^2."""
    kick_sigma_m_s: float = 6.0
    """Sigma of a kick's velocity change, and of the velocity of a new track [m/s]."""
    max_speed_m_s: float = 12.0
    """Fastest ball: bounds how far two estimates that corroborate each other may lie."""
    manoeuvre_ns: int = 150_000_000
    """How long a rejected estimate waits to be corroborated [ns]."""
    lost_after_ns: int = NS_PER_S
    """A track without an accepted estimate for this long is lost [ns]."""
    memory_ns: int = 300_000_000
    """How far back late estimates are re-inserted [ns] (>= manoeuvre_ns)."""
    reacquire_ns: int = 300_000_000
    """Window of rejected estimates that may agree on a new path [ns] (memory_ns at most)."""
    reacquire_count: int = 2
    """Fewest rejected estimates that agree on a new path and may restart the track."""
    confirm_ns: int = 40_000_000
    """A tentative track that a robot disagreed with is confirmed only when its accepted
    estimates span at least this long [ns] (two robots taking the same box for the ball
    9 ms apart, against a third that sees the ball, do not confirm it)."""
    lean_count: int = 4
    """A kick is tried where the last this many accepted estimates lean one way
    (:mod:`estimator.tracking.lean`; 0: never)."""
    lean_sigma: float = 3.0
    """... when their whitened innovations' mean, times sqrt(lean_count), is this long."""
    lean_keep: float = 0.5
    """... and kept when their summed squared innovations fall to this share or less."""
    lone_kick_ns: int = 250_000_000
    """A lone rejected estimate may explain a kick when the track's last accepted estimate
    is at most this old [ns] and within the tracker's memory (0: never; a kick then needs
    corroboration)."""

    def __post_init__(self) -> None:
        positive = (self.gate, self.kick_sigma_m_s, self.max_speed_m_s, self.lost_after_ns)
        if not (all(v > 0 for v in positive) and self.accel_noise_m2_s3 >= 0.0
                and self.friction_per_s >= 0.0 and 0 <= self.manoeuvre_ns <= self.memory_ns
                and self.reacquire_ns >= 0 and self.reacquire_count >= 2
                and self.lone_kick_ns >= 0 and self.confirm_ns >= 0
                and self.lean_count >= 0 and self.lean_sigma > 0 and 0 < self.lean_keep <= 1):
            raise FusionError(
                f"tracker parameters {self}: gate, kick_sigma_m_s, max_speed_m_s and "
                "lost_after_ns must be > 0, accel_noise_m2_s3 and friction_per_s >= 0, "
                "0 <= manoeuvre_ns <= memory_ns, reacquire_ns >= 0, reacquire_count >= 2, "
                "lone_kick_ns >= 0, confirm_ns >= 0, lean_count >= 0, lean_sigma > 0, "
                "0 < lean_keep <= 1"
            )


@dataclass(frozen=True)
class BallisticParams:
    accel_sigma_mps2: float = 3.0
    """White acceleration noise [m/s^2] (the ball's unmodelled manoeuvres: kicks, drag)."""
    restitution: float = 0.6
    """A bounce keeps this much of the normal speed (a football on turf)."""
    bounce_sigma: float = 0.15
    """The spread of the kept share at a bounce."""
    bounce_level_sigma: float = 0.2
    """The spread of the level speed kept at a bounce (friction)."""
    rest_mps: float = 0.5
    """A bounce slower than this leaves the ball rolling."""
    airborne_m: float = 0.02
    unknown_variance_m2: float = 0.5
    """A measurement's covariance direction wider than this is not measured (one robot's
    ray: the spread along it says the height is unknown; the track keeps its own there)."""
    max_misses: int = 3
    restart_on_fixed: bool = True
    """A refused measurement that fixes all three directions (crossed rays) restarts the
    track at once, from the way since the last accepted one: rays that meet are seldom a
    false blob (the track met a robot, a post, a bounce sooner or later than predicted)."""
    initial_speed_sigma_mps: float = 10.0
    launch_sigma_mps: float = 2.0
    max_speed_mps: float = 12.0
    """No ball runs faster (the simulator's fastest kick is 10 m/s): two refused points
    further apart are taken where their rays pass nearest the track (``_restarted``), a
    restart's way faster than this tells no speed (``_fly_from``), and one robot's point
    that would roll the track faster is refused (``update``)."""
    min_way_s: float = 0.05
    """A restart's velocity is taken from a way at least this long (see ``_fly_from``)."""
    restart_way_s: tuple[float, float] = (0.02, 0.1)
    """A restart at crossed rays shortly after another (its way this many seconds, [min,
    max)) takes the speed of the way from that one's point when the last accepted
    measurement is nearer than ``min_way_s``: both are after the manoeuvre that refused
    them, and each is a few centimetres off, where a far robot's ground point taken
    between them may be a metre out along its ray."""
    short_way_vz_sigma_mps: float = 4.0
    """The sigma of vz at a restart from a way shorter than ``min_way_s``."""
    top_m: float = 3.5
    """No ball flies higher (a lob's apex is at most 3 m): a flight above it is given up."""
    lost_sigma_m: float = 0.5
    """A flying track that refused ``max_misses`` rays in a row: its position's sigma is
    widened by this, its velocity made unknown, and it takes the next ray; a restart's
    point after a way faster than ``max_speed_mps`` is widened by this too."""
