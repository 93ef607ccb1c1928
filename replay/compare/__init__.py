"""``dsp-compare``: two estimator runs of the same logs, paired, with bootstrap intervals.

:func:`compare` is the typed function behind the command (docs/compare.md)::

    report = compare(Path("results-mean"), Path("results-track"))
    print(report.to_markdown())

Rooms: :mod:`~replay.compare.load` (results files read and checked),
:mod:`~replay.compare.pairing` (logs by sha256, frames and steps by stamp),
:mod:`~replay.compare.bootstrap` (the metrics and their intervals),
:mod:`~replay.compare.report` (JSON, CSV, Markdown), :mod:`~replay.compare.figure`
(``--plot``), :mod:`~replay.compare.cli` (the command).
"""

from __future__ import annotations

from pathlib import Path

from dsp.errors import UsageError
from replay.compare.bootstrap import METRICS, MetricResult, compare_logs
from replay.compare.load import ResultsRun, read_run
from replay.compare.pairing import PairedLog, pair_runs
from replay.compare.report import Report

__all__ = ["DEFAULT_REPLICATES", "MAX_RESAMPLED", "METRICS", "MetricResult", "PairedLog",
           "Report", "ResultsRun", "compare", "compare_logs", "pair_runs", "read_run"]

DEFAULT_REPLICATES = 1000
MAX_RESAMPLED = 10_000_000_000
"""The most paired units (steps and frames) drawn over all replicates beyond the default
1000 replicates: about three minutes on one core. 1000 replicates are always allowed (their
work grows with the input, which is capped)."""


def _check_work(pairs: list[PairedLog], replicates: int) -> None:
    units = sum(len(p.error_a) + len(p.detected_a) for p in pairs)
    budget = max(MAX_RESAMPLED, DEFAULT_REPLICATES * units)
    if replicates * units > budget:
        raise UsageError(f"--replicates {replicates} over {units} paired steps and frames is "
                         f"{replicates * units:.3g} draws; give at most {budget // units} here")


def compare(a: Path, b: Path, *, replicates: int = DEFAULT_REPLICATES, seed: int = 0,
            allow_different_logs: bool = False) -> Report:
    """Read, pair and compare run ``a`` (a results file or folder) with run ``b``."""
    runs_a, runs_b = read_run(Path(a)), read_run(Path(b))
    pairs, left = pair_runs(runs_a, runs_b, a_name=str(a), b_name=str(b),
                            allow_different_logs=allow_different_logs)
    _check_work(pairs, replicates)
    results = compare_logs(pairs, replicates=replicates, seed=seed)
    return Report(str(a), str(b), runs_a, runs_b, pairs, results, left, replicates, seed)
