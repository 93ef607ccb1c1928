"""The summary of a batch replay: one row per log and the totals, as JSON, CSV and Markdown.

Rows come in the batch's log order and hold nothing machine dependent (file names, counts,
errors from the data; no timings, no worker names), so the three files are the same bytes
whatever the worker count or the order the logs finish in. Totals are recomputed from the
rows' sums (an RMSE over all logs is ``sqrt(sum of squares / errors)``, not a mean of RMSEs).
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass, field

from dsp.jsonio import Json
from replay.sinks.results_json import normalise

__all__ = ["FORMAT", "BatchSummary", "ErrorSums", "LogRow"]

FORMAT = "dsp-replay-batch"
VERSION = 1


@dataclass(frozen=True)
class ErrorSums:
    """Counts and the sums an RMSE is made of, for one robot (or the fused estimate)."""

    frames: int = 0
    detections: int = 0
    estimates: int = 0
    errors: int = 0
    sum_sq_m2: float = 0.0

    @property
    def rmse_m(self) -> float | None:
        return math.sqrt(self.sum_sq_m2 / self.errors) if self.errors else None

    def __add__(self, other: ErrorSums) -> ErrorSums:
        return ErrorSums(self.frames + other.frames, self.detections + other.detections,
                         self.estimates + other.estimates, self.errors + other.errors,
                         self.sum_sq_m2 + other.sum_sq_m2)

    def to_dict(self, *, fused: bool = False) -> dict[str, Json]:
        if fused:
            return {"estimates": self.estimates, "errors": self.errors, "rmse_m": self.rmse_m}
        return {"frames": self.frames, "detections": self.detections,
                "estimates": self.estimates, "errors": self.errors, "rmse_m": self.rmse_m}


@dataclass(frozen=True)
class LogRow:
    """One log of the batch: its counts, or the one-line error it failed with."""

    log: str
    """The log's file name."""
    error: str | None = None
    frames: int = 0
    steps: int = 0
    robots: dict[str, ErrorSums] = field(default_factory=dict)
    fused: ErrorSums = field(default_factory=ErrorSums)
    warnings: tuple[str, ...] = ()
    """The replay's warnings (printed by the command, not in the summary files)."""

    @property
    def ok(self) -> bool:
        return self.error is None

    @property
    def detections(self) -> int:
        return sum(r.detections for r in self.robots.values())

    def to_dict(self) -> dict[str, Json]:
        return {"log": self.log, "ok": self.ok, "error": self.error, "frames": self.frames,
                "steps": self.steps, "fused_steps": self.fused.estimates,
                "detections": self.detections,
                "robots": {r: s.to_dict() for r, s in self.robots.items()},
                "fused": self.fused.to_dict(fused=True)}


@dataclass(frozen=True)
class BatchSummary:
    rows: tuple[LogRow, ...]
    options: dict[str, Json]
    """The replay options that shape the results (``ReplayOptions.results_view``)."""

    @property
    def failed(self) -> tuple[LogRow, ...]:
        return tuple(r for r in self.rows if not r.ok)

    @property
    def robots(self) -> list[str]:
        return sorted({name for r in self.rows for name in r.robots})

    def totals(self) -> LogRow:
        """The sum of the logs that replayed (``log`` = "total")."""
        robots: dict[str, ErrorSums] = {}
        fused = ErrorSums()
        for row in self.rows:
            for name, sums in row.robots.items():
                robots[name] = robots.get(name, ErrorSums()) + sums
            fused = fused + row.fused
        return LogRow("total", None, sum(r.frames for r in self.rows),
                      sum(r.steps for r in self.rows), dict(sorted(robots.items())), fused)

    def to_json(self) -> str:
        totals = {**self.totals().to_dict(), "logs": len(self.rows),
                  "failed": len(self.failed)}
        for key in ("log", "ok", "error"):
            del totals[key]
        doc = {"format": FORMAT, "version": VERSION, "options": self.options,
               "logs": [r.to_dict() for r in self.rows], "totals": totals}
        return json.dumps(normalise(doc), sort_keys=True, indent=2, allow_nan=False) + "\n"

    def _table(self) -> tuple[list[str], list[list[str]]]:
        robots = self.robots
        header = ["log", "status", "frames", "steps", "fused_steps", "detections",
                  *(f"{r}_rmse_m" for r in robots), "fused_rmse_m", "error"]
        total_status = f"{len(self.rows) - len(self.failed)}/{len(self.rows)} ok"
        rows = [self._cells(row, "ok" if row.ok else "failed", robots) for row in self.rows]
        rows.append(self._cells(self.totals(), total_status, robots))
        return header, rows

    @staticmethod
    def _cells(row: LogRow, status: str, robots: list[str]) -> list[str]:
        rmse = [row.robots[r].rmse_m if r in row.robots else None for r in robots]
        return [row.log, status, str(row.frames), str(row.steps), str(row.fused.estimates),
                str(row.detections), *(_num(v) for v in [*rmse, row.fused.rmse_m]),
                row.error or ""]

    def to_csv(self) -> str:
        header, rows = self._table()
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(header)
        writer.writerows(rows)
        return buf.getvalue()

    def to_markdown(self) -> str:
        header, rows = self._table()
        lines = [f"Batch replay of {len(self.rows)} logs ({len(self.failed)} failed); "
                 f"method {self.options.get('method')}, fusion {self.options.get('fusion')}. "
                 "RMSE in metres against the logs' ground truth.", "",
                 "| " + " | ".join(header) + " |", "|---" * len(header) + "|"]
        lines += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
        return "\n".join(lines) + "\n"


def _num(v: float | None) -> str:
    n = normalise(v)
    return "" if n is None else repr(n)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ") or "-"

