"""Clutter: where the track keeps rejecting estimates of something that does not move.

A false blob (an orange object beside the field that a robot takes for the ball when the
ball is out of its sight) gives estimates at one place, again and again, that the track
rejects. A lone rejected estimate may be the ball just after a kick (the tracker lets it
explain a kick on its own); one at a place where rejected estimates keep falling is not.
:class:`ClutterMap` remembers the rejected estimates of the last ``memory_ns`` and calls a
position clutter when at least ``count`` of them, spread over at least ``span_ns``, lie
within ``radius_m`` of it. The ball itself is rejected at one place only when it lies
still away from the track, which re-acquisition handles (a still object never displaces a
moving track there either). Pure and deterministic.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

__all__ = ["ClutterMap"]


@dataclass
class ClutterMap:
    """Rejected estimates of the last ``memory_ns``; :meth:`covers` says where they pile up."""

    memory_ns: int = 3_000_000_000
    radius_m: float = 0.3
    count: int = 3
    span_ns: int = 200_000_000
    _points: deque[tuple[int, float, float]] = field(default_factory=deque)

    def add(self, stamp_ns: int, x_m: float, y_m: float) -> None:
        """A rejected estimate (in about stamp order)."""
        self._points.append((stamp_ns, x_m, y_m))
        while self._points and stamp_ns - self._points[0][0] > self.memory_ns:
            self._points.popleft()

    def covers(self, stamp_ns: int, x_m: float, y_m: float) -> bool:
        """Do ``count`` rejected estimates of the last ``memory_ns`` before ``stamp_ns``,
        over ``span_ns`` or more, lie within ``radius_m`` of (x_m, y_m)?"""
        r2 = self.radius_m**2
        near = [t for t, x, y in self._points
                if 0 <= stamp_ns - t <= self.memory_ns and (x - x_m) ** 2 + (y - y_m) ** 2 <= r2]
        return len(near) >= self.count and max(near) - min(near) >= self.span_ns
