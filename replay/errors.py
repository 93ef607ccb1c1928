"""Errors of the replay package: what a log (or replaying it) can get wrong, one subclass each.

They derive from the project's error tree (:mod:`dsp.errors`); bad option values raise
:class:`dsp.errors.UsageError`, a refused overwrite :class:`dsp.errors.OutputExistsError` and
an unusable calibration :class:`dsp.errors.CalibrationError`. Every message names the
offending file (or value) and, where there is one, the fix.
"""

from __future__ import annotations

import os
import shlex
import stat
from collections.abc import Iterable
from pathlib import Path

from dsp.errors import InputError
from dsp.text import printable

__all__ = [
    "CorruptLogError",
    "ImageDecodeError",
    "InputNotFoundError",
    "MissingPosesError",
    "NoCameraError",
    "NoFramesError",
    "NoImageTopicsError",
    "NoPoseTopicError",
    "NotMcapError",
    "ReplayError",
    "SchemaError",
    "StrictError",
    "TruncatedLogError",
]


MAX_LISTED_TOPICS = 10
"""A topic error lists this many of the log's topics, then says how many more there are."""


class ReplayError(InputError):
    """A log, or something replaying it needs, cannot be used (exit code 1)."""


class InputNotFoundError(ReplayError):
    """The input path does not exist or is not a regular file (the message says which)."""

    def __init__(self, path: Path | str) -> None:
        super().__init__(f"{path}: {_not_a_file(Path(path))}")


def _not_a_file(path: Path) -> str:
    """Why ``path`` is not a log to read: missing, a folder, or not a regular file."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return "no such file (check the path)"
    except OSError as err:
        return f"cannot read it: {err.strerror or err}"
    if stat.S_ISDIR(st.st_mode):
        return ("is a folder, not a log (dsp-replay FOLDER --out-dir DIR replays every log "
                "in it)")
    return "not a regular file (a device, pipe or socket): give the log file itself"


class NotMcapError(ReplayError):
    """The input does not start with the MCAP magic bytes."""

    def __init__(self, path: Path | str) -> None:
        super().__init__(f"{path}: not an MCAP file (bad magic bytes)")


class TruncatedLogError(ReplayError):
    """The log ends early (no footer / summary); ``--recover`` replays what is complete."""

    def __init__(self, path: Path | str, detail: str = "") -> None:
        extra = f" ({detail})" if detail else ""
        super().__init__(
            f"{path}: the log is truncated or its end is damaged{extra}; "
            "use --recover to replay every complete chunk"
        )


class CorruptLogError(ReplayError):
    """A chunk or record of the log cannot be read (bad CRC, bad compression, bad record)."""

    def __init__(self, path: Path | str, detail: str) -> None:
        super().__init__(
            f"{path}: corrupt log data ({detail}); use --recover to skip damaged chunks"
        )


class NoImageTopicsError(ReplayError):
    """No channel of the log matches the image topic pattern; the message lists the log's
    topics (the first :data:`MAX_LISTED_TOPICS`) and points to ``dsp-info``."""

    def __init__(self, path: Path | str, pattern: str, robots: list[str] | None = None, *,
                 topics: Iterable[str] = (), given: bool = False,
                 matched: Iterable[str] = ()) -> None:
        """``robots``: the robots asked for (``--robots``); ``given``: ``pattern`` is the
        user's ``--image-topic``; ``matched``: the robots ``pattern`` names in the log."""
        which = f" for robots {', '.join(robots)}" if robots else ""
        found = ", ".join(printable(r, limit=60) for r in matched)
        hint = (f"its robots are {found}: check --robots" if robots and found
                else "the --image-topic given" if given else "set --image-topic")
        super().__init__(f"{path}: no image topics match {pattern!r}{which} ({hint}); "
                         + _topics_hint(path, topics))


class MissingPosesError(ReplayError):
    """A robot with images has no pose topic, or no image could be paired with a pose."""

    def __init__(self, path: Path | str, detail: str) -> None:
        super().__init__(f"{path}: missing poses: {detail} (set --pose-topic or "
                         "--pose-tolerance)")


class NoPoseTopicError(MissingPosesError):
    """A robot with images has no pose topic (``--pose-tolerance`` cannot help: the message
    lists the log's topics and points to ``dsp-info``)."""

    def __init__(self, path: Path | str, pattern: str, robots: Iterable[str], *,
                 topics: Iterable[str] = (), given: bool = False) -> None:
        names = ", ".join(printable(r, limit=60) for r in robots)
        hint = "the --pose-topic given" if given else "set --pose-topic"
        ReplayError.__init__(self, f"{path}: missing poses: no pose topic {pattern!r} for "
                             f"{names} ({hint}); {_topics_hint(path, topics)}")


def _topics_hint(path: Path | str, topics: Iterable[str]) -> str:
    """The log's topics (at most :data:`MAX_LISTED_TOPICS`, terminal-safe) and the command
    that lists them with their types and the patterns that replay them."""
    names = sorted(set(topics))
    shown = ", ".join(printable(t, limit=120) for t in names[:MAX_LISTED_TOPICS])
    more = (f" and {len(names) - MAX_LISTED_TOPICS} more" if len(names) > MAX_LISTED_TOPICS
            else "")
    listed = f"the log's topics: {shown}{more}" if names else "the log has no topics"
    return f"{listed} (dsp-info {shlex.quote(str(path))} lists them with their types)"


class NoCameraError(ReplayError):
    """A robot that replays needs a camera description that neither the log nor an option
    gives (a replay never guesses the image centre or the calibration)."""

    def __init__(self, path: Path | str, detail: str) -> None:
        super().__init__(f"{path}: {detail}")


class StrictError(ReplayError):
    """``--strict``: a replay that would have ended with warnings fails instead."""

    def __init__(self, warnings: list[str]) -> None:
        more = f" (and {len(warnings) - 1} more warning(s))" if len(warnings) > 1 else ""
        super().__init__(f"--strict: {warnings[0]}{more}")
        self.warnings = warnings


class ImageDecodeError(ReplayError):
    """No image of the log could be decoded (a single bad image is only counted)."""

    def __init__(self, path: Path | str, detail: str) -> None:
        super().__init__(f"{path}: images do not decode: {detail}")


class SchemaError(ReplayError):
    """The schema of a topic replay reads is missing or does not parse."""

    def __init__(self, path: Path | str, what: str, detail: str) -> None:
        super().__init__(f"{path}: unusable schema for {what}: {printable(detail, limit=120)}")


class NoFramesError(ReplayError):
    """The replay read no image frame at all (an empty selection, or nothing readable)."""

    def __init__(self, path: Path | str, detail: str) -> None:
        super().__init__(f"{path}: no frames replayed: {detail}")
