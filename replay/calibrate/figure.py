"""The residual figure of a real camera's calibration: range against pixel radius per robot,
every fitted model, and the best model's residuals (what it leaves unexplained)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from dsp.plotting import figure
from estimator.calibration import ranges_m
from replay.calibrate.fit import CameraFit

__all__ = ["measured_figure"]

_COLOURS = ("#1f5fbf", "#d95f02", "#1b9e77", "#7570b3", "#a6761d", "#666666")
_STYLES = {"linear": "--", "mirror": "-", "lookup": ":"}


def _held(fit: Any) -> str:
    return "-" if fit.holdout_rms_m is None else f"{fit.holdout_rms_m:.3f} m"


def measured_figure(cameras: Sequence[CameraFit], source: str) -> Any:
    """The figure (a :class:`matplotlib.figure.Figure`) of the fitted cameras."""
    fig, (top, bottom) = figure(7.5, 6.5, nrows=2, sharex=True, height_ratios=[2.2, 1.0])
    r_max = max(max(c.r_px) for c in cameras) * 1.05
    grid = np.linspace(0.0, r_max, 400)
    for i, cam in enumerate(cameras):
        colour = _COLOURS[i % len(_COLOURS)]
        r, d = np.array(cam.r_px), np.array(cam.range_m)
        top.plot(r, d, "o", ms=3.0, color=colour, alpha=0.8, label=f"{cam.robot}: samples")
        for fit in cam.fits:
            name = fit.model.name
            top.plot(grid, ranges_m(fit.model, grid), color=colour, lw=1.0,
                     ls=_STYLES.get(name, "-"), alpha=1.0 if fit is cam.best else 0.45,
                     label=f"{cam.robot}: {name} (held-out {_held(fit)})"
                     + (", best" if fit is cam.best else ""))
        bottom.plot(r, d - ranges_m(cam.best.model, r), "o", ms=3.0, color=colour, alpha=0.8,
                    label=f"{cam.robot}: {cam.best.model.name}, RMS {cam.best.rms_m:.3f} m")
    top.set_xlim(0.0, r_max)
    top.set_ylim(0.0, max(max(c.range_m) for c in cameras) * 1.1)
    top.set_ylabel("range d [m]")
    top.grid(True, lw=0.4, alpha=0.5)
    top.legend(loc="upper left", fontsize="x-small", frameon=False)
    top.set_title(f"calibration from {source}: range against pixel radius", fontsize="medium")
    bottom.axhline(0.0, color="#888888", lw=0.8)
    bottom.set_xlabel("pixel radius r [px] (about the fitted centre)")
    bottom.set_ylabel("residual [m]")
    bottom.grid(True, lw=0.4, alpha=0.5)
    bottom.legend(loc="upper left", fontsize="x-small", frameon=False)
    residuals = np.concatenate([np.array(c.range_m) - ranges_m(c.best.model, np.array(c.r_px))
                                for c in cameras])
    finite = residuals[np.isfinite(residuals)]
    worst = float(np.max(np.abs(finite))) if finite.size else math.nan
    bottom.set_title(f"residuals of each robot's best model (largest {worst:.3f} m)",
                     fontsize="small")
    return fig
