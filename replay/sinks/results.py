"""Sinks writing the results file (:class:`ResultsWriter`) or keeping its lists in memory
(:class:`ResultsCollector`); the file's form is :mod:`replay.sinks.results_json`.

Frames and fused steps are spooled to temporary files while replaying, so memory stays flat
however long the log; the file is assembled (sorted keys, as :func:`json.dumps` would) and
appears only after a whole replay.
"""

from __future__ import annotations

import contextlib
import io
import json
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any, Protocol

import numpy as np

from dsp.atomic import AtomicFile
from dsp.errors import OutputError
from dsp.jsonio import Json
from replay.log import RecoveryLoss
from replay.records import FrameResult, StepResult
from replay.sink import SinkBase
from replay.sinks.results_json import dumps, frame_to_dict, normalise, step_to_dict

__all__ = ["ResultsCollector", "ResultsHeader", "ResultsWriter", "SummarySource"]


def _rounded(d: dict[str, Json]) -> dict[str, Any]:
    out = normalise(d)
    assert isinstance(out, dict)
    return out


@dataclass(frozen=True)
class ResultsHeader:
    """What the results file says of the log and the options."""

    file: str
    """The log's base name."""
    sha256: str
    robots: tuple[str, ...]
    options: dict[str, Json]
    """:meth:`replay.options.ReplayOptions.results_view`."""
    parts: dict[str, Json] = field(default_factory=dict)
    """The estimator's parts from outside the package (:mod:`replay.plugins`); the key is
    left out when there are none, so files made without them stay as they were."""
    pipeline: dict[str, Json] | None = None
    """What ran, part by part (:meth:`replay.profiles.Pipeline.to_dict`), for a replay made
    from a profile; left out otherwise."""


class ResultsCollector(SinkBase):
    """Sink keeping the results file's ``frames`` and ``fused`` lists in memory, exactly as
    the file would hold them (rounded): for callers that score a replay without writing it."""

    def __init__(self) -> None:
        self.frames: list[dict[str, Any]] = []
        """The frames as the results file holds them (a JSON document's values vary)."""
        self.fused: list[dict[str, Any]] = []

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        self.frames.append(_rounded(frame_to_dict(result)))

    def step(self, result: StepResult) -> None:
        self.fused.append(_rounded(step_to_dict(result)))


class SummarySource(Protocol):
    """What the results header needs from the replay's statistics."""

    @property
    def recovered(self) -> RecoveryLoss | None: ...

    def summary_dict(self) -> dict[str, Json]: ...


def _head(header: ResultsHeader, stats: SummarySource) -> dict[str, Json]:
    recovered = None if stats.recovered is None else stats.recovered.to_dict()
    return {
        "format": "dsp-replay-results", "version": 1,
        "log": {"file": header.file, "sha256": header.sha256, "robots": list(header.robots),
                "recovered": recovered},
        "options": header.options,
        **({"parts": header.parts} if header.parts else {}),
        **({"pipeline": header.pipeline} if header.pipeline is not None else {}),
        "summary": stats.summary_dict(),
    }


class ResultsWriter(SinkBase):
    """Sink writing the results JSON to ``path`` (refuses an existing file unless ``force``);
    frames and steps are spooled to temporary files, so memory stays flat."""

    def __init__(self, path: Path, *, header: ResultsHeader, stats: SummarySource,
                 force: bool = False) -> None:
        self.header = header
        self.stats = stats
        self._out = AtomicFile(path, force=force)
        self._spools: dict[str, IO[str]] = {}
        try:
            for key in ("frames", "fused"):
                self._spools[key] = tempfile.TemporaryFile("w+", encoding="ascii")
        except OSError as err:  # no temporary folder with room: a full disk
            self.close(ok=False)
            raise OutputError(path, f"no room for its temporary files ({err.strerror or err})"
                              ) from err
        self._counts = dict.fromkeys(self._spools, 0)

    def _spool(self, key: str, item: dict[str, Json]) -> None:
        f = self._spools[key]
        with self._out.guard():  # the spool's folder full: one line naming the results file
            f.write(("  " if self._counts[key] == 0 else ",\n  ") + dumps(item))
        self._counts[key] += 1

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        self._spool("frames", frame_to_dict(result))

    def step(self, result: StepResult) -> None:
        self._spool("fused", step_to_dict(result))

    def close(self, ok: bool) -> None:
        """Assemble the file when the replay succeeded, else discard it."""
        try:
            if ok:
                with self._out.guard():  # a full disk: one line naming the results file
                    self._write(self._out.stream())
                self._out.commit()
        finally:
            self._out.discard()
            for spool in self._spools.values():
                with contextlib.suppress(OSError):  # its buffer on a full disk: said already
                    spool.close()

    def _write(self, stream: IO[bytes]) -> None:
        doc: dict[str, Json] = {**_head(self.header, self.stats), "frames": None, "fused": None}
        with io.TextIOWrapper(stream, encoding="ascii", newline="\n") as out:
            out.write("{\n")
            keys = sorted(doc)
            for i, key in enumerate(keys):
                out.write(f"{json.dumps(key)}: ")
                if key in self._spools:
                    spool = self._spools[key]
                    spool.seek(0)
                    out.write("[\n")
                    while chunk := spool.read(1 << 16):
                        out.write(chunk)
                    out.write("\n]" if self._counts[key] else "]")
                else:
                    out.write(dumps(doc[key]))
                out.write(",\n" if i < len(keys) - 1 else "\n")
            out.write("}\n")
