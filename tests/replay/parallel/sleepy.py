"""A task for the pool tests: it says it started, naps, then says it is done (files)."""

from __future__ import annotations

import time
from pathlib import Path


def nap(path: str) -> str:
    Path(path + ".started").touch()
    time.sleep(20.0)
    Path(path + ".done").touch()
    return path
