"""An empty selection is a mistake, not a result: ``--start`` past the log's end, ``--end``
before its start, or ``--robots`` naming no robot would replay nothing and print a table of
zeros. :func:`check_selection` refuses them before the replay, :func:`check_selected` after
it (for logs whose time span is unknown until read, e.g. with ``--recover``).

``--start`` / ``--end`` count seconds from the log's start (:func:`log_origin_ns`): sim
time for a log dsp-record wrote (whose clock starts at 0, also when ``--recover`` lost its
first chunks), the first message's stamp for any other log (a robot's log stamped in Unix
time); ``@S`` gives an absolute stamp instead.
"""

from __future__ import annotations

from pathlib import Path

from dsp.errors import UsageError
from estimator.constants import NS_PER_S
from replay.log import LogInfo
from replay.options import ReplayOptions

__all__ = ["check_selected", "check_selection", "log_origin_ns"]


def log_origin_ns(info: LogInfo) -> int:
    """Where ``--start`` / ``--end`` count from: 0 for a log dsp-record wrote (sim time),
    else the log's first message (0 when the log has none)."""
    if info.recorder is not None or info.start_ns is None:
        return 0
    return info.start_ns


def _span(info: LogInfo) -> str:
    if info.start_ns is None or info.end_ns is None:
        return ""
    origin = log_origin_ns(info)
    start, end = (info.start_ns - origin) / NS_PER_S, (info.end_ns - origin) / NS_PER_S
    if origin:
        return (f" (its messages run from {start:.3f} to {end:.3f} s after its first, "
                f"stamped @{origin / NS_PER_S:.3f})")
    return f" (its messages run from {start:.3f} to {end:.3f} s)"


def _flag(seconds: float | None, absolute: bool) -> str:
    return "" if seconds is None else f"{'@' if absolute else ''}{seconds:g} s"


def check_selection(path: Path, info: LogInfo, options: ReplayOptions) -> None:
    """Raise :class:`~dsp.errors.UsageError` when the options select nothing in the log."""
    if options.robots is not None and not options.robots:
        raise UsageError("--robots names no robot; give names such as "
                         f"{','.join(info.robots[:2]) or 'robot1,robot2'}")
    t = options.timing(log_origin_ns(info))
    if t.start_ns is not None and info.end_ns is not None and t.start_ns > info.end_ns:
        raise UsageError(f"--start {_flag(options.start_s, options.start_absolute)} is past "
                         f"the end of {path}{_span(info)}")
    if t.end_ns is not None and info.start_ns is not None and t.end_ns < info.start_ns:
        raise UsageError(f"--end {_flag(options.end_s, options.end_absolute)} is before the "
                         f"start of {path}{_span(info)}")


def check_selected(path: Path, info: LogInfo, options: ReplayOptions, frames: int) -> None:
    """After the replay: no frame between ``--start`` and ``--end`` is an error too."""
    if frames == 0 and (options.start_s is not None or options.end_s is not None):
        start = _flag(options.start_s, options.start_absolute) or "the start"
        end = _flag(options.end_s, options.end_absolute) or "the end"
        raise UsageError(f"no image of {path} lies between {start} and {end}{_span(info)}")
