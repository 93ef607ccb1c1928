"""What a replay came to believe of each robot's pose that its log did not state, for the
summary and the results (``summary.learnt``)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from dsp.jsonio import Json
from estimator.tracking.bias import BiasEstimator
from estimator.tracking.pose_noise import PoseNoiseEstimator
from estimator.tracking.tracker import BallTracker

__all__ = ["beliefs", "describe_belief", "learnt_markdown"]


def beliefs(robots: Sequence[str], learnt: PoseNoiseEstimator | None,
            bias: BiasEstimator | None, stated: Mapping[str, tuple[float, float]],
            tracker: BallTracker | None = None) -> dict[str, dict[str, Json]]:
    """Per robot: the pose spread ``learnt`` from the residuals (and how many), the spread its
    log ``stated`` (m, rad) beside it, the ``bias`` corrected by at the end, and the offset
    of its estimates from the others' that the ``tracker``'s velocity filter held at the end
    (:mod:`estimator.tracking.offsets`); robots of which nothing was learnt are left out."""
    out: dict[str, dict[str, Json]] = {}
    offsets = {} if tracker is None else tracker.offsets()
    for robot in robots:
        d: dict[str, Json] = {}
        if learnt is not None and learnt.count(robot):
            s_m, s_t = learnt.sigma(robot)
            d.update(pose_sigma_m=round(s_m, 6), pose_sigma_deg=round(math.degrees(s_t), 6),
                     residuals=learnt.count(robot))
            if robot in stated:  # what the log states, beside what its balls show
                m, t = stated[robot]
                d.update(stated_sigma_m=round(m, 6), stated_sigma_deg=round(math.degrees(t), 6))
        if bias is not None and bias.updates:
            b, _ = bias.bias(robot)
            d.update(bias_x_m=round(float(b[0]), 6), bias_y_m=round(float(b[1]), 6),
                     bias_yaw_deg=round(math.degrees(float(b[2])), 6))
        if robot in offsets:
            d.update(offset_x_m=round(offsets[robot][0], 6),
                     offset_y_m=round(offsets[robot][1], 6))
        if d:
            out[robot] = d
    return out


def _spread(b: Mapping[str, object], m: str, deg: str) -> str:
    return f"{100 * float(str(b[m])):.1f} cm and {float(str(b[deg])):.2f} deg"


def describe_belief(b: Mapping[str, object]) -> str:
    """One robot's learnt pose, in words (:attr:`ReplaySummary.beliefs`)."""
    parts = []
    if "pose_sigma_m" in b:
        parts.append(f"pose off by {_spread(b, 'pose_sigma_m', 'pose_sigma_deg')} (1 sigma, "
                     f"from {b['residuals']} residuals)")
    if "line_sigma_m" in b:
        parts.append(f"its belief off by {_spread(b, 'line_sigma_m', 'line_sigma_deg')} as "
                     f"its line fits show (1 sigma, from {b['line_fits']} fits)")
    if "stated_sigma_m" in b:
        parts.append(f"the log states {_spread(b, 'stated_sigma_m', 'stated_sigma_deg')}")
    if "bias_x_m" in b:
        parts.append(f"corrected by ({100 * float(str(b['bias_x_m'])):+.1f}, "
                     f"{100 * float(str(b['bias_y_m'])):+.1f}) cm, "
                     f"{float(str(b['bias_yaw_deg'])):+.2f} deg at the end")
    if "offset_x_m" in b:
        parts.append(f"its ball ({100 * float(str(b['offset_x_m'])):+.1f}, "
                     f"{100 * float(str(b['offset_y_m'])):+.1f}) cm from the others' at the end")
    return "; ".join(parts)


def learnt_markdown(robots: Sequence[str], learnt: Mapping[str, Mapping[str, object]] | None
                    ) -> str:
    """What the replay came to believe of each robot's pose (``summary.learnt``), as the
    Markdown the Rerun recording shows at ``/summary/learnt``."""
    head = ("# What the replay learnt\n\nOf each robot's pose, what its log did not state, "
            "estimated as the log replayed (the results' `summary.learnt`).\n\n")
    rows = [f"- **{r}**: {describe_belief(learnt[r])}" for r in robots
            if learnt is not None and r in learnt]
    return head + ("\n".join(rows) if rows else "Nothing was learnt of any robot's pose "
                   "in this replay.") + "\n"
