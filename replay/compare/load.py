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

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dsp import jsonio
from dsp.errors import InputError
from dsp.jsonio import Json
from dsp.textfile import read_text_file

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


def _stamp(path: Path, where: str, value: object) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise _fail(path, f"{where}.stamp_ns is {value!r}, not an integer")
    return value


def _items(path: Path, doc: Mapping[str, Any], key: str) -> list[Mapping[str, Any]]:
    items = doc.get(key)
    if not isinstance(items, list) or not all(isinstance(i, dict) for i in items):
        raise _fail(path, f"'{key}' is not a list of objects")
    return items


def _frames(path: Path, doc: Mapping[str, Any]) -> tuple[dict[FrameKey, bool], int]:
    out: dict[FrameKey, bool] = {}
    dup = 0
    for i, f in enumerate(_items(path, doc, "frames")):
        robot = f.get("robot")
        if not isinstance(robot, str):
            raise _fail(path, f"frames[{i}].robot is {robot!r}")
        key = (_stamp(path, f"frames[{i}]", f.get("stamp_ns")), robot)
        if key in out:
            dup += 1
            continue
        out[key] = f.get("detection") is not None
    return out, dup


def _steps(path: Path, doc: Mapping[str, Any]) -> tuple[dict[StepKey, StepScore], int]:
    out: dict[StepKey, StepScore] = {}
    dup = 0
    for i, s in enumerate(_items(path, doc, "fused")):
        key = (_stamp(path, f"fused[{i}]", s.get("stamp_ns")), bool(s.get("tick", False)))
        if key in out:
            dup += 1
            continue
        if s.get("truth") is None:
            continue
        error = _number(path, f"fused[{i}].error_m", s.get("error_m"))
        velocity = _number(path, f"fused[{i}].velocity_error_m_s", s.get("velocity_error_m_s"))
        out[key] = StepScore(error, velocity if error is not None else None)
    return out, dup


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
    """The run in ``text`` (read from ``path``); None when it is JSON of another format."""
    try:
        doc = jsonio.loads(text, parse_constant=_reject_constant)
    except (ValueError, RecursionError) as err:
        raise InputError(f"{path}: not JSON ({str(err).splitlines()[0]})") from None
    if not isinstance(doc, dict) or doc.get("format") != RESULTS_FORMAT:
        return None
    if doc.get("version") != 1:
        raise _fail(path, f"version {doc.get('version')!r}; this dsp-compare reads version 1")
    name, sha, options, parts = _header(path, doc)
    frames, dup_f = _frames(path, doc)
    steps, dup_s = _steps(path, doc)
    return ResultsRun(path, name, sha, options, parts, frames, steps, dup_f + dup_s)


def read_results(path: Path) -> ResultsRun | None:
    """One results file, bounded and checked (None: JSON of another format)."""
    return parse_results(path, read_text_file(path, MAX_RESULTS_BYTES, what="a results file"))


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
