"""Batch replay: many logs, one results file each, and a summary over all of them.

- :mod:`replay.batch.run`: :func:`replay_batch` (``dsp-replay LOG... --out-dir DIR``), one
  task per log on :mod:`replay.parallel`;
- :mod:`replay.batch.summary`: the batch summary as JSON, CSV and Markdown;
- :mod:`replay.batch.cli`: the batch flags of ``dsp-replay`` and its thin command.
"""

from __future__ import annotations

from replay.batch.run import (
    ESTIMATES_SUFFIX,
    SUMMARY_STEM,
    LogTask,
    collect_logs,
    replay_batch,
    replay_log,
)
from replay.batch.summary import BatchSummary, ErrorSums, LogRow

__all__ = [
    "ESTIMATES_SUFFIX",
    "SUMMARY_STEM",
    "BatchSummary",
    "ErrorSums",
    "LogRow",
    "LogTask",
    "collect_logs",
    "replay_batch",
    "replay_log",
]
