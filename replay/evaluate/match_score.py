"""Scoring one match's fused steps (:mod:`replay.evaluate.match`): position and velocity
errors, and distractor captures.

A capture is a run of at least :data:`CAPTURE_STEPS` consecutive fused steps whose estimate
is more than :data:`CAPTURE_ERROR_M` from the ball and within :data:`CAPTURE_RADIUS_M` of a
distractor.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["CAPTURE_ERROR_M", "CAPTURE_RADIUS_M", "CAPTURE_STEPS", "Scores", "captures",
           "score_steps"]

CAPTURE_ERROR_M = 0.5
CAPTURE_RADIUS_M = 0.75
CAPTURE_STEPS = 3


@dataclass
class Scores:
    """Pooled errors of one fusion method over steps (and matches)."""

    errors: list[float] = field(default_factory=list)
    velocity_errors: list[float] = field(default_factory=list)
    captures: int = 0
    matches_captured: int = 0
    steps: int = 0
    missing: int = 0
    """Steps with a truth but no estimate."""

    def add(self, other: Scores) -> None:
        self.errors += other.errors
        self.velocity_errors += other.velocity_errors
        self.captures += other.captures
        self.matches_captured += other.matches_captured
        self.steps += other.steps
        self.missing += other.missing

    def stats(self) -> dict[str, Any]:
        e, v = np.array(self.errors), np.array(self.velocity_errors)
        return {
            "steps": self.steps, "estimates": len(e), "missing": self.missing,
            "rmse_m": float(np.sqrt(np.mean(e**2))) if len(e) else None,
            "median_m": float(np.median(e)) if len(e) else None,
            "p95_m": float(np.percentile(e, 95)) if len(e) else None,
            "max_m": float(e.max()) if len(e) else None,
            "velocity_median_m_s": float(np.median(v)) if len(v) else None,
            "velocity_p95_m_s": float(np.percentile(v, 95)) if len(v) else None,
            "captures": self.captures, "matches_captured": self.matches_captured,
        }


def captures(fused: Sequence[dict[str, Any]], distractors: Sequence[tuple[float, float]],
             *, error_m: float = CAPTURE_ERROR_M, radius_m: float = CAPTURE_RADIUS_M,
             steps: int = CAPTURE_STEPS) -> int:
    """Runs of >= ``steps`` consecutive fused steps more than ``error_m`` from the truth and
    within ``radius_m`` of a distractor."""
    runs, run = 0, 0
    for f in fused:
        err = f.get("error_m")
        near = f.get("x_m") is not None and any(
            math.hypot(f["x_m"] - x, f["y_m"] - y) <= radius_m for x, y in distractors)
        if err is not None and err > error_m and near:
            run += 1
            if run == steps:
                runs += 1
        else:
            run = 0
    return runs


def _velocity_error(f: dict[str, Any]) -> float | None:
    if f.get("velocity_error_m_s") is not None:
        return float(f["velocity_error_m_s"])
    v, t = f.get("velocity_m_s"), f.get("truth_velocity_m_s")
    if v is None or t is None:
        return None
    return math.hypot(v[0] - t[0], v[1] - t[1])


def score_steps(fused: list[dict[str, Any]],
                distractors: list[tuple[float, float]]) -> Scores:
    """The scores of one match's fused steps (those with a truth)."""
    s = Scores()
    for f in fused:
        if f.get("truth") is None:
            continue
        s.steps += 1
        if f.get("error_m") is None:
            s.missing += 1
            continue
        s.errors.append(float(f["error_m"]))
        if (ve := _velocity_error(f)) is not None:
            s.velocity_errors.append(ve)
    s.captures = captures(fused, distractors)
    s.matches_captured = int(s.captures > 0)
    return s
