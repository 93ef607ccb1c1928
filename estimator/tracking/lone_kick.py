"""Where a lone refused estimate's kick was: just before it, or a frame or two earlier.

When one robot's estimate is refused and nothing corroborates it, the tracker may explain
it by a kick (:class:`~estimator.tracking.BallTracker`, its module docstring). The kick is
tried first just after the last accepted estimate. That is wrong when the first image
after a bounce passed the gate, behind the ball: the track then holds the ball where it
was, the next image is refused, and a kick between the two crosses the centimetres that
separate two robots' estimates in the milliseconds between their images (a ball at
13 m/s). So a kick that makes the ball faster than any ball runs (``max_speed``) is tried
instead before each of the last ``back`` accepted estimates within ``back_ns`` of the
refused one, and the likeliest of those that let every estimate keep its verdict is kept
(the negative log-likelihood of the accepted estimates from the earliest tried on:
d^2 + ln det S each). Found on a foreign log with exact poses and the line fit, where the
fits' small pose covariance let the first image after a bounce pass the gate 10 cm
behind the ball.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Protocol

import numpy as np

from estimator.tracking.model import Gaussian, Matrix, innovation

__all__ = ["LONE_KICK_BACK", "LONE_KICK_BACK_NS", "Kickable", "lone_kick"]

LONE_KICK_BACK = 2
"""How many accepted estimates before a lone refused one its kick may be put before..."""
LONE_KICK_BACK_NS = 100_000_000
"""...within this long of it [ns] (two or three images of each robot at 20-30 Hz)."""


class _Stamped(Protocol):
    @property
    def stamp_ns(self) -> int: ...


class Kickable(Protocol):
    """What the search reads of a tracker's entry, and the kick it sets."""

    @property
    def m(self) -> _Stamped: ...

    accepted: bool
    kick: bool
    state: Gaussian | None
    prior: Gaussian | None
    z: Matrix
    r: Matrix


def lone_kick(entries: Sequence[Kickable], i: int, j: int, rerun: Callable[[int], None], *,
              max_speed: float, back: int = LONE_KICK_BACK,
              back_ns: int = LONE_KICK_BACK_NS) -> bool:
    """Explain the refused ``entries[i]`` by a kick (module docstring); ``j`` is the last
    accepted entry before it, ``rerun(k)`` re-runs the track from ``entries[k]``. True when
    a kick was kept (the track is left re-run with it)."""
    e = entries[i]
    after = _try(entries, j + 1, i, rerun, keep_below=max_speed)
    if after is not None and after[1] <= max_speed:
        return True  # kept by _try
    earlier = [a for a in range(j, 0, -1)
               if entries[a].accepted and not entries[a].kick
               and e.m.stamp_ns - entries[a].m.stamp_ns <= back_ns][:back]
    best: tuple[float, int] | None = None
    for k in earlier:
        tried = _try(entries, k, i, rerun, cost_from=earlier[-1])
        if tried is not None and tried[1] <= max_speed and (best is None or tried[0] < best[0]):
            best = (tried[0], k)
    chosen = best[1] if best is not None else j + 1 if after is not None else None
    if chosen is None:
        return False
    entries[chosen].kick = True
    rerun(chosen)
    return True


def _try(entries: Sequence[Kickable], k: int, i: int, rerun: Callable[[int], None], *,
         cost_from: int | None = None, keep_below: float | None = None
         ) -> tuple[float, float] | None:
    """The track re-run with a kick before entries[k], then taken back unless the ball's
    speed is at most ``keep_below``: (the negative log-likelihood of the accepted
    entries[cost_from:i + 1], 0 without ``cost_from``; the ball's speed after entries[i]);
    None when entries[i] is still refused or an entry between the kick and it changes its
    verdict."""
    verdicts = [f.accepted for f in entries[k:i]]
    was, entries[k].kick = entries[k].kick, True
    rerun(k)
    out = None
    e = entries[i]
    if e.accepted and [f.accepted for f in entries[k:i]] == verdicts:
        cost = 0.0
        for f in entries[i + 1 if cost_from is None else cost_from:i + 1]:
            if f.accepted and f.prior is not None:
                _, s, d2 = innovation(f.prior, f.z, f.r)
                cost += d2 + math.log(float(np.linalg.det(s)))
        assert e.state is not None
        out = (cost, math.hypot(float(e.state[0][2]), float(e.state[0][3])))
        if keep_below is not None and out[1] <= keep_below:
            return out
    entries[k].kick = was
    rerun(k)
    return out
