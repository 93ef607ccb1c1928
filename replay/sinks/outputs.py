"""The sinks a replay's options ask for, opened in one :class:`contextlib.ExitStack`.

``--out`` the results JSON (:mod:`replay.sinks.results`), ``--out-mcap`` the estimates as
MCAP (:mod:`replay.sinks.estimates_mcap`), ``--out-csv`` (:mod:`replay.sinks.csv_export`),
``--plot`` (:mod:`replay.sinks.plot`) and a Rerun target (:mod:`replay.sinks.rerun.sink`).
What a replay does not ask for is not imported (rerun-sdk, matplotlib).
"""

from __future__ import annotations

import contextlib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from dsp.field import DEFAULT_FIELD, FIELDS, FieldSpec
from dsp.jsonio import Json
from replay.log import LogInfo
from replay.options import ReplayOptions
from replay.sink import Sink
from replay.sinks.results import ResultsHeader, ResultsWriter, SummarySource

__all__ = ["OutputContext", "open_outputs"]


@dataclass(frozen=True)
class OutputContext:
    """What the outputs need to know of the replay besides its options."""

    info: LogInfo
    name: str
    """The log's file name (the results file names the log by it alone)."""
    digest: str
    """The log's SHA-256 (hex)."""
    stats: SummarySource
    centres: Mapping[str, tuple[float, float]]
    """Each robot's image centre [px], for the Rerun view."""
    pipeline: dict[str, Json] | None = None
    """What runs, part by part (:class:`replay.profiles.Pipeline`), when made from a profile."""
    field: FieldSpec | None = None
    """The field the replay localises on (the log's or the camera file's,
    :func:`replay.localise.field_for`); None: neither names one (the views draw the paper's)."""

    @property
    def drawn_field(self) -> FieldSpec:
        """The field the views draw."""
        return self.field if self.field is not None else FIELDS[DEFAULT_FIELD]


def open_outputs(stack: contextlib.ExitStack[bool | None], options: ReplayOptions,
                 context: OutputContext) -> list[Sink]:
    """The sinks ``options`` ask for, each entered in ``stack``."""
    info = context.info
    sinks: list[Sink] = []
    if options.out is not None:
        header = ResultsHeader(file=context.name, sha256=context.digest, robots=info.robots,
                               options=options.results_view(), parts=options.parts_view(),
                               pipeline=context.pipeline)
        sinks.append(stack.enter_context(ResultsWriter(
            Path(options.out), header=header, stats=context.stats, force=options.force)))
    if options.out_mcap is not None:
        from replay.sinks.estimates_mcap import McapSink

        sinks.append(stack.enter_context(McapSink(Path(options.out_mcap), force=options.force)))
    if options.out_csv is not None:
        from replay.sinks.csv_export import CsvSink

        sinks.append(stack.enter_context(CsvSink(Path(options.out_csv), force=options.force,
                                                 localised=options.localising)))
    if options.plot is not None:
        from replay.sinks.plot import PlotSink

        field = context.drawn_field
        scenario = info.scenario.name if info.scenario is not None else "log"
        title = f"{scenario}: {options.method} estimator, {options.fusion_method} fusion"
        sinks.append(stack.enter_context(PlotSink(
            Path(options.plot), robots=tuple(info.robots), field=field, title=title,
            force=options.force)))
    if options.rerun is not None:
        from replay.sinks.rerun.sink import RerunSink

        sinks.append(stack.enter_context(RerunSink(
            options.rerun, info=info, digest=context.digest, options=options,
            centres=context.centres, field=context.drawn_field, summary=context.stats)))
        if options.rerun_save is not None:  # viewed live and saved: a second stream
            from replay.options import RerunTarget

            sinks.append(stack.enter_context(RerunSink(
                RerunTarget("save", str(options.rerun_save)), info=info,
                digest=context.digest, options=options, centres=context.centres,
                field=context.drawn_field, summary=context.stats)))
    return sinks
