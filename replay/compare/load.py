"""Results files read for ``dsp-compare``: checked, and reduced to what the comparison needs.

A run is one results file (``dsp-replay LOG --out X.json``) or a folder of them (a batch's
``--out-dir``: every ``*.json`` whose ``format`` is "dsp-replay-results"; the batch summary
and other JSON files are left out). A results file is untrusted input: it is read bounded
(:data:`MAX_RESULTS_BYTES`), parsed as strict JSON (no ``NaN``), and every field used is
checked; a problem is one line naming the file.

Of each file :func:`read_results` keeps the header (the log's name and sha256, the options,
the estimator's parts) and two tables keyed for pairing:

- frames by ``(stamp_ns, robot)``: whether the ball was detected;
- fused steps by ``(stamp_ns, tick)`` (a tick of ``--clock`` and an image step at one stamp
  are two steps), for the steps that have a truth: the position error (None: no fused
  estimate) and the velocity error (None: none estimated, or no true velocity).
"""

from __future__ import annotations

import contextlib
import json
import math
import re
import shlex
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dsp import jsonio
from dsp.errors import InputError
from dsp.jsonio import Json
from dsp.textfile import read_text_file
from replay.log.mcap_records import MAGIC

__all__ = ["MAX_RESULTS_BYTES", "RESULTS_FORMAT", "ResultsRun", "StepScore", "read_results",
           "read_run"]

RESULTS_FORMAT = "dsp-replay-results"
MAX_RESULTS_BYTES = 1 << 30
"""The largest results file read (1 GiB: hours of images)."""
FrameKey = tuple[int, str]
StepKey = tuple[int, bool]


@dataclass(frozen=True)
class StepScore:
    """One fused step with a truth."""

    error_m: float | None
    velocity_error_m_s: float | None


@dataclass(frozen=True)
class ResultsRun:
    """What one results file says, keyed for pairing."""

    path: Path
    log_file: str
    sha256: str
    options: dict[str, Json]
    parts: dict[str, Json]
    frames: dict[FrameKey, bool] = field(repr=False)
    """(stamp_ns, robot) -> detected."""
    steps: dict[StepKey, StepScore] = field(repr=False)
    duplicates: int = 0
    """Frames or steps whose key came twice (the first is kept)."""


def _reject_constant(name: str) -> None:
    raise ValueError(f"{name} is not JSON")


def _fail(path: Path, what: str) -> InputError:
    return InputError(f"{path}: not a dsp-replay results file ({what})")


def _number(path: Path, where: str, value: object, *, optional: bool = True) -> float | None:
    if value is None and optional:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(
            value):
        raise _fail(path, f"{where} is {value!r}, not a number")
    return float(value)


def _distance(path: Path, where: str, value: object) -> float | None:
    """An error (a distance, so never negative) or None."""
    got = _number(path, where, value)
    if got is not None and got < 0.0:
        raise _fail(path, f"{where} is {got!r}; an error is a distance, never negative")
    return got


def _stamp(path: Path, where: str, value: object) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise _fail(path, f"{where}.stamp_ns is {value!r}, not an integer")
    return value


class _Table:
    """The pairing table of one list of a results file ("frames" or "fused"), built item by
    item as the list is decoded (each item dropped once read); the first problem is kept
    and raised only once the file is known to be a results file (:meth:`check`)."""

    def __init__(self, path: Path, key: str) -> None:
        self.path, self.key = path, key
        self.rows: dict[Any, Any] = {}
        self.duplicates = 0
        self.seen = False
        self.error: InputError | None = None

    def add(self, i: int, item: object) -> None:
        if self.error is not None:
            return
        try:
            if not isinstance(item, dict):
                raise _fail(self.path, f"'{self.key}' is not a list of objects")
            self._add(i, item)
        except InputError as err:
            self.error = err

    def _add(self, i: int, item: Mapping[str, Any]) -> None:
        raise NotImplementedError

    def check(self) -> None:
        if self.error is not None:
            raise self.error
        if not self.seen:
            raise _fail(self.path, f"'{self.key}' is not a list of objects")


class _Frames(_Table):
    """(stamp_ns, robot) -> detected."""

    def _add(self, i: int, f: Mapping[str, Any]) -> None:
        robot = f.get("robot")
        if not isinstance(robot, str):
            raise _fail(self.path, f"frames[{i}].robot is {robot!r}")
        key = (_stamp(self.path, f"frames[{i}]", f.get("stamp_ns")), robot)
        if key in self.rows:
            self.duplicates += 1
            return
        self.rows[key] = f.get("detection") is not None


class _Steps(_Table):
    """(stamp_ns, tick) -> the step's scores, for the steps with a truth."""

    def _add(self, i: int, s: Mapping[str, Any]) -> None:
        path = self.path
        key = (_stamp(path, f"fused[{i}]", s.get("stamp_ns")), bool(s.get("tick", False)))
        if key in self.rows:
            self.duplicates += 1
            return
        if s.get("truth") is None:
            return
        error = _distance(path, f"fused[{i}].error_m", s.get("error_m"))
        velocity = _distance(path, f"fused[{i}].velocity_error_m_s",
                             s.get("velocity_error_m_s"))
        self.rows[key] = StepScore(error, velocity if error is not None else None)


_DECODER = json.JSONDecoder(parse_constant=_reject_constant)
_SPACE = re.compile(r"[ \t\n\r]*")
_STREAMED = object()
"""What a streamed list stands as in the decoded top-level object."""


def _space(text: str, pos: int) -> int:
    end = _SPACE.match(text, pos)
    return pos if end is None else end.end()


def _expect(text: str, pos: int, chars: str, what: str) -> str:
    if pos >= len(text) or text[pos] not in chars:
        raise ValueError(f"Expecting {what}: char {pos}")
    return text[pos]


def _decode_streaming(text: str, tables: Mapping[str, _Table]) -> Any:
    """The JSON value of ``text``, as :func:`json.loads` gives it, except that in a top-level
    object the arrays under the keys of ``tables`` are handed to them item by item (and
    stand as :data:`_STREAMED`): what is held is the text and the tables, never the whole
    document. Raises ``ValueError`` for what is not JSON."""
    jsonio.check_limits(text)
    pos = _space(text, 0)
    if not text.startswith("{", pos):  # not an object: no results file, decoded as it is
        value, pos = _DECODER.raw_decode(text, pos)
        if _space(text, pos) != len(text):
            raise ValueError(f"Extra data: char {pos}")
        return value
    doc: dict[str, Any] = {}
    pos = _space(text, pos + 1)
    if text.startswith("}", pos):
        pos += 1
    else:
        while True:
            _expect(text, pos, '"', "property name enclosed in double quotes")
            key, pos = _DECODER.raw_decode(text, pos)
            pos = _space(text, pos)
            _expect(text, pos, ":", "':' delimiter")
            pos = _space(text, pos + 1)
            table = tables.get(key)
            if table is not None and text.startswith("[", pos):
                if table.seen:
                    raise ValueError(f"the key {key!r} is given twice")
                table.seen = True
                pos = _space(text, pos + 1)
                i = 0
                if text.startswith("]", pos):
                    pos += 1
                else:
                    while True:
                        item, pos = _DECODER.raw_decode(text, pos)
                        table.add(i, item)
                        i += 1
                        pos = _space(text, pos)
                        if _expect(text, pos, ",]", "',' delimiter") == "]":
                            pos += 1
                            break
                        pos = _space(text, pos + 1)
                doc[key] = _STREAMED
            else:
                doc[key], pos = _DECODER.raw_decode(text, pos)
            pos = _space(text, pos)
            if _expect(text, pos, ",}", "',' delimiter") == "}":
                pos += 1
                break
            pos = _space(text, pos + 1)
    if _space(text, pos) != len(text):
        raise ValueError(f"Extra data: char {pos}")
    return doc


def _header(path: Path, doc: Mapping[str, Any]) -> tuple[str, str, dict[str, Json],
                                                          dict[str, Json]]:
    log = doc.get("log")
    if not isinstance(log, dict):
        raise _fail(path, "no 'log' header")
    sha, name = log.get("sha256"), log.get("file")
    if not isinstance(sha, str) or not sha or not isinstance(name, str):
        raise _fail(path, "its 'log' header has no file name and sha256")
    options, parts = doc.get("options"), doc.get("parts", {})
    if not isinstance(options, dict) or not isinstance(parts, dict):
        raise _fail(path, "'options' or 'parts' is not an object")
    return name, sha, options, parts


def parse_results(path: Path, text: str) -> ResultsRun | None:
    """The run in ``text`` (read from ``path``); None when it is JSON of another format.
    The frames and fused steps are reduced to the pairing tables as they are decoded, so
    what is held beside the text is in proportion to the tables, not to the document."""
    frames, steps = _Frames(path, "frames"), _Steps(path, "fused")
    try:
        doc = _decode_streaming(text, {"frames": frames, "fused": steps})
    except (ValueError, RecursionError) as err:
        raise InputError(f"{path}: not JSON ({str(err).splitlines()[0]})") from None
    if not isinstance(doc, dict) or doc.get("format") != RESULTS_FORMAT:
        return None
    if doc.get("version") != 1:
        raise _fail(path, f"version {doc.get('version')!r}; this dsp-compare reads version 1")
    name, sha, options, parts = _header(path, doc)
    frames.check()
    steps.check()
    return ResultsRun(path, name, sha, options, parts, frames.rows, steps.rows,
                      frames.duplicates + steps.duplicates)


def read_results(path: Path) -> ResultsRun | None:
    """One results file, bounded and checked (None: JSON of another format)."""
    _refuse_log(path)
    return parse_results(path, read_text_file(path, MAX_RESULTS_BYTES, what="a results file"))


def _refuse_log(path: Path) -> None:
    """A log given for a results file is named as one, with the command that makes results
    from it, before any of it is read as text."""
    head = b""
    if path.is_file():  # a regular file: reading it cannot block
        with contextlib.suppress(OSError), path.open("rb") as f:
            head = f.read(len(MAGIC))
    if head == MAGIC:
        raise InputError(f"{path}: an MCAP log, not a results file: dsp-compare compares the "
                         f"results of replays (dsp-replay {shlex.quote(str(path))} --out "
                         "r.json writes them); --log LOG --rerun shows a log's two replays "
                         "side by side")


def read_run(path: Path) -> list[ResultsRun]:
    """A run: one results file, or every results file in a folder (sorted by name)."""
    path = Path(path)
    if path.is_dir():
        runs = []
        others = []
        for p in sorted(path.glob("*.json"), key=lambda p: p.name):
            run = read_results(p)
            if run is None:
                others.append(p.name)
            else:
                runs.append(run)
        if not runs:
            hint = (f" (only {', '.join(others[:3])}{', ...' if len(others) > 3 else ''}: "
                    "a dsp-eval folder holds tables, not results; replay its logs with "
                    f"dsp-replay {path} --out-dir DIR)") if others else ""
            raise InputError(f"{path}: no dsp-replay results files (*.json) in this folder"
                             + hint)
        return runs
    if not path.exists():
        raise InputError(f"{path}: no such file or folder")
    run = read_results(path)
    if run is None:
        raise InputError(f"{path}: not a dsp-replay results file (its 'format' is not "
                         f"{RESULTS_FORMAT!r})")
    return [run]
