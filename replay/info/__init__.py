"""``dsp-info``: what a log holds and whether it is intact (:mod:`replay.info.summary`), and
its thin command (:mod:`replay.info.cli`)."""

from __future__ import annotations

from replay.info.summary import LogSummary, TopicInfo, format_info, log_info

__all__ = ["LogSummary", "TopicInfo", "format_info", "log_info"]
