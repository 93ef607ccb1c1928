"""Batch replay: many logs, one results file each, and a summary over all of them.

    dsp-replay logs/ more.mcap --out-dir results/ [--out-mcap] [--workers N | --ray]

:func:`replay_batch` is the typed function behind it::

    summary = replay_batch([Path("logs")], Path("results"), ReplayOptions(),
                           workers=Workers(count=2))

- Inputs: log files and folders (a folder's ``*.mcap``, sorted by name, leaving out the
  ``*.estimates.mcap`` a batch writes), in the order given. Two logs with the same stem
  would write the same outputs: refused before any work, as are outputs that exist
  (without ``--force``).
- Per log ``DIR/<stem>.json``: the same bytes as ``dsp-replay LOG --out X.json`` with the
  same options (the results file names the log by its file name only); with
  ``estimates_mcap`` also ``DIR/<stem>.estimates.mcap``.
- ``DIR/batch-summary.{json,csv,md}`` (:mod:`replay.batch.summary`): one row per log in
  that order, and the totals. A log that fails is a row with its one-line error; the others
  still run; :func:`replay_batch` returns, and the command then exits 1.
- Each log is one task of :func:`replay.parallel.map_tasks` (serial, process pool or Ray).
  Ctrl-C stops the workers and removes the temporaries of the outputs they were writing.
  A worker reads the log and writes the outputs itself, so on a cluster the logs and
  ``DIR`` must be on a folder every node mounts at the same path; a worker that cannot read
  a log says so, naming its host and the path.
"""

from __future__ import annotations

import dataclasses
import os
import socket
import sys
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dsp.atomic import atomic_output, check_distinct, remove_stale_temporaries
from dsp.errors import DspError, InputError, OutputError, OutputExistsError, UsageError
from dsp.progress import progress_bar
from dsp.text import printable
from dsp.textfile import TEXT_ERRORS
from replay.batch.summary import BatchSummary, ErrorSums, LogRow
from replay.errors import InputNotFoundError
from replay.memory import keep_image_buffers
from replay.options import ReplayOptions
from replay.parallel import Outcome, Workers, map_tasks
from replay.records import FrameResult, StepResult
from replay.runner import replay
from replay.sink import SinkBase
from replay.stats import ErrorStats

__all__ = [
    "ESTIMATES_SUFFIX",
    "SUMMARY_STEM",
    "LogTask",
    "collect_logs",
    "replay_batch",
    "replay_log",
]

ESTIMATES_SUFFIX = ".estimates.mcap"
SUMMARY_STEM = "batch-summary"
SHARED_PATH_HINT = ("every worker needs the logs and the output folder at the same path: "
                    "put them on a shared folder (docs/batch.md)")


def collect_logs(paths: Sequence[Path]) -> list[Path]:
    """The logs named by ``paths`` (files, and folders' ``*.mcap`` sorted by name), in the
    order given, each once; refuses two logs with the same stem."""
    logs: list[Path] = []
    for path in map(Path, paths):
        if path.is_dir():
            found = sorted((p for p in path.glob("*.mcap")
                            if p.is_file() and not p.name.endswith(ESTIMATES_SUFFIX)),
                           key=lambda p: p.name)
            if not found:
                raise InputError(f"{path}: no *.mcap logs in this folder")
            logs += found
        elif path.is_file():
            logs.append(path)
        else:
            raise InputNotFoundError(path)
    unique: dict[Path, Path] = {}
    for log in logs:
        unique.setdefault(log.resolve(), log)
    by_stem: dict[str, Path] = {}
    for log in unique.values():
        if log.stem == SUMMARY_STEM:
            raise UsageError(f"{log}: a log may not be named {SUMMARY_STEM}.mcap "
                             "(the batch's summary files have that name)")
        if log.stem in by_stem:
            raise UsageError(f"{by_stem[log.stem]} and {log} have the same name {log.stem!r}: "
                             "their outputs would overwrite each other; rename one or "
                             "replay them in separate batches")
        by_stem[log.stem] = log
    return list(unique.values())


@dataclass(frozen=True)
class LogTask:
    """One log of a batch and the options to replay it with (outputs already set)."""

    log: Path
    options: ReplayOptions


class _Sums(SinkBase):
    """The sums behind the summary's RMSEs (ReplaySummary keeps RMSEs, not their sums)."""

    def __init__(self) -> None:
        self.robots: dict[str, ErrorStats] = {}
        self.fused = ErrorStats()

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        errs = self.robots.setdefault(result.robot, ErrorStats())
        if result.estimate is not None and result.error_m is not None:
            errs.add(result.error_m)

    def step(self, result: StepResult) -> None:
        if result.fused is not None and result.error_m is not None:
            self.fused.add(result.error_m)


def replay_log(task: LogTask) -> LogRow:
    """Replay one log of a batch (in whichever process runs it): its summary row, or the
    row with its one-line error. Never raises for a bad log."""
    name = task.log.name
    if not (task.log.is_file() and os.access(task.log, os.R_OK)):
        return LogRow(name, f"{task.log}: cannot read the log on host "
                      f"{socket.gethostname()} ({SHARED_PATH_HINT})")
    keep_image_buffers()  # a pool or Ray worker is a process of its own
    sums = _Sums()
    try:
        s = replay(task.log, task.options, sinks=[sums])
    except (DspError, OSError) as err:
        return LogRow(name, _one_line(err))
    except Exception as err:  # a bug: keep the batch going, say where it happened
        traceback.print_exc(file=sys.stderr)
        return LogRow(name, f"{task.log}: unexpected {type(err).__name__}: {_one_line(err)}")
    robots = {}
    for r in s.robots:
        rs, errs = s.per_robot[r], sums.robots.get(r, ErrorStats())
        robots[r] = ErrorSums(rs.frames, rs.detections, rs.estimates, errs.n, errs.sum_sq)
    f = sums.fused
    fused = ErrorSums(s.steps, s.fused_steps, s.fused_steps, f.n, f.sum_sq)
    return LogRow(name, None, s.frames, s.steps, robots, fused, s.warnings)


def _one_line(err: BaseException) -> str:
    lines = str(err).strip().splitlines()
    return lines[0] if lines else type(err).__name__


def output_paths(log: Path, out_dir: Path, *, estimates_mcap: bool) -> tuple[Path, Path | None]:
    """A log's results JSON and estimates MCAP in ``out_dir``."""
    return (out_dir / f"{log.stem}.json",
            out_dir / f"{log.stem}{ESTIMATES_SUFFIX}" if estimates_mcap else None)


def summary_paths(out_dir: Path) -> list[Path]:
    return [out_dir / f"{SUMMARY_STEM}.{ext}" for ext in ("json", "csv", "md")]


def _tasks(logs: Sequence[Path], out_dir: Path, options: ReplayOptions,
           estimates_mcap: bool) -> list[LogTask]:
    tasks = []
    for log in logs:
        out, out_mcap = output_paths(log, out_dir, estimates_mcap=estimates_mcap)
        tasks.append(LogTask(log, dataclasses.replace(
            options, out=out, out_mcap=out_mcap, rerun=None, progress=False)))
    # every refusal before any work: no output, the summaries included, on an input log or
    # on a file the options name (with --force too)
    check_distinct([*((f"the output {p.name}", p) for task in tasks
                      for p in (task.options.out, task.options.out_mcap) if p is not None),
                    *((f"the summary {p.name}", p) for p in summary_paths(out_dir))],
                   [*((f"the input log {log}", log) for log in logs), *options.input_flags()])
    for task in tasks:
        task.options.check_outputs(task.log)
    if not options.force:
        for path in summary_paths(out_dir):
            if path.exists():
                raise OutputExistsError(path)
    return tasks


def replay_batch(paths: Sequence[Path], out_dir: Path, options: ReplayOptions, *,
                 estimates_mcap: bool = False, workers: Workers | None = None,
                 progress: bool | None = False,
                 on_log: Callable[[LogRow], None] | None = None) -> BatchSummary:
    """Replay every log in ``paths`` into ``out_dir`` and write the batch summary there.

    Refuses (before any work) bad inputs, duplicate stems and existing outputs without
    ``options.force``. A log that fails is a row with its error; check
    :attr:`BatchSummary.failed`. ``on_log`` sees each row as its log finishes."""
    logs = collect_logs(paths)
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise UsageError(f"--out-dir {out_dir}: not a folder")
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as err:  # a read-only or full disk: the project's one line
        raise OutputError(out_dir, err) from err
    workers = workers or Workers(count=1)
    if options.threads is None and (workers.ray or workers.processes > 1):
        # the workers already use the cores: a thread pool per log would oversubscribe them
        options = dataclasses.replace(options, threads=1)
    tasks = _tasks(logs, out_dir, options, estimates_mcap)
    rows: list[LogRow | None] = [None] * len(tasks)
    with progress_bar(len(tasks), "dsp-replay", progress, unit="log") as bar:

        def done(i: int, outcome: Outcome[LogRow]) -> None:
            row = outcome.value if outcome.failure is None else LogRow(
                logs[i].name, outcome.failure.text)
            if outcome.failure is not None and outcome.failure.detail:
                print(printable(outcome.failure.detail, lines=True), file=sys.stderr)
            for line in row.warnings if row is not None else ():
                print(printable(f"warning: {line}"), file=sys.stderr)
            rows[i] = row
            bar.update(1)
            bar.set_postfix_str(logs[i].name)
            if on_log is not None and row is not None:
                on_log(row)

        try:
            map_tasks(replay_log, tasks, workers, on_done=done)
        except BaseException:  # Ctrl-C: the stopped workers' temporaries go as well
            _remove_temporaries(tasks)
            raise
    summary = BatchSummary(tuple(r for r in rows if r is not None), options.results_view())
    _write_summary(summary, out_dir)
    return summary


def _remove_temporaries(tasks: Sequence[LogTask]) -> None:
    """Remove the hidden temporaries of the outputs whose writers were stopped: pool workers
    are terminated at once, with no clean-up of their own, and a batch interrupted that way
    left one for every output of every log in progress. Only those of processes that no
    longer run are removed (:func:`dsp.atomic.stale_temporaries`)."""
    for task in tasks:
        for path in (task.options.out, task.options.out_mcap):
            if path is not None:
                remove_stale_temporaries(path)


def _write_summary(summary: BatchSummary, out_dir: Path) -> None:
    js, csv_, md = summary_paths(out_dir)
    for path, text in ((js, summary.to_json()), (csv_, summary.to_csv()),
                       (md, summary.to_markdown())):
        with atomic_output(path, force=True) as tmp:  # refused earlier when not --force
            tmp.write_text(text, encoding="utf-8", errors=TEXT_ERRORS)
