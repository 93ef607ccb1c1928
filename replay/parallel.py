"""Run independent tasks on all cores or on a Ray cluster; results come back in task order.

:func:`map_tasks` is the one entry point::

    outcomes = map_tasks(replay_one, logs, Workers(count=4), on_done=tick)

- ``Workers(count=1)``: today's serial path, in this process (exceptions propagate as is).
- ``Workers(count=N)`` (``None``: every core this process may use): a local process pool
  (``forkserver`` where the platform has it, else ``spawn``: no state is inherited).
- ``Workers(ray=True)``: the same tasks as Ray tasks (``max_retries`` for lost workers).
  With ``RAY_ADDRESS`` set, Ray joins that cluster; else a local instance is started (with
  ``count`` CPUs when given) and shut down at the end. A Ray already initialised in this
  process (a test session) is used as it is.

A task is a module-level function and a picklable argument; it runs in a worker that
imports the project (install it on every node). Whatever a task raises is caught in the
worker and comes back as a :class:`TaskFailure` (message and exit code, never a pickled
exception), so the outcome does not depend on where the task ran. Results are put back in
task order, so callers that fold them in that order get the same bytes whatever the worker
count or the order tasks finish in (DESIGN.md, convention 14).

Ctrl-C cancels the batch: pool workers ignore SIGINT and are terminated, Ray tasks are
cancelled (``ray.cancel(force=True)``); :class:`KeyboardInterrupt` is re-raised for
:func:`dsp.cli.run_main` to turn into exit code 130.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import signal
import socket
import traceback
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from dsp.errors import EXIT_INPUT, DspError, InputError, UsageError

__all__ = [
    "RAY_INSTALL_HINT",
    "RAY_MAX_RETRIES",
    "Outcome",
    "RayUnavailableError",
    "TaskFailure",
    "Workers",
    "add_worker_arguments",
    "available_cores",
    "map_tasks",
    "workers_from_args",
]

T = TypeVar("T")
R = TypeVar("R")

MAX_WORKERS = 1024
"""More processes than this would exhaust the machine before doing any work."""
RAY_MAX_RETRIES = 3
"""How often Ray re-runs a task whose worker died (a lost node, the OOM killer)."""
RAY_INSTALL_HINT = "--ray needs Ray: pip install 'dual-sight[ray]' (or pip install -e '.[ray]')"


class RayUnavailableError(UsageError):
    """``--ray`` was asked for but Ray is not installed (exit code 2)."""

    def __init__(self) -> None:
        super().__init__(RAY_INSTALL_HINT)


def add_worker_arguments(parser: argparse.ArgumentParser, *, what: str) -> None:
    """``--workers N`` and ``--ray`` (``what``: the unit of work, for the help)."""
    parser.add_argument("--workers", type=int, metavar="N",
                        help=f"run {what} in N local processes (default: every core; "
                        "1: one after the other in this process); with --ray, the CPUs "
                        "of the local Ray instance")
    parser.add_argument("--ray", action="store_true",
                        help=f"run {what} as Ray tasks: on the cluster RAY_ADDRESS names, "
                        "else on a local Ray instance (needs the extra: pip install "
                        "'dual-sight[ray]')")


def workers_from_args(args: argparse.Namespace) -> Workers:
    """The :class:`Workers` the arguments ask for; with ``--ray``, checks that Ray imports
    (else :class:`RayUnavailableError`, exit code 2) before any work."""
    workers = Workers(count=args.workers, ray=args.ray)
    if workers.ray:
        from replay.parallel_ray import import_ray

        import_ray()
    return workers


def available_cores() -> int:
    """The cores this process may run on (its affinity mask where the OS has one)."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)  # pragma: no cover - macOS, Windows


@dataclass(frozen=True)
class Workers:
    """Where tasks run: ``count`` processes (None: every core), on Ray when ``ray``."""

    count: int | None = None
    ray: bool = False

    def __post_init__(self) -> None:
        if self.count is not None and self.count < 1:
            raise UsageError(f"--workers {self.count}: give at least 1")
        if self.count is not None and self.count > MAX_WORKERS:
            raise UsageError(f"--workers {self.count}: give at most {MAX_WORKERS}")

    @property
    def processes(self) -> int:
        return self.count if self.count is not None else available_cores()

    @property
    def serial(self) -> bool:
        """True for today's in-process loop: one worker and no Ray."""
        return not self.ray and self.processes == 1


@dataclass(frozen=True)
class TaskFailure:
    """What a task raised, as data: the one-line ``message``, the :mod:`dsp.errors`
    ``exit_code`` it maps to, the ``host`` it ran on, and ``detail``, the worker's traceback
    for an unexpected error (a bug), else empty."""

    message: str
    exit_code: int = EXIT_INPUT
    detail: str = ""
    host: str = ""

    @property
    def text(self) -> str:
        """The message, naming the host when the task ran on another machine."""
        if self.host and self.host != socket.gethostname():
            return f"{self.message} (on host {self.host})"
        return self.message

    def raise_(self) -> None:
        """Raise it in this process: a :class:`DspError` with the same message and code, or,
        for a bug, a RuntimeError carrying the worker's traceback."""
        if self.detail:
            raise RuntimeError(f"{self.text}\nworker traceback:\n{self.detail}")
        err = DspError(self.text)
        err.exit_code = self.exit_code
        raise err


@dataclass(frozen=True)
class Outcome(Generic[R]):
    """One task's result, or how it failed."""

    value: R | None = None
    failure: TaskFailure | None = None

    def unwrap(self) -> R:
        if self.failure is not None:
            self.failure.raise_()
        return self.value  # type: ignore[return-value]


def _failure(err: BaseException) -> TaskFailure:
    host = socket.gethostname()
    if isinstance(err, DspError):
        return TaskFailure(str(err), err.exit_code, host=host)
    if isinstance(err, OSError):
        return TaskFailure(str(err), EXIT_INPUT, host=host)
    detail = "".join(traceback.format_exception(type(err), err, err.__traceback__))
    return TaskFailure(f"{type(err).__name__}: {err}", EXIT_INPUT, detail, host)


def _call(fn: Callable[[T], R], index: int, arg: T) -> tuple[int, Outcome[R]]:
    """Run one task in a worker; whatever it raises comes back as data."""
    try:
        return index, Outcome(value=fn(arg))
    except Exception as err:
        return index, Outcome(failure=_failure(err))


Done = Callable[[int, "Outcome[Any]"], None]


def map_tasks(fn: Callable[[T], R], args: Sequence[T], workers: Workers, *,
              on_done: Done | None = None, fail_fast: bool = False) -> list[Outcome[R]]:
    """``[fn(a) for a in args]`` on ``workers``, as outcomes in the order of ``args``.

    ``on_done(index, outcome)`` is called in this process as each task ends (in finishing
    order). With ``fail_fast`` the first failure cancels the tasks not yet done and is
    raised (:meth:`TaskFailure.raise_`); in the serial path every exception propagates."""
    if not args:
        return []
    if workers.ray:
        from replay.parallel_ray import map_ray

        return map_ray(_call, fn, args, workers, on_done=on_done, fail_fast=fail_fast)
    if workers.serial or len(args) == 1:
        return _map_serial(fn, args, on_done)
    return _map_pool(fn, args, min(workers.processes, len(args)), on_done, fail_fast)


def _map_serial(fn: Callable[[T], R], args: Sequence[T],
                on_done: Done | None) -> list[Outcome[R]]:
    out: list[Outcome[R]] = []
    for i, arg in enumerate(args):
        outcome = Outcome(value=fn(arg))
        out.append(outcome)
        if on_done is not None:
            on_done(i, outcome)
    return out


def _ignore_sigint() -> None:
    """Pool workers leave Ctrl-C to the parent, which terminates them."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


PRELOAD = ["__main__", "replay.runner"]
"""Imported once by the fork server, so a new pool worker starts without importing numpy,
OpenCV and mcap again."""


def _context() -> multiprocessing.context.BaseContext:
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(PRELOAD)
        return ctx
    return multiprocessing.get_context("spawn")  # pragma: no cover - macOS, Windows


def _map_pool(fn: Callable[[T], R], args: Sequence[T], processes: int, on_done: Done | None,
              fail_fast: bool) -> list[Outcome[R]]:
    results: list[Outcome[R] | None] = [None] * len(args)
    pool = ProcessPoolExecutor(max_workers=processes, mp_context=_context(),
                               initializer=_ignore_sigint)
    try:
        pending: set[Future[tuple[int, Outcome[R]]]] = {
            pool.submit(_call, fn, i, arg) for i, arg in enumerate(args)}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for i, outcome in sorted((fut.result() for fut in done), key=lambda t: t[0]):
                results[i] = outcome
                if on_done is not None:
                    on_done(i, outcome)
                if fail_fast and outcome.failure is not None:
                    _terminate(pool)
                    outcome.failure.raise_()
    except BrokenProcessPool as err:  # a worker was killed (the OOM killer, a signal)
        _terminate(pool)
        raise InputError(f"a worker process died abruptly ({err}); try fewer --workers "
                         "(memory?)") from err
    except BaseException:  # Ctrl-C: stop every worker now
        _terminate(pool)
        raise
    pool.shutdown(wait=True)
    return [r for r in results if r is not None]


def _terminate(pool: ProcessPoolExecutor) -> None:
    """Cancel what has not started and stop the workers at once."""
    terminate = getattr(pool, "terminate_workers", None)  # Python 3.14
    if terminate is not None:  # pragma: no cover - newer Pythons
        terminate()
        return
    processes = dict(getattr(pool, "_processes", None) or {})
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in processes.values():
        if proc.is_alive():
            proc.terminate()
    for proc in processes.values():
        proc.join(timeout=5)

