"""A kick the gate missed: accepted estimates that all lean one way.

The gate refuses an estimate far off the track, and a refused one may explain a kick. A
kick whose estimates stay inside the gate (a ball that starts slowly, robots whose pose
uncertainty widens the gate) is accepted estimate by estimate while the track falls
behind: each innovation is within its noise, but they all point the same way, and the
constant-velocity filter takes a second or more to catch up. The test, on the last
``count`` accepted estimates (a manoeuvre detector on the innovations' mean): each
innovation whitened by its covariance, nu_i' = L_i^-1 (z_i - x_i^-), S_i = L_i L_i^T; a
kick is tried before the first of them when the length of their mean, times
sqrt(``count``), exceeds ``sigma`` (``count`` white innovations reach it with probability
exp(-sigma^2 / 2): 1 in 90 at 3). The track is re-run with the kick,
which is kept when every one of them is still accepted and their summed squared
innovations fall to at most ``keep_ratio`` of what they were; else it is taken back.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Protocol

import numpy as np

from estimator.tracking.model import Gaussian, Matrix

__all__ = ["Leaning", "lean_kick"]


class Leaning(Protocol):
    """What the test reads of a tracker's entry, and the kick it sets."""

    accepted: bool
    kick: bool
    prior: Gaussian | None
    z: Matrix
    r: Matrix


def _whitened(e: Leaning) -> Matrix:
    assert e.prior is not None
    x, p = e.prior
    return np.asarray(np.linalg.solve(np.linalg.cholesky(p[:2, :2] + e.r), e.z - x[:2]))


def _squared(whitened: Sequence[Matrix]) -> float:
    return sum(float(v @ v) for v in whitened)


def lean_kick(entries: Sequence[Leaning], rerun: Callable[[int], None], *, count: int,
              sigma: float, keep_ratio: float) -> bool:
    """Try a kick before the last ``count`` accepted ``entries`` when they lean one way
    (module docstring); ``rerun(i)`` re-runs the track from ``entries[i]``. True when the
    kick was kept."""
    last = [e for e in entries if e.accepted][-count:]
    if len(last) < count or any(e.kick for e in last):
        return False
    whitened = [_whitened(e) for e in last]
    mean = np.mean(whitened, axis=0)
    if float(np.hypot(mean[0], mean[1])) * math.sqrt(count) < sigma:
        return False
    before = _squared(whitened)
    i = next(j for j, e in enumerate(entries) if e is last[0])
    last[0].kick = True
    rerun(i)
    if all(e.accepted for e in last) and (
            _squared([_whitened(e) for e in last]) <= keep_ratio * before):
        return True
    last[0].kick = False
    rerun(i)
    return False
