"""The fixed-interval (Rauch-Tung-Striebel) smoother over a recorded track, for offline use.

The causal tracker (:mod:`estimator.tracking.tracker`) estimates the ball at t from what was seen
up to t. Offline, every estimate of a log is known, and the RTS smoother (Rauch, Tung &
Striebel, AIAA J. 3(8), 1965; Bar-Shalom et al. 2001, sec. 8.6) runs backwards over the
filter's record: with x_f(k), P_f(k) the filtered state at node k and x_p(k+1), P_p(k+1)
the prediction from k to k+1 with its transition F::

    C_k    = P_f(k) F^T P_p(k+1)^-1
    x_s(k) = x_f(k) + C_k (x_s(k+1) - x_p(k+1))
    P_s(k) = P_f(k) + C_k (P_s(k+1) - P_p(k+1)) C_k^T

starting from x_s = x_f at the last node. A kick's inflated covariance sits in P_p(k+1),
so the smoother does not pull a bounce's corner round. Each track segment (from a start
to a loss or a restart) is smoothed on its own.
"""

from __future__ import annotations

import bisect
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from estimator.constants import NS_PER_S
from estimator.tracking.model import Gaussian, predict, transition

__all__ = ["FilterNode", "SmoothedTrack", "rts_smooth"]


@dataclass(frozen=True)
class FilterNode:
    """The filter at one estimate: its prior (the prediction to the stamp; the state itself
    at a track's first node) and its posterior (the prior when the estimate was rejected)."""

    stamp_ns: int
    prior: Gaussian
    posterior: Gaussian
    segment: int
    """Which track segment (0, 1, ... in order) the node belongs to."""


def rts_smooth(nodes: Sequence[FilterNode], friction_per_s: float) -> list[Gaussian]:
    """The smoothed (x, P) at every node of ONE segment, in order (module docstring)."""
    if not nodes:
        return []
    smoothed: list[Gaussian] = [nodes[-1].posterior]
    for k in range(len(nodes) - 2, -1, -1):
        x_f, p_f = nodes[k].posterior
        x_p, p_p = nodes[k + 1].prior
        x_next, p_next = smoothed[-1]
        f = transition((nodes[k + 1].stamp_ns - nodes[k].stamp_ns) / NS_PER_S, friction_per_s)
        c = np.linalg.solve(p_p, f @ p_f).T  # P_f F^T P_p^-1 (P_f, P_p symmetric)
        p_s = p_f + c @ (p_next - p_p) @ c.T
        smoothed.append((x_f + c @ (x_next - x_p), 0.5 * (p_s + p_s.T)))
    smoothed.reverse()
    return smoothed


class SmoothedTrack:
    """Smoothed states of a whole record, looked up by stamp: between nodes, the last
    node's smoothed state predicted (without process noise) to the stamp."""

    def __init__(self, nodes: Sequence[FilterNode], *, friction_per_s: float) -> None:
        self.friction_per_s = friction_per_s
        self._stamps: list[int] = []
        self._states: list[Gaussian] = []
        self._segments: list[int] = []
        start = 0
        for i in range(1, len(nodes) + 1):
            if i == len(nodes) or nodes[i].segment != nodes[start].segment:
                part = nodes[start:i]
                self._stamps += [n.stamp_ns for n in part]
                self._states += rts_smooth(part, friction_per_s)
                self._segments += [n.segment for n in part]
                start = i

    def __len__(self) -> int:
        return len(self._stamps)

    def state_at(self, stamp_ns: int) -> Gaussian | None:
        """The smoothed (x, P) at ``stamp_ns``; None before the first node."""
        i = bisect.bisect_right(self._stamps, stamp_ns) - 1
        if i < 0:
            return None
        x, p = self._states[i]
        x_t, _ = predict((x, p), (stamp_ns - self._stamps[i]) / NS_PER_S, q=0.0,
                         friction_per_s=self.friction_per_s)
        f = transition((stamp_ns - self._stamps[i]) / NS_PER_S, self.friction_per_s)
        return x_t, f @ p @ f.T
