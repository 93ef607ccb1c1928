"""``dsp-compare --plot``: each metric's paired per-log difference B - A with its interval."""

from __future__ import annotations

from pathlib import Path

from dsp import plotting
from replay.compare.bootstrap import METRICS
from replay.compare.report import Report

__all__ = ["draw"]


def draw(report: Report, path: Path, fmt: str = "png") -> None:
    """One panel per metric that both runs have: a point per log (and the total) at B - A,
    the bar its interval, green when better, red when worse, grey otherwise."""
    metrics = [m for m in METRICS if report.total[m.key].diff is not None]
    names = [p.log for p in report.pairs] + ["total"]
    fig, axes = plotting.figure(max(6.0, 0.45 * len(names) + 2), 2.2 * max(1, len(metrics)),
                                nrows=max(1, len(metrics)), squeeze=False)
    colours = {"better": "tab:green", "worse": "tab:red"}
    for ax, m in zip(axes[:, 0], metrics, strict=False):
        for x, res in enumerate(report.results):
            r = res[m.key]
            if r.diff is None:
                continue
            lo, hi = r.ci if r.ci is not None else (r.diff, r.diff)
            ax.errorbar([x], [r.diff], yerr=[[r.diff - lo], [hi - r.diff]], fmt="o",
                        color=colours.get(r.verdict, "tab:gray"), capsize=3)
        ax.axhline(0.0, color="black", linewidth=0.8)
        ax.set_ylabel(f"B - A\n{m.label}", fontsize=8)
        ax.set_xticks(range(len(names)))
        ax.set_xticklabels(names if ax is axes[len(metrics) - 1, 0] else [], rotation=60,
                           ha="right", fontsize=7)
    axes[0, 0].set_title(f"B = {report.b_name} against A = {report.a_name}: per-log "
                         "differences, 95% intervals", fontsize=9)
    plotting.save(fig, path, fmt=fmt)
