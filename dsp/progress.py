"""Progress on stderr, the same way for every command and the library code behind them.

:func:`progress_bar` makes what :func:`dsp.cli.progress_enabled` decided: a tqdm bar on a
terminal (True), plain lines every :data:`LINE_INTERVAL_S` seconds when stderr is not one
(None: a pipe, a CI log; :class:`LineProgress`) or nothing (False). Either is a
:class:`Progress`.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import IO, Protocol

from dsp.text import printable

__all__ = ["LINE_INTERVAL_S", "LineProgress", "Progress", "progress_bar"]


class Progress(Protocol):
    """What a command does with its progress: a tqdm bar, :class:`LineProgress` or a
    disabled bar, used as a context manager."""

    def update(self, n: int = 1) -> None: ...

    def set_postfix_str(self, text: str, refresh: bool = True) -> None: ...

    def __enter__(self) -> Progress: ...

    def __exit__(self, *exc: object) -> None: ...


LINE_INTERVAL_S = 10.0
"""How often a progress line is printed when stderr is not a terminal."""


class LineProgress:
    """Progress as plain lines on a stream that is not a terminal: ``desc: 120/600 img
    (20%), 31 s`` at most every ``interval_s`` seconds (the tqdm calls a bar gets)."""

    def __init__(self, total: int | None, desc: str, *, unit: str = "it",
                 interval_s: float = LINE_INTERVAL_S, stream: IO[str] | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.total, self.desc, self.unit = total, desc, unit
        self.n = 0
        self.interval_s = interval_s
        self.stream = stream
        self.clock = clock
        self.start = self.last = clock()

    def update(self, n: int = 1) -> None:
        self.n += n
        now = self.clock()
        if now - self.last >= self.interval_s:
            self.last = now
            self._line(now)

    def set_postfix_str(self, text: str, refresh: bool = True) -> None:
        """Accepted for tqdm compatibility; lines carry counts only."""

    def _line(self, now: float) -> None:
        done = f"{self.n}/{self.total}" if self.total else f"{self.n}"
        pct = f" ({100.0 * self.n / self.total:.0f}%)" if self.total else ""
        stream = sys.stderr if self.stream is None else self.stream
        print(f"{self.desc}: {done} {self.unit}{pct}, {now - self.start:.0f} s",
              file=stream, flush=True)

    def close(self) -> None:
        return None

    def __enter__(self) -> LineProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def progress_bar(total: int | None, desc: str, enabled: bool | None, *,
                 unit: str = "it") -> Progress:
    """Progress on stderr as :func:`dsp.cli.progress_enabled` decided: a tqdm bar (True), plain
    lines (None, :class:`LineProgress`) or nothing (False); use it as a context manager.

    The bar is removed when it closes, so the summary that follows stands alone. ``desc``
    (often a file name) is escaped as everything printed is (:func:`dsp.text.printable`)."""
    desc = printable(desc)
    if enabled is None:
        return LineProgress(total, desc, unit=unit)
    from tqdm import tqdm

    bar: Progress = tqdm(total=total, desc=desc, unit=unit, disable=not enabled,
                         leave=False, file=sys.stderr, dynamic_ncols=True)
    return bar
