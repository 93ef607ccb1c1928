"""Stamps a log cannot mean: a message whose header stamp is absurdly far from the stamps
around it is a bad message, skipped and counted like one that does not decode.

"Absurd" is relative to the log itself, never to a clock of ours, so a log stamped in sim
time from 0, in Unix epoch nanoseconds, or in sim time while its ``log_time`` is the wall
clock reads the same. A message is absurd when its stamp is more than :data:`FAR_NS` from

- the median stamp of the :data:`AROUND` messages before it and the :data:`AROUND` after it
  (every stream, in log-time order: a log the recorder paused, or two recordings a day apart
  in one file, keep every message, since the median moves with the majority at the seam), and
- the median stamp of its own stream's last :data:`OWN` messages and of those among the
  :data:`AROUND` after it (a robot's images, its poses, the ground truth: a stream stamped
  consistently on its own clock, even in reverse, is left to the pairing, which reports
  what it cannot pair).

Ten minutes is beyond any look-ahead, tolerance or window a replay takes (each at most 60 s),
so no message a replay could use is lost; the one image stamped in the year 2055 of a
20-step log is skipped, and fusion never waits on it.
"""

from __future__ import annotations

import bisect
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from typing import Generic, TypeVar

from estimator.constants import NS_PER_S

__all__ = ["AROUND", "FAR_NS", "OWN", "StampGate"]

FAR_NS = 600 * NS_PER_S
AROUND = 8
OWN = 3

R = TypeVar("R")


class _Window:
    """The last ``n`` values with their median."""

    def __init__(self, n: int) -> None:
        self.order: deque[int] = deque()
        self.sorted: list[int] = []
        self.n = n

    def add(self, value: int) -> None:
        self.order.append(value)
        bisect.insort(self.sorted, value)
        if len(self.order) > self.n:
            old = self.order.popleft()
            del self.sorted[bisect.bisect_left(self.sorted, old)]

    def remove_first(self) -> None:
        old = self.order.popleft()
        del self.sorted[bisect.bisect_left(self.sorted, old)]

    def median(self) -> int | None:
        s = self.sorted
        return s[(len(s) - 1) // 2] if s else None


class StampGate(Generic[R]):
    """Passes on the items of ``(stream, stamp, item)`` triples in order, holding
    :data:`AROUND` items back to see the stamps after each, and hands each absurd one to
    ``on_absurd`` instead."""

    def __init__(self, on_absurd: Callable[[R], None], far_ns: int = FAR_NS) -> None:
        self.on_absurd = on_absurd
        self.far_ns = far_ns

    def filter(self, items: Iterable[tuple[str, int, R]]) -> Iterator[R]:
        ahead: deque[tuple[str, int, R]] = deque()
        around = _Window(2 * AROUND + 1)  # the held items and the AROUND before the head
        own: dict[str, _Window] = {}
        for entry in items:
            ahead.append(entry)
            around.add(entry[1])
            if len(ahead) > AROUND:
                yield from self._judge(ahead.popleft(), ahead, around, own)
        while ahead:  # the end: fewer stamps after the head, as many before
            while len(around.order) > len(ahead) + AROUND:
                around.remove_first()
            yield from self._judge(ahead.popleft(), ahead, around, own)

    def _judge(self, entry: tuple[str, int, R], ahead: deque[tuple[str, int, R]],
               around: _Window, own: dict[str, _Window]) -> Iterator[R]:
        stream, stamp, item = entry
        mine = own.setdefault(stream, _Window(OWN))
        ours = sorted([*mine.order, *(t for s, t, _ in ahead if s == stream)])
        far = self._far(stamp, around.median()) and (
            not ours or self._far(stamp, ours[(len(ours) - 1) // 2]))
        mine.add(stamp)
        if far:
            self.on_absurd(item)
        else:
            yield item

    def _far(self, stamp: int, median: int | None) -> bool:
        return median is not None and abs(stamp - median) > self.far_ns
