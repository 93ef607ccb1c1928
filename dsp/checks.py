"""Option checks every command shares: numbers finite and in range, topic patterns that name
the robot, output extensions (:func:`check_suffix`).

Each raises :class:`~dsp.errors.UsageError` (exit 2) with one line naming the option, the
value given and what is accepted, before any work starts::

    check_number("--window", 0.0, low=0, high=60, low_open=True, unit="s")
    # UsageError: --window 0.0: give a finite number in (0, 60] s
"""

from __future__ import annotations

import math
import operator
from collections.abc import Sequence
from pathlib import Path

from dsp.errors import UsageError

__all__ = [
    "MAX_DISTRACTORS",
    "MAX_FACE_PX",
    "MAX_RATE_HZ",
    "MAX_THREADS",
    "MAX_TIME_S",
    "MIN_FACE_PX",
    "MIN_RATE_HZ",
    "check_int",
    "check_number",
    "check_rrd",
    "check_suffix",
    "check_topic_pattern",
]

MAX_THREADS = 1024
"""The most threads (or worker processes) an option may ask for: each is a stack and a
share of the memory, and no machine runs more at once."""
MAX_TIME_S = 9e9
"""The largest time [s] an option takes, either sign: stamps of real robots' logs are Unix
times (1.7e9 s today), and 9e9 s in nanoseconds still fits a signed 64-bit integer."""
MIN_RATE_HZ = 0.1
"""The slowest camera or pose rate a recording takes [Hz] (slower ones stepped the
simulation for ever)."""
MAX_RATE_HZ = 1000.0
"""The fastest camera rate a recording takes [Hz]."""
MIN_FACE_PX = 256
"""The smallest cube-map face a recording renders [px]."""
MAX_FACE_PX = 4096
"""Six faces of 4096^2 RGB are ~300 MB; larger would exhaust memory, not sharpen the image."""
MAX_DISTRACTORS = 20
"""The most boxes of the ball's colour beside a simulated field."""


def _num(x: float) -> str:
    if isinstance(x, int):
        return str(x)
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e16 else f"{x:g}"


def _range(low: float | None, high: float | None, low_open: bool, high_open: bool,
           unit: str) -> str:
    if low is not None and high is not None:
        text = f"in {'(' if low_open else '['}{_num(low)}, {_num(high)}{')' if high_open else ']'}"
    elif low is not None:
        text = f"{'>' if low_open else '>='} {_num(low)}"
    elif high is not None:
        text = f"{'<' if high_open else '<='} {_num(high)}"
    else:
        text = "any finite value"
    return f"{text} {unit}".rstrip()


def check_number(flag: str, value: float | None, *, low: float | None = None,
                 high: float | None = None, low_open: bool = False, high_open: bool = False,
                 unit: str = "") -> None:
    """Refuse a ``value`` (None passes: the option was not given) that is not a finite number
    within ``[low, high]`` (``low_open`` / ``high_open``: the bound itself is excluded)."""
    if value is None:
        return
    too_low = low is not None and (operator.le if low_open else operator.lt)(value, low)
    too_high = high is not None and (operator.ge if high_open else operator.gt)(value, high)
    if not math.isfinite(value) or too_low or too_high:
        raise UsageError(f"{flag} {value}: give a finite number "
                         f"{_range(low, high, low_open, high_open, unit)}")


def check_int(flag: str, value: int | None, *, low: int | None = None,
              high: int | None = None) -> None:
    """Refuse an integer ``value`` outside ``[low, high]`` (None passes)."""
    if value is None:
        return
    if (low is not None and value < low) or (high is not None and value > high):
        raise UsageError(f"{flag} {value}: give a whole number "
                         f"{_range(low, high, False, False, '')}")


def check_topic_pattern(flag: str, pattern: str) -> None:
    """A topic pattern must hold ``{robot}`` (where each robot's name goes) exactly once."""
    if pattern.count("{robot}") != 1:
        raise UsageError(f"{flag} {pattern!r}: the pattern must hold {{robot}} once, where the "
                         "robot's name goes (e.g. /{robot}/pose)")


def check_suffix(flag: str, path: Path | None, suffixes: Sequence[str]) -> Path | None:
    """Refuse an output name whose extension is not one of ``suffixes`` (case-insensitive):
    ``--out-csv run.json`` is a mistake worth a word before a long run, not a surprise after.
    A name that can only be a folder (``/``, ``.``, ``..``) is refused as one.
    Returns ``path`` (None passes)."""
    if path is None:
        return path
    if path.name in ("", ".", ".."):
        raise UsageError(f"{flag} {path}: is a folder; give a file name "
                         f"(e.g. {path / ('out' + suffixes[0])})")
    if path.suffix.lower() in suffixes:
        return path
    wanted = " or ".join(suffixes)
    raise UsageError(f"{flag} {path}: the file name must end in {wanted} "
                     f"(e.g. {path.with_suffix(suffixes[0])})")


def check_rrd(flag: str, path: Path | None) -> Path | None:
    """:func:`check_suffix` for a Rerun .rrd, whose writer takes only a name in UTF-8: a
    file or folder name of other bytes is refused here, before any work, instead of failing
    the save at its start. Returns ``path`` (None passes)."""
    check_suffix(flag, path, (".rrd",))
    if path is not None:
        try:
            str(path).encode("utf-8")
        except UnicodeEncodeError:
            raise UsageError(f"{flag} {path}: Rerun writes only to a path in UTF-8; choose "
                             "another name") from None
    return path

