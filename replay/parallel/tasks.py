"""What :func:`replay.parallel.map_tasks` works with: where tasks run (:class:`Workers`)
and how each one ended (:class:`Outcome`, :class:`TaskFailure`), the same wherever it ran.

A task that raises comes back as a :class:`TaskFailure` (message and exit code, never a
pickled exception; :func:`run_task` catches it in the worker), so the outcome does not
depend on where the task ran.
"""

from __future__ import annotations

import os
import socket
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from typing import Generic, TypeVar

from dsp.errors import EXIT_INPUT, DspError, UsageError

__all__ = [
    "MAX_WORKERS",
    "RAY_INSTALL_HINT",
    "RAY_MAX_RETRIES",
    "Done",
    "Outcome",
    "RayUnavailableError",
    "TaskFailure",
    "Workers",
    "available_cores",
    "run_task",
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


def run_task(fn: Callable[[T], R], index: int, arg: T) -> tuple[int, Outcome[R]]:
    """Run one task in a worker; whatever it raises comes back as data."""
    try:
        return index, Outcome(value=fn(arg))
    except Exception as err:
        return index, Outcome(failure=_failure(err))


Done = Callable[[int, "Outcome[R]"], None]
"""``on_done(index, outcome)``: told of each task as it ends."""
