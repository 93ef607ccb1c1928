"""Polling for what another process does (a child started, a file appeared, a process ended),
for the tests that drive commands in child processes."""

from __future__ import annotations

import time
from collections.abc import Callable


def wait_for(condition: Callable[[], object], timeout_s: float, poll_s: float = 0.05) -> bool:
    """Whether ``condition()`` became true within ``timeout_s``, polled every ``poll_s``."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if condition():
            return True
        time.sleep(poll_s)
    return False
