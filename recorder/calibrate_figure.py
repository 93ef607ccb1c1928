"""The calibration figure, like the paper's Fig. 10: range against pixel radius.

Top: the samples (one marker per direction), every fitted model, the paper's eq. 4 line,
and the paper's own procedure (a line through the forward samples) written out as an
equation with its R^2, as Fig. 10 prints it. Bottom: the best model's residuals per
direction, which show what a line misses on a non-linear lens. Drawn with matplotlib
(:mod:`dsp.plotting`); ticks are matplotlib's, so they fall on round numbers.
"""

from __future__ import annotations

import io
import math
from typing import Any

import numpy as np

from dsp.plotting import figure, save
from estimator.calibration import PAPER_CALIBRATION, ranges_m
from estimator.constants import PAPER_B_M, PAPER_K_M_PER_PX, PAPER_R2
from recorder.calibrate import CalibrationRun

__all__ = ["calibration_figure", "plot_png"]

_DIRECTION_COLOURS = ("#1f5fbf", "#d95f02", "#1b9e77", "#7570b3", "#a6761d", "#666666")
_MODEL_STYLES = {"linear": "--", "mirror": "-", "lookup": ":"}


def _line_label(a: float, b: float, r2: float, who: str) -> str:
    sign = "+" if b >= 0 else "-"
    return f"{who}: d = {a:.4f} r {sign} {abs(b):.4f}  (R² = {r2:.4f})"


def calibration_figure(run: CalibrationRun) -> Any:
    """The figure (a :class:`matplotlib.figure.Figure`) of a calibration run."""
    fig, (top, bottom) = figure(7.5, 6.5, nrows=2, sharex=True, height_ratios=[2.2, 1.0])
    ok = [s for s in run.samples if math.isfinite(s.r_px)]
    directions = sorted({s.direction_deg for s in run.samples})
    best = run.best.model
    for i, direction in enumerate(directions):
        colour = _DIRECTION_COLOURS[i % len(_DIRECTION_COLOURS)]
        pts = [s for s in ok if s.direction_deg == direction]
        r = np.array([s.r_px for s in pts])
        d = np.array([s.range_m for s in pts])
        top.plot(r, d, "o", ms=3.0, color=colour, alpha=0.8, label=f"samples, {direction:g}°")
        bottom.plot(r, d - ranges_m(best, r), "o", ms=3.0, color=colour, alpha=0.8)
    r_max = max((s.r_px for s in ok), default=1.0) * 1.05
    d_max = max((s.range_m for s in ok), default=1.0) * 1.1
    grid = np.linspace(0.0, r_max, 400)
    top.plot(grid, ranges_m(PAPER_CALIBRATION, grid), color="black", lw=1.0,
             label=_line_label(PAPER_K_M_PER_PX, PAPER_B_M, PAPER_R2, "paper eq. 4"))
    pp = run.paper_procedure
    a, b = getattr(pp.model, "a_m_per_px", math.nan), getattr(pp.model, "b_m", math.nan)
    top.plot(grid, ranges_m(pp.model, grid), color="#c00000", lw=1.2, ls="-.",
             label=_line_label(a, b, pp.r2, "ours, the paper's procedure"))
    for fit in run.fits:
        name = fit.model.name
        top.plot(grid, ranges_m(fit.model, grid), color="#444444", lw=1.0,
                 ls=_MODEL_STYLES.get(name, "-"),
                 label=f"{name} fit (RMS {fit.rms_m:.3f} m, held-out "
                 f"{run.holdout_rms_m[name]:.3f} m)" + (", best" if fit is run.best else ""))
    top.set_xlim(0.0, r_max)
    top.set_ylim(0.0, d_max)
    top.set_ylabel("range d [m]")
    top.grid(True, lw=0.4, alpha=0.5)
    top.legend(loc="upper left", fontsize="x-small", frameon=False)
    top.set_title(f"camera {run.camera.get('model', '?')}: range against pixel radius",
                  fontsize="medium")
    bottom.axhline(0.0, color="#888888", lw=0.8)
    bottom.set_xlabel("pixel radius r [px]")
    bottom.set_ylabel("residual [m]")
    bottom.grid(True, lw=0.4, alpha=0.5)
    bottom.set_title(f"residuals of the best model ({best.name})", fontsize="small")
    return fig


def plot_png(run: CalibrationRun) -> bytes:
    """:func:`calibration_figure` as PNG bytes (no varying metadata: same run, same bytes)."""
    buf = io.BytesIO()
    save(calibration_figure(run), buf, fmt="png")
    return buf.getvalue()
