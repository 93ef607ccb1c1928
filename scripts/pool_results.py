"""The fused errors of several runs over the same logs, pooled, as one Markdown table.

    python scripts/pool_results.py runs/believed runs/lines ...

Each RUN is a folder of ``dsp-replay`` results files (``--out-dir``, or ``--out RUN/X.json``
per log). For every run, over the fused steps with a truth and an estimate (image steps; a
``--clock``'s ticks are left out): the RMSE pooled over all its logs' steps (the root of the
mean squared error, not a mean of RMSEs), each log's RMSE (the logs in name order, numbers
by value), the range of the logs' median errors, the median of the velocity errors over all
steps and its range over the logs.
"""

from __future__ import annotations

import json
import math
import re
import statistics
import sys
from pathlib import Path
from typing import Any


def _steps(path: Path) -> tuple[list[float], list[float]]:
    doc: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    errors, velocity = [], []
    for f in doc["fused"]:
        if f.get("tick") or f.get("error_m") is None:
            continue
        errors.append(float(f["error_m"]))
        if f.get("velocity_error_m_s") is not None:
            velocity.append(float(f["velocity_error_m_s"]))
    return errors, velocity


def _natural(path: Path) -> list[tuple[int, str]]:
    """match-9 before match-10: the numbers in the name compared as numbers."""
    return [(int(t), "") if t.isdigit() else (-1, t) for t in re.split(r"(\d+)", path.name)]


def _rmse(errors: list[float]) -> float:
    return math.sqrt(sum(e * e for e in errors) / len(errors))


def _span(values: list[float], nd: int) -> str:
    return f"{min(values):.{nd}f}-{max(values):.{nd}f}" if values else "-"


def row(run: Path) -> str:
    """One run's table row."""
    logs = sorted((p for p in run.glob("*.json") if not p.name.startswith("batch-summary")),
                  key=_natural)
    if not logs:
        raise SystemExit(f"{run}: no results files (*.json)")
    per_log = [_steps(p) for p in logs]
    errors = [e for errs, _ in per_log for e in errs]
    velocity = [v for _, vel in per_log for v in vel]
    medians = [statistics.median(errs) for errs, _ in per_log if errs]
    vel_medians = [statistics.median(vel) for _, vel in per_log if vel]
    pooled_v = f"{statistics.median(velocity):.3f}" if velocity else "-"
    return (f"| {run.name} | {len(errors)} | {_rmse(errors):.4f} | "
            + ", ".join(f"{_rmse(errs):.4f}" for errs, _ in per_log) + f" | {_span(medians, 4)}"
            + f" | {pooled_v} | {_span(vel_medians, 3)} |")


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__.strip().splitlines()[0], file=sys.stderr)
        return 2
    print("| run | steps | fused RMSE [m] | per log [m] | median per log [m] | "
          "velocity median [m/s] | per log [m/s] |")
    print("|---|---|---|---|---|---|---|")
    for run in argv:
        print(row(Path(run)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
