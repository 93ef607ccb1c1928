"""Independent tasks on all cores or on a Ray cluster, results in task order.

- :mod:`replay.parallel.pool`: :func:`map_tasks`, serial, in a local process pool, or (through
  :mod:`replay.parallel.ray_tasks`) as Ray tasks;
- :mod:`replay.parallel.tasks`: :class:`Workers`, :class:`Outcome`, :class:`TaskFailure`;
- :mod:`replay.parallel.cli`: the ``--workers`` / ``--ray`` flags the commands share (imported
  by the commands only).

Used by batch replay (:mod:`replay.batch`) and the evaluation suites (:mod:`replay.evaluate`);
it knows nothing of either.
"""

from __future__ import annotations

from replay.parallel.pool import map_tasks
from replay.parallel.tasks import (
    RAY_INSTALL_HINT,
    RAY_MAX_RETRIES,
    Done,
    Outcome,
    RayUnavailableError,
    TaskFailure,
    Workers,
    available_cores,
)

__all__ = [
    "RAY_INSTALL_HINT",
    "RAY_MAX_RETRIES",
    "Done",
    "Outcome",
    "RayUnavailableError",
    "TaskFailure",
    "Workers",
    "available_cores",
    "map_tasks",
]
