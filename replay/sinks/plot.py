"""The replay figure as a file: ``dsp-replay --plot FILE.png`` (or .svg).

:class:`PlotSink` keeps the errors and positions (:class:`~replay.sinks.trace.ReplayTrace`)
and draws :func:`replay.sinks.figure.replay_figure` when the replay ends, under a temporary
name that appears only after a whole replay. matplotlib is imported only then.
"""

from __future__ import annotations

from pathlib import Path

from dsp.atomic import AtomicFile
from dsp.field import FieldSpec
from dsp.plotting import save
from replay.sinks.figure import replay_figure
from replay.sinks.trace import ReplayTrace

__all__ = ["PlotSink"]


class PlotSink(ReplayTrace):
    """Sink drawing the replay figure to ``path`` (.png or .svg) when the replay ends."""

    def __init__(self, path: Path, *, robots: tuple[str, ...], field: FieldSpec, title: str,
                 force: bool = False) -> None:
        super().__init__(robots, field, title)
        self._out = AtomicFile(path, force=force)
        self._fmt = Path(path).suffix.lower().lstrip(".") or "png"

    def close(self, ok: bool) -> None:
        try:
            if ok:
                figure = replay_figure(self)
                with self._out.guard(), self._out.stream() as stream:  # a full disk: one line
                    save(figure, stream, fmt=self._fmt)
                self._out.commit()
        finally:
            self._out.discard()
