"""Replay an MCAP log offline through the estimator, into Rerun and results files.

``replay(path, options) -> ReplaySummary`` is the one entry point (the ``dsp-replay`` CLI is
a thin wrapper around it); ``LogReader`` streams a log's images, poses and ground truth.
docs/api.md maps the modules and how a frame flows from the reader to the sinks.
"""

from replay.errors import ReplayError
from replay.log import LogReader
from replay.options import ReplayOptions, RerunTarget
from replay.runner import replay
from replay.sink import Sink, SinkBase
from replay.stats import ReplaySummary

__all__ = ["LogReader", "ReplayError", "ReplayOptions", "ReplaySummary", "RerunTarget", "Sink",
           "SinkBase", "replay"]
