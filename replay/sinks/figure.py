"""The replay figure (``dsp-replay --plot``): error over time, and the track seen from above.

Left: each robot's error and the fused error against the ground truth over sim time; a
line breaks where there is no estimate (a point alone is a marker). Right: the field from
above with the true ball's path, the fused estimates, each robot's own estimates and the
robots' footprints where they first stood. Drawn with matplotlib (:mod:`dsp.plotting`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from dsp.field import polylines
from dsp.plotting import figure
from replay.sinks.style import (
    FUSED_COLOUR,
    ROBOT_FOOTPRINT_M,
    footprint,
    hex_colour,
    robot_colour,
)
from replay.sinks.trace import ReplayTrace

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["replay_figure"]

_TRUTH_DARK = "#8a7a00"
"""The truth's yellow is for the grass of the viewer; on paper a darker olive reads."""


def _errors(ax: Axes, trace: ReplayTrace) -> None:
    for i, robot in enumerate(trace.robots):
        rows = np.array(trace.frames.get(robot) or np.empty((0, 4)), dtype=float).reshape(-1, 4)
        ax.plot(rows[:, 0], rows[:, 1], "-o", ms=2.5, lw=1.0, label=robot,
                color=hex_colour(robot_colour(i)))
    fused = np.array(trace.fused or np.empty((0, 4)), dtype=float).reshape(-1, 4)
    ax.plot(fused[:, 0], fused[:, 1], "-o", ms=3.0, lw=1.8, label="fused",
            color=hex_colour(FUSED_COLOUR))
    ax.set_xlabel("sim time [s]")
    ax.set_ylabel("error vs ground truth [m]")
    ax.set_ylim(bottom=0.0)
    ax.grid(True, lw=0.4, alpha=0.5)
    ax.legend(loc="upper right", fontsize="small", frameon=False)
    ax.set_title("error over time", fontsize="medium")


def _field(ax: Axes, trace: ReplayTrace) -> None:
    spec = trace.field
    for line in polylines(spec):
        xy = np.array(line)
        ax.plot(xy[:, 0], xy[:, 1], color="#9a9a9a", lw=0.8, zorder=1)
    for i, robot in enumerate(trace.robots):
        colour = hex_colour(robot_colour(i))
        poses = trace.poses.get(robot) or []
        if poses:
            x, y, yaw = poses[0]
            fp = np.array(footprint(x, y, yaw))
            ax.fill(fp[:, 0], fp[:, 1], color=colour, alpha=0.35, lw=0, zorder=2)
            ax.plot(fp[:, 0], fp[:, 1], color=colour, lw=1.0, zorder=2)
            ax.annotate("", xy=(x + ROBOT_FOOTPRINT_M * math.cos(yaw),
                                y + ROBOT_FOOTPRINT_M * math.sin(yaw)),
                        xytext=(x, y), arrowprops={"arrowstyle": "->", "color": colour},
                        zorder=3)
        rows = np.array(trace.frames.get(robot) or np.empty((0, 4)), dtype=float).reshape(-1, 4)
        ax.plot(rows[:, 2], rows[:, 3], "o", ms=2.0, color=colour, alpha=0.6, zorder=3,
                label=f"{robot}'s estimates")
    if trace.truth:
        t = np.array(trace.truth)
        ax.plot(t[:, 0], t[:, 1], "--", color=_TRUTH_DARK, lw=1.3, zorder=6, label="true ball")
    fused = np.array(trace.fused or np.empty((0, 4)), dtype=float).reshape(-1, 4)
    ax.plot(fused[:, 2], fused[:, 3], "-o", ms=2.5, lw=1.0, color=hex_colour(FUSED_COLOUR),
            zorder=5, label="fused")
    half_l = spec.half_length_m + spec.border_m
    half_w = spec.half_width_m + spec.border_m
    ax.set_xlim(-half_l, half_l)
    ax.set_ylim(-half_w, half_w)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(loc="upper left", fontsize="x-small", frameon=True, framealpha=0.8)
    ax.set_title(f"top-down ({spec.name} field)", fontsize="medium")


def replay_figure(trace: ReplayTrace) -> Figure:
    """The figure of a replay (a :class:`matplotlib.figure.Figure`)."""
    fig, (left, right) = figure(11.0, 4.4, ncols=2, width_ratios=[1.0, 1.35])
    _errors(left, trace)
    _field(right, trace)
    fig.suptitle(trace.title, fontsize="medium")
    return fig
