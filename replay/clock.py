"""The ticks of ``--clock``: steps without images, only where the log has images near them.

A tick is the fused estimate a robot's control loop would read at that moment. Between two
image steps the clock ticks within ``reach_ns`` (the pose tolerance, at least one period)
after the earlier and before the later one; the ticks in the middle of a longer gap are
skipped and counted. So the work is bounded by the images, not by the span of the stamps: a
log whose stamps jump 1e6 s ahead made one tick per period across the jump (100,000 steps at
0.1 Hz, months of work at 10 kHz); it now makes at most ``2 (reach / period + 1)`` ticks per
image step, and the replay says how many it skipped (:meth:`Clock.note`).
"""

from __future__ import annotations

from collections.abc import Iterator

__all__ = ["Clock"]

NS_PER_S = 1_000_000_000


class Clock:
    """The ticks k * ``period_ns`` between image steps given in stamp order."""

    def __init__(self, period_ns: int, reach_ns: int) -> None:
        self.period_ns = max(1, period_ns)
        self.reach_ns = max(reach_ns, self.period_ns)
        self.next_ns: int | None = None
        """The next tick not yet made (None before the first image step)."""
        self.last_ns: int | None = None
        """The last image step's stamp."""
        self.skipped = 0
        """Ticks skipped in gaps without images."""
        self.gaps = 0
        """The gaps they were skipped in."""

    def _ceil(self, t_ns: int) -> int:
        """The first tick at or after ``t_ns``."""
        return -(-t_ns // self.period_ns) * self.period_ns

    def before(self, t_ns: int) -> Iterator[int]:
        """The ticks before the image step at ``t_ns``: those within reach of the last
        image step, then (skipping the rest) those within reach of this one."""
        if self.next_ns is None:
            self.next_ns = self._ceil(t_ns)
        if self.last_ns is not None:
            near_last = min(t_ns, self.last_ns + self.reach_ns + 1)
            while self.next_ns < near_last:
                yield self.next_ns
                self.next_ns += self.period_ns
        near = self._ceil(t_ns - self.reach_ns)
        if near > self.next_ns:
            self.skipped += (near - self.next_ns) // self.period_ns
            self.gaps += 1
            self.next_ns = near
        while self.next_ns < t_ns:
            yield self.next_ns
            self.next_ns += self.period_ns

    def at(self, t_ns: int) -> Iterator[int]:
        """The tick at the image step at ``t_ns``, if there is one (made after the step)."""
        self.last_ns = t_ns
        if self.next_ns == t_ns:
            yield t_ns
            self.next_ns += self.period_ns

    def note(self, log: str) -> str | None:
        """One line saying what was skipped, None when nothing was."""
        if not self.skipped:
            return None
        return (f"{log}: --clock skipped {self.skipped} tick(s) in {self.gaps} gap(s) "
                f"without images (ticks are made only within "
                f"{self.reach_ns / NS_PER_S:g} s of an image)")
