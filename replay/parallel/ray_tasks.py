"""The Ray side of :func:`replay.parallel.map_tasks` (Ray is imported only for ``--ray``).

Ray's own conventions (checked against Ray 2.x's ``ray.init``): with ``RAY_ADDRESS`` set,
``ray.init()`` joins that cluster (``auto`` finds one started on this machine with ``ray
start --head``) and ``num_cpus`` must not be given; without it we ask for a fresh local
instance (``address="local"``) with ``num_cpus`` from ``--workers`` when given. A Ray that
this process already initialised (a test session) is used and left running.

A local instance is watched by :mod:`replay.parallel.ray_reaper`: killed outright (SIGKILL,
the OOM killer), the command would leave Ray's dashboard and runtime-env agents running on;
the reaper kills what the command started once the command is gone.
"""

from __future__ import annotations

import importlib
import logging
import os
from collections.abc import Callable, Sequence
from types import ModuleType
from typing import TypeVar

from dsp.errors import InputError
from replay.parallel.ray_reaper import start_reaper, stop_reaper
from replay.parallel.tasks import (
    RAY_MAX_RETRIES,
    Done,
    Outcome,
    RayUnavailableError,
    TaskFailure,
    Workers,
)

__all__ = ["import_ray", "map_ray"]

T = TypeVar("T")
R = TypeVar("R")


def import_ray() -> ModuleType:
    """The ``ray`` module, or :class:`RayUnavailableError` saying how to install it."""
    try:
        return importlib.import_module("ray")
    except ImportError as err:
        raise RayUnavailableError() from err


def _init(ray: ModuleType, workers: Workers) -> bool:
    """Initialise Ray unless it already is; True when this call started it."""
    if ray.is_initialized():
        return False
    quiet: dict[str, object] = {"logging_level": logging.ERROR, "log_to_driver": False}
    address = os.environ.get("RAY_ADDRESS")
    try:
        if address:
            ray.init(**quiet)  # joins the cluster RAY_ADDRESS names
        else:
            ray.init(address="local", num_cpus=workers.count, include_dashboard=False,
                     **quiet)
    except (ConnectionError, ValueError, RuntimeError) as err:
        where = f"the Ray cluster at RAY_ADDRESS={address}" if address else "a local Ray"
        raise InputError(f"cannot start or join {where}: {_one_line(err)}") from err
    return True


def _one_line(err: BaseException) -> str:
    text = str(err).strip().splitlines()
    return f"{type(err).__name__}: {text[0] if text else ''}".rstrip(": ")


def map_ray(call: Callable[[Callable[[T], R], int, T], tuple[int, Outcome[R]]],
            fn: Callable[[T], R], args: Sequence[T], workers: Workers, *,
            on_done: Done[R] | None, fail_fast: bool) -> list[Outcome[R]]:
    """Submit ``call(fn, i, arg)`` for every argument as a Ray task; outcomes in order."""
    ray = import_ray()
    local = not ray.is_initialized() and not os.environ.get("RAY_ADDRESS")
    reaper = start_reaper() if local else None  # the local Ray dies with this command
    try:
        started = _init(ray, workers)
    except BaseException:
        stop_reaper(reaper)
        raise
    try:
        remote = ray.remote(num_cpus=1, max_retries=RAY_MAX_RETRIES,
                            retry_exceptions=False)(call)
        refs = [remote.remote(fn, i, arg) for i, arg in enumerate(args)]
        return _collect(ray, refs, on_done, fail_fast)
    finally:
        stop_reaper(reaper)
        if started:
            ray.shutdown()


def _collect(ray: ModuleType, refs: list[object], on_done: Done[R] | None,
             fail_fast: bool) -> list[Outcome[R]]:
    index = {ref: i for i, ref in enumerate(refs)}
    results: list[Outcome[R] | None] = [None] * len(refs)
    pending = list(refs)
    try:
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                i = index[ref]
                try:
                    _, outcome = ray.get(ref)
                except ray.exceptions.RayError as err:  # the worker was lost, retries spent
                    outcome = Outcome(failure=TaskFailure(f"Ray task failed: {_one_line(err)}"))
                results[i] = outcome
                if on_done is not None:
                    on_done(i, outcome)
                if fail_fast and outcome.failure is not None:
                    _cancel(ray, pending)
                    outcome.failure.raise_()
    except KeyboardInterrupt:
        _cancel(ray, pending)
        raise
    return [r for r in results if r is not None]


def _cancel(ray: ModuleType, refs: list[object]) -> None:
    for ref in refs:
        ray.cancel(ref, force=True)
