"""An empty selection is a mistake, not a result: ``--start`` past the log's end, ``--end``
before its start, or ``--robots`` naming no robot would replay nothing and print a table of
zeros. :func:`check_selection` refuses them before the replay, :func:`check_selected` after
it (for logs whose time span is unknown until read, e.g. with ``--recover``).
"""

from __future__ import annotations

from pathlib import Path

from dsp.errors import UsageError
from estimator.constants import NS_PER_S
from replay.log import LogInfo
from replay.options import ReplayOptions

__all__ = ["check_selected", "check_selection"]


def _span(info: LogInfo) -> str:
    if info.start_ns is None or info.end_ns is None:
        return ""
    start, end = info.start_ns / NS_PER_S, info.end_ns / NS_PER_S
    return f" (its messages run from {start:.3f} to {end:.3f} s)"


def check_selection(path: Path, info: LogInfo, options: ReplayOptions) -> None:
    """Raise :class:`~dsp.errors.UsageError` when the options select nothing in the log."""
    if options.robots is not None and not options.robots:
        raise UsageError("--robots names no robot; give names such as "
                         f"{','.join(info.robots[:2]) or 'robot1,robot2'}")
    t = options.timing()
    if t.start_ns is not None and info.end_ns is not None and t.start_ns > info.end_ns:
        raise UsageError(f"--start {options.start_s:g} s is past the end of {path}{_span(info)}")
    if t.end_ns is not None and info.start_ns is not None and t.end_ns < info.start_ns:
        raise UsageError(f"--end {options.end_s:g} s is before the start of {path}{_span(info)}")


def check_selected(path: Path, info: LogInfo, options: ReplayOptions, frames: int) -> None:
    """After the replay: no frame between ``--start`` and ``--end`` is an error too."""
    if frames == 0 and (options.start_s is not None or options.end_s is not None):
        start = "the start" if options.start_s is None else f"{options.start_s:g} s"
        end = "the end" if options.end_s is None else f"{options.end_s:g} s"
        raise UsageError(f"no image of {path} lies between {start} and {end}{_span(info)}")
