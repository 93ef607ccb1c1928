"""Test-suite layout: one folder per package (``estimator/``, ``recorder/``, ``replay/``,
``scripts/``); ``synthetic.py`` beside this file makes small logs for any of them.

pytest's default import mode puts this file's folder on ``sys.path``, so every test can
``from synthetic import write_log``.
"""

from __future__ import annotations

import errno
import io
import os
import signal
from collections.abc import Callable, Iterator
from types import FrameType
from typing import Any

import pytest


class FullDisk(io.RawIOBase):
    """A file that takes ``room`` bytes, then fails as a full disk does."""

    def __init__(self, inner: Any, room: int) -> None:
        self.inner, self.room = inner, room

    def writable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def seek(self, offset: int, whence: int = 0) -> int:
        return int(self.inner.seek(offset, whence))

    def write(self, b: Any) -> int:
        if len(b) > self.room:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        self.room -= len(b)
        return int(self.inner.write(b))

    def close(self) -> None:
        self.inner.close()
        super().close()


@pytest.fixture
def full_disk(monkeypatch: pytest.MonkeyPatch) -> Callable[[int], None]:
    """``full_disk(room)``: every output written through :class:`dsp.atomic.AtomicFile`
    from then on takes ``room`` bytes, then fails with ENOSPC."""
    from dsp.atomic import AtomicFile

    real = AtomicFile.stream

    def fill(room: int) -> None:
        monkeypatch.setattr(AtomicFile, "stream", lambda self: FullDisk(real(self), room))

    return fill


@pytest.fixture
def no_hang() -> Iterator[None]:
    """Fails the test (TimeoutError) when it blocks for a minute: a read of a FIFO, a
    command waiting on nothing."""
    def hang(_signum: int, _frame: FrameType | None) -> None:
        raise TimeoutError("the test blocked")

    previous = signal.signal(signal.SIGALRM, hang)
    signal.alarm(60)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)
