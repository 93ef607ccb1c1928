"""The lobs suite's tracker scores: the ``ballistic`` fusion's steps (the tracker fed with
each step's triangulated point, in the replay), scored in flight and on where it predicts
the ball lands, 0.3 s ahead.

The true landings come from the log's truth at its own rate (240 Hz on
``/ground_truth/ball/odometry``): a landing is the first sample back within
:data:`LANDED_WITHIN_M` of the ball's radius after the ball flew higher than
``flight_above_m``. The prediction scored is the one the tracker made at its last step at
or before :data:`LEAD_S` before the landing (the lead is reported: at 10 Hz cameras it is
0.3-0.4 s).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from estimator.constants import BALL_RADIUS_M, NS_PER_S
from replay.log import LogReader
from replay.log.messages import TruthMessage

__all__ = ["LANDED_WITHIN_M", "LEAD_S", "TrackScore", "score_track", "true_landings"]

LEAD_S = 0.3
LANDED_WITHIN_M = 0.005


@dataclass
class TrackScore:
    flight_3d: list[float] = field(default_factory=list)
    """The tracker's 3-D error at the steps in flight that two robots saw."""
    flight_z: list[float] = field(default_factory=list)
    """|z - z_true| at those steps (the free-running rule, :mod:`replay.evaluate.lobs_free`)."""
    flight_steps: int = 0
    """Steps in flight (the free-running rule: seen by two robots or not)."""
    landing_errors: list[float] = field(default_factory=list)
    landing_leads_s: list[float] = field(default_factory=list)
    landings: int = 0
    """True landings in the log (some have no prediction: the ball was not seen flying)."""

    def add(self, other: TrackScore) -> None:
        self.flight_3d += other.flight_3d
        self.flight_z += other.flight_z
        self.flight_steps += other.flight_steps
        self.landing_errors += other.landing_errors
        self.landing_leads_s += other.landing_leads_s
        self.landings += other.landings


def true_landings(log: Path, flight_above_m: float) -> list[tuple[int, float, float]]:
    """(stamp, x, y) of every landing in the log's truth."""
    out: list[tuple[int, float, float]] = []
    flying = False
    with LogReader(log) as reader:
        for msg in reader.messages():
            if not isinstance(msg, TruthMessage) or msg.z_m is None:
                continue
            if msg.z_m > flight_above_m:
                flying = True
            elif flying and msg.z_m - BALL_RADIUS_M <= LANDED_WITHIN_M:
                out.append((msg.stamp_ns, msg.x_m, msg.y_m))
                flying = False
    return out


def score_track(steps: Sequence[dict[str, Any]], landings: Sequence[tuple[int, float, float]],
                flight_above_m: float) -> TrackScore:
    """Score the ``ballistic`` fusion's steps (results-file form, in order): the 3-D error
    at the steps in flight whose point came from crossed rays, and each true landing's
    prediction made :data:`LEAD_S` or more before it."""
    predictions: list[tuple[int, dict[str, Any] | None]] = []
    score = TrackScore(landings=len(landings))
    for s in steps:
        if s.get("z_m") is None:
            continue
        predictions.append((int(s["stamp_ns"]), s.get("landing")))
        z_true = s.get("truth_z_m")
        if (z_true is not None and z_true > flight_above_m and s.get("triangulated")
                and s.get("error_3d_m") is not None):
            score.flight_3d.append(float(s["error_3d_m"]))
    for t_land, lx, ly in landings:
        before = [(t, p) for t, p in predictions if t <= t_land - LEAD_S * NS_PER_S]
        if not before or before[-1][1] is None:
            continue
        t, p = before[-1]
        assert p is not None
        score.landing_errors.append(math.hypot(float(p["x_m"]) - lx, float(p["y_m"]) - ly))
        score.landing_leads_s.append((t_land - t) / NS_PER_S)
    return score
