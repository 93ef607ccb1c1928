"""The lobs suite with free-running cameras (``--camera-phase random``): what it scores.

Free-running cameras fire each at its own phase, so no two images share a stamp and no two
rays of one instant cross: ``triangulate`` places nothing in flight, and the ground-plane
rows beside it have no steps to stand on. The ``ballistic`` fusion takes each image's ray
at its own stamp; it is scored at every step whose ball is truly in flight (centre above
``flight_above_m``) and that two or more robots saw within the last camera period
(:data:`SEEN_WITHIN_NS`: one image each, at their own stamps), against the 3-D truth at the
step's stamp, and on its landings 0.3 s ahead (:mod:`replay.evaluate.lobs_track`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from replay.evaluate.lobs_track import TrackScore, score_track

__all__ = ["FREE_RUNNING_RULE", "FREE_RUNNING_WHY", "SEEN_WITHIN_NS", "score_free_running"]

SEEN_WITHIN_NS = 100_000_000
"""A step counts when two or more robots saw the ball within this before it [ns]."""

FREE_RUNNING_RULE = (
    "the ballistic fusion's steps in flight (z > {above:g} m) that two or more robots saw "
    "within the last 0.1 s (each image's ray at its own stamp), against the 3-D truth at "
    "the step's stamp; landings predicted 0.3 s ahead")
FREE_RUNNING_WHY = (
    "free-running cameras never give two rays of one instant, so triangulate crosses none: "
    "its rows (and the ground-plane fusion on them) would be empty")


def _robots_within(seen: Sequence[tuple[int, str]], stamp_ns: int) -> int:
    return len({robot for t, robot in seen if stamp_ns - SEEN_WITHIN_NS < t <= stamp_ns})


def score_free_running(steps: Sequence[dict[str, Any]], frames: Sequence[dict[str, Any]],
                       landings: Sequence[tuple[int, float, float]],
                       flight_above_m: float) -> TrackScore:
    """Score the ``ballistic`` fusion's steps (results-file form, in order) by the
    free-running rule: ``flight_3d`` and ``flight_z`` hold the errors of the steps in
    flight that two or more robots saw (a frame with status ``ok``) within the last
    :data:`SEEN_WITHIN_NS`; ``flight_steps`` counts every step in flight; the landings are
    :func:`~replay.evaluate.lobs_track.score_track`'s."""
    seen = [(int(f["stamp_ns"]), str(f["robot"])) for f in frames if f["status"] == "ok"]
    score = score_track(steps, landings, flight_above_m)
    score.flight_3d = []
    for s in steps:
        z_true = s.get("truth_z_m")
        if z_true is None or z_true <= flight_above_m:
            continue
        score.flight_steps += 1
        if s.get("error_3d_m") is None or s.get("z_m") is None:
            continue
        if _robots_within(seen, int(s["stamp_ns"])) >= 2:
            score.flight_3d.append(float(s["error_3d_m"]))
            score.flight_z.append(abs(float(s["z_m"]) - float(z_true)))
    return score
