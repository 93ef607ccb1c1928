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

Ten minutes is beyond any look-ahead a replay takes (at most 120 s: a pose tolerance and a
fusion window of 60 s each), so no message a replay could pair is lost; one image stamped a
million seconds ahead in a 20-step log is skipped, and fusion never waits on it.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable, Iterator
from typing import Generic, TypeVar

from estimator.constants import NS_PER_S

__all__ = ["AROUND", "FAR_NS", "OWN", "StampGate"]

FAR_NS = 600 * NS_PER_S
AROUND = 8
OWN = 3

R = TypeVar("R")


def _median(values: Iterable[int]) -> int:
    ordered = sorted(values)
    return ordered[(len(ordered) - 1) // 2]


class StampGate(Generic[R]):
    """Passes on the items of ``(stream, stamp, item)`` triples in order, holding
    :data:`AROUND` items back to see the stamps after each, and hands each absurd one to
    ``on_absurd`` instead."""

    def __init__(self, on_absurd: Callable[[R], None], far_ns: int = FAR_NS) -> None:
        self.on_absurd = on_absurd
        self.far_ns = far_ns

    def filter(self, items: Iterable[tuple[str, int, R]]) -> Iterator[R]:
        ahead: deque[tuple[str, int, R]] = deque()
        around: deque[int] = deque(maxlen=2 * AROUND + 1)  # the held and AROUND before
        own: dict[str, deque[int]] = {}
        for entry in items:
            ahead.append(entry)
            around.append(entry[1])
            if len(ahead) > AROUND:
                head = ahead.popleft()
                if self._sound(head, ahead, around, own):
                    yield head[2]
        while ahead:  # the end: fewer stamps after the head, as many before
            while len(around) > len(ahead) + AROUND:
                around.popleft()
            head = ahead.popleft()
            if self._sound(head, ahead, around, own):
                yield head[2]

    def _sound(self, entry: tuple[str, int, R], ahead: deque[tuple[str, int, R]],
               around: deque[int], own: dict[str, deque[int]]) -> bool:
        """Whether the item is kept (else it goes to ``on_absurd``)."""
        stream, stamp, item = entry
        mine = own.get(stream)
        if mine is None:
            mine = own[stream] = deque(maxlen=OWN)
        far = self.far_ns
        # near every stamp around it, so near their median: the common case, two C calls
        far_off = (max(around) - stamp > far or stamp - min(around) > far) and (
            abs(stamp - _median(around)) > far and self._far_from_own(stamp, stream, mine,
                                                                      ahead))
        mine.append(stamp)
        if far_off:
            self.on_absurd(item)
        return not far_off

    def _far_from_own(self, stamp: int, stream: str, mine: deque[int],
                      ahead: deque[tuple[str, int, R]]) -> bool:
        """Far from the median of the stream's stamps before and after it (or it has none)."""
        ours = [*mine, *(t for s, t, _ in ahead if s == stream)]
        return not ours or abs(stamp - _median(ours)) > self.far_ns
