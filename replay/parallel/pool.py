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
:func:`dsp.cli.run_main` to turn into exit code 130. A pool worker whose command was killed
outright (nothing could terminate it) ends by itself within :data:`PARENT_POLL_S`.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import TypeVar

from dsp.errors import EXIT_INTERRUPTED, InputError
from replay.parallel.ray_tasks import map_ray
from replay.parallel.tasks import Done, Outcome, Workers, run_task

__all__ = ["PRELOAD", "map_tasks"]

T = TypeVar("T")
R = TypeVar("R")


def map_tasks(fn: Callable[[T], R], args: Sequence[T], workers: Workers, *,
              on_done: Done[R] | None = None, fail_fast: bool = False) -> list[Outcome[R]]:
    """``[fn(a) for a in args]`` on ``workers``, as outcomes in the order of ``args``.

    ``on_done(index, outcome)`` is called in this process as each task ends (in finishing
    order). With ``fail_fast`` the first failure cancels the tasks not yet done and is
    raised (:meth:`TaskFailure.raise_`); in the serial path every exception propagates."""
    if not args:
        return []
    if workers.ray:
        return map_ray(run_task, fn, args, workers, on_done=on_done, fail_fast=fail_fast)
    if workers.serial or len(args) == 1:
        return _map_serial(fn, args, on_done)
    return _map_pool(fn, args, min(workers.processes, len(args)), on_done, fail_fast)


def _map_serial(fn: Callable[[T], R], args: Sequence[T],
                on_done: Done[R] | None) -> list[Outcome[R]]:
    out: list[Outcome[R]] = []
    for i, arg in enumerate(args):
        outcome = Outcome(value=fn(arg))
        out.append(outcome)
        if on_done is not None:
            on_done(i, outcome)
    return out


PARENT_POLL_S = 0.2
"""How often a pool worker checks that the command that started it is still there."""


def _start_worker(command: int) -> None:
    """Pool workers leave Ctrl-C to the parent, which terminates them, and end on their own
    when the command (process ``command``) is gone: killed outright (SIGKILL, the OOM
    killer), it cannot terminate them, and they would replay on and write for nobody."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threading.Thread(target=_end_with_command, args=(command,), daemon=True,
                     name="dsp-command-watch").start()


def _end_with_command(command: int) -> None:
    """Exit at once when process ``command`` has ended. (The fork server, this worker's
    parent, outlives the command while a worker runs, so the parent is no sign.)"""
    while _running(command):
        time.sleep(PARENT_POLL_S)
    os._exit(EXIT_INTERRUPTED)


def _running(pid: int) -> bool:
    """Whether process ``pid`` runs: not gone, and not a zombie waiting to be reaped."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            state = f.read().rsplit(b")", 1)[1].split()[0]
    except (OSError, IndexError):
        return True  # no /proc here: alive as far as the signal tells
    return state not in (b"Z", b"X")


PRELOAD = ["__main__", "replay.runner"]
"""Imported once by the fork server, so a new pool worker starts without importing numpy,
OpenCV and mcap again."""


def _context() -> multiprocessing.context.BaseContext:
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(PRELOAD)
        return ctx
    return multiprocessing.get_context("spawn")  # pragma: no cover - macOS, Windows


def _map_pool(fn: Callable[[T], R], args: Sequence[T], processes: int, on_done: Done[R] | None,
              fail_fast: bool) -> list[Outcome[R]]:
    results: list[Outcome[R] | None] = [None] * len(args)
    pool = ProcessPoolExecutor(max_workers=processes, mp_context=_context(),
                               initializer=_start_worker,
                               initargs=(os.getpid(),))
    try:
        pending: set[Future[tuple[int, Outcome[R]]]] = {
            pool.submit(run_task, fn, i, arg) for i, arg in enumerate(args)}
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
