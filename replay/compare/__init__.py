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

from replay.compare.bootstrap import METRICS, MetricResult, compare_logs
from replay.compare.load import ResultsRun, read_run
from replay.compare.pairing import PairedLog, pair_runs
from replay.compare.report import Report

__all__ = ["METRICS", "MetricResult", "PairedLog", "Report", "ResultsRun", "compare",
           "compare_logs", "pair_runs", "read_run"]


def compare(a: Path, b: Path, *, replicates: int = 1000, seed: int = 0,
            allow_different_logs: bool = False) -> Report:
    """Read, pair and compare run ``a`` (a results file or folder) with run ``b``."""
    runs_a, runs_b = read_run(Path(a)), read_run(Path(b))
    pairs, left = pair_runs(runs_a, runs_b, a_name=str(a), b_name=str(b),
                            allow_different_logs=allow_different_logs)
    results = compare_logs(pairs, replicates=replicates, seed=seed)
    return Report(str(a), str(b), runs_a, runs_b, pairs, results, left, replicates, seed)
