"""The flags that choose where a command's tasks run: ``--workers N`` and ``--ray``."""

from __future__ import annotations

import argparse

from replay.parallel.ray_tasks import import_ray
from replay.parallel.tasks import Workers

__all__ = ["add_worker_arguments", "workers_from_args"]


def add_worker_arguments(parser: argparse._ActionsContainer, *, what: str) -> None:
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
        import_ray()
    return workers
