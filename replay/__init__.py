"""Replay an MCAP log offline through the estimator, into Rerun and results files.

``replay(path, options) -> ReplaySummary`` is the one entry point (the ``dsp-replay`` CLI is
a thin wrapper around it); ``LogReader`` streams a log's images, poses and ground truth.
"""

from replay.errors import ReplayError
from replay.reader import LogReader
from replay.runner import ReplayOptions, ReplaySummary, RerunTarget, replay

run = replay
"""Alias: docs/api.md names the entry point ``replay.run``."""

__all__ = ["LogReader", "ReplayError", "ReplayOptions", "ReplaySummary", "RerunTarget", "replay",
           "run"]
