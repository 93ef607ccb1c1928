"""Where a replay's frames and steps go: every output is a :class:`~replay.sink.Sink`.

- :mod:`replay.sinks.results_json`: the results file's form of the records;
  :mod:`replay.sinks.results`: :class:`ResultsWriter` (``--out``) and
  :class:`ResultsCollector` (the same lists in memory, for ``dsp-eval``);
- :mod:`replay.sinks.estimates_mcap`: the estimates as ROS 2 MCAP (``--out-mcap``);
- :mod:`replay.sinks.csv_export`: the estimates as CSV (``--out-csv``);
- :mod:`replay.sinks.trace`, :mod:`replay.sinks.figure`, :mod:`replay.sinks.plot`: the
  replay figure (``--plot``); :mod:`replay.sinks.style`: colours and sizes it shares with
  the Rerun view;
- :mod:`replay.sinks.rerun`: the Rerun recording, its layouts and live viewing;
- :mod:`replay.sinks.outputs`: the sinks the options ask for, opened together.

Sinks read the records (:mod:`replay.records`) and the log's description; nothing in the
log reader (:mod:`replay.log`) imports them.
"""

from __future__ import annotations

from replay.sinks.outputs import OutputContext, open_outputs
from replay.sinks.results import ResultsCollector, ResultsHeader, ResultsWriter, SummarySource
from replay.sinks.results_json import DECIMALS, frame_to_dict, normalise, step_to_dict

__all__ = [
    "DECIMALS",
    "OutputContext",
    "ResultsCollector",
    "ResultsHeader",
    "ResultsWriter",
    "SummarySource",
    "frame_to_dict",
    "normalise",
    "open_outputs",
    "step_to_dict",
]
