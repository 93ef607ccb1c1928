"""Fixtures for the replay tests: one local Ray instance (2 CPUs) for the whole session.

Ray takes seconds to start, so the tests that run tasks on it share this one; the code
under test finds it initialised and uses it as it is (replay.parallel.ray_tasks)."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from typing import Any

import pytest


@pytest.fixture(scope="session")
def ray_local() -> Iterator[Any]:
    ray = pytest.importorskip(
        "ray", reason="Ray is not installed (pip install -e '.[ray]'; the test extra has it)")
    started = not ray.is_initialized()
    if started:
        ray.init(address="local", num_cpus=2, include_dashboard=False,
                 logging_level=logging.ERROR, log_to_driver=False)
    yield ray
    if started:
        ray.shutdown()
