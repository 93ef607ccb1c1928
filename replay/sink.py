"""The shape every replay sink has: one call per frame, one per fused step, one to close.

The runner opens its sinks in one :class:`contextlib.ExitStack`; leaving it calls
``close(ok)`` on each, ``ok`` False when the replay failed, so a sink commits its output
only after a whole replay (results JSON, estimates MCAP, an .rrd) and discards it otherwise.
"""

from __future__ import annotations

from types import TracebackType
from typing import TYPE_CHECKING, Protocol

import numpy as np

if TYPE_CHECKING:
    from replay.records import FrameResult, StepResult

__all__ = ["Sink", "SinkBase"]


class Sink(Protocol):
    """Receives every frame and step of a replay, in log order."""

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        """One image's result; ``image_bgr`` its pixels (None when it did not decode)."""

    def step(self, result: StepResult) -> None:
        """One fusion step's result."""

    def close(self, ok: bool) -> None:
        """End of the replay: commit the output when ``ok``, else discard it."""

    def __enter__(self) -> Sink: ...

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None: ...


class SinkBase:
    """A sink that ignores what it is not interested in, usable in a ``with`` block."""

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        return None

    def step(self, result: StepResult) -> None:
        return None

    def close(self, ok: bool) -> None:
        return None

    def __enter__(self) -> SinkBase:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close(exc_type is None)
