"""Time synchronisation: poses at an image's stamp, ground truth at a step's stamp, and the
grouping of the robots' estimates into fusion steps.

Streaming with a fixed look-ahead: :class:`DelayLine` holds images until the log has moved
``lookahead_ns`` past their stamp, so every pose (and ground-truth sample) that could bracket
the image has been seen, and hands them on in stamp order. Histories keep only what the
look-ahead can still need, so memory is bounded by the look-ahead, not by the log's length.

One stamp far from the others costs its own message only: an image stamped ahead waits in
the delay line without holding back the images behind it, and a history prunes behind the
images still to come (``clock_ns``), not behind its newest sample, so a pose stamped ahead
(or poses in reverse order) never push out the poses the next images need.
"""

from __future__ import annotations

import bisect
import heapq
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Generic, TypeVar

from estimator.geometry import RobotPose, slerp, yaw_from_quaternion
from replay.log import ImageMessage, PoseMessage, TruthMessage

__all__ = [
    "DelayLine",
    "FusionGrouper",
    "History",
    "PoseMatch",
    "interpolate_pose",
    "interpolate_truth",
    "interpolate_truth_velocity",
    "interpolate_truth_z",
]

T = TypeVar("T", PoseMessage, TruthMessage)


class History(Generic[T]):
    """Time-ordered samples of one stream, pruned to a horizon behind the newest and to at
    most ``max_samples`` (the newest). Adding is O(log n) search + a bounded move, so stamps
    in any order cost the same."""

    def __init__(self, horizon_ns: int, max_samples: int = 4096) -> None:
        self.horizon_ns = horizon_ns
        self.max_samples = max(2, max_samples)
        self._stamps: list[int] = []
        self._items: list[T] = []
        self._lo = 0  # samples before it are pruned (compacted now and then)

    def __len__(self) -> int:
        return len(self._items) - self._lo

    def add(self, item: T, clock_ns: int | None = None) -> None:
        """Add a sample; prune what is ``horizon_ns`` behind the newest sample, or behind
        ``clock_ns`` (the oldest stamp still to be looked up) when that is earlier."""
        stamps = self._stamps
        if len(stamps) > self._lo and item.stamp_ns < stamps[-1]:
            # out of order (header stamps may disagree with log time): insert in place
            i = bisect.bisect_right(stamps, item.stamp_ns, self._lo)
            stamps.insert(i, item.stamp_ns)
            self._items.insert(i, item)
        else:
            stamps.append(item.stamp_ns)
            self._items.append(item)
        limit = stamps[-1] - self.horizon_ns
        if clock_ns is not None:
            limit = min(limit, clock_ns - self.horizon_ns)
        # keep one sample at or before the limit so a late image can still be bracketed
        cut = bisect.bisect_right(stamps, limit, self._lo) - 1
        lo = max(self._lo, cut)
        while len(stamps) - lo > self.max_samples:  # drop the sample furthest from the clock
            if clock_ns is not None and stamps[-1] - clock_ns > clock_ns - stamps[lo]:
                stamps.pop()
                self._items.pop()
            else:
                lo += 1
        self._lo = lo
        if lo > 1024 and lo * 2 > len(stamps):
            del stamps[:lo], self._items[:lo]
            self._lo = 0

    def neighbours(self, t_ns: int) -> tuple[T | None, T | None]:
        """The last sample at or before ``t_ns`` and the first at or after it."""
        i = bisect.bisect_right(self._stamps, t_ns, self._lo)
        before = self._items[i - 1] if i > self._lo else None
        if before is not None and before.stamp_ns == t_ns:
            return before, before
        after = self._items[i] if i < len(self._items) else None
        return before, after


@dataclass(frozen=True)
class PoseMatch:
    """A robot's pose at an image's stamp, and how far the nearest real pose was."""

    pose: RobotPose
    gap_ns: int
    """Distance from the image stamp to the nearest pose sample [ns]."""
    interpolated: bool
    covariance: tuple[float, ...] | None = None
    """The nearest pose sample's covariance over (x, y, yaw), row-major, when the log
    gives one (:attr:`~replay.log.PoseMessage.covariance`)."""


def interpolate_pose(history: History[PoseMessage], t_ns: int, tolerance_ns: int) -> (
    PoseMatch | None
):
    """The pose at ``t_ns``: position linear, orientation slerped between the neighbouring
    poses; the nearest one alone when only one side exists. None when the nearest pose is
    further than ``tolerance_ns`` away."""
    before, after = history.neighbours(t_ns)
    gaps = [abs(t_ns - p.stamp_ns) for p in (before, after) if p is not None]
    if not gaps or min(gaps) > tolerance_ns:
        return None
    gap = min(gaps)
    if before is not None and after is not None and after.stamp_ns != before.stamp_ns:
        s = (t_ns - before.stamp_ns) / (after.stamp_ns - before.stamp_ns)
        x = before.x_m + s * (after.x_m - before.x_m)
        y = before.y_m + s * (after.y_m - before.y_m)
        q = slerp((before.qx, before.qy, before.qz, before.qw),
                  (after.qx, after.qy, after.qz, after.qw), s)
        nearer = before if t_ns - before.stamp_ns <= after.stamp_ns - t_ns else after
        return PoseMatch(RobotPose(x, y, yaw_from_quaternion(*q)), gap, True,
                         nearer.covariance)
    p = before if before is not None else after
    assert p is not None
    return PoseMatch(RobotPose(p.x_m, p.y_m, yaw_from_quaternion(p.qx, p.qy, p.qz, p.qw)),
                     gap, False, p.covariance)


def interpolate_truth(history: History[TruthMessage], t_ns: int, tolerance_ns: int) -> (
    tuple[float, float] | None
):
    """The true ball position at ``t_ns`` (linear), None when no sample is near enough."""
    before, after = history.neighbours(t_ns)
    gaps = [abs(t_ns - p.stamp_ns) for p in (before, after) if p is not None]
    if not gaps or min(gaps) > tolerance_ns:
        return None
    if before is not None and after is not None and after.stamp_ns != before.stamp_ns:
        s = (t_ns - before.stamp_ns) / (after.stamp_ns - before.stamp_ns)
        return (before.x_m + s * (after.x_m - before.x_m),
                before.y_m + s * (after.y_m - before.y_m))
    p = before if before is not None else after
    assert p is not None
    return (p.x_m, p.y_m)


def interpolate_truth_z(history: History[TruthMessage], t_ns: int, tolerance_ns: int) -> (
    float | None
):
    """The true height of the ball's centre at ``t_ns`` (linear), None when no sample is
    near enough or the nearest has no height."""
    before, after = history.neighbours(t_ns)
    near = [p for p in (before, after) if p is not None]
    if not near or min(abs(t_ns - p.stamp_ns) for p in near) > tolerance_ns:
        return None
    if (before is not None and after is not None and before.z_m is not None
            and after.z_m is not None and after.stamp_ns != before.stamp_ns):
        s = (t_ns - before.stamp_ns) / (after.stamp_ns - before.stamp_ns)
        return before.z_m + s * (after.z_m - before.z_m)
    return min(near, key=lambda p: abs(t_ns - p.stamp_ns)).z_m


def _velocity(p: TruthMessage | None) -> tuple[float, float] | None:
    if p is None or p.vx_m_s is None or p.vy_m_s is None:
        return None
    return (p.vx_m_s, p.vy_m_s)


def interpolate_truth_velocity(history: History[TruthMessage], t_ns: int, tolerance_ns: int) -> (
    tuple[float, float] | None
):
    """The ball's true velocity at ``t_ns`` (linear), from samples that carry one
    (nav_msgs/Odometry); None when no sample is near enough or the nearest has none."""
    before, after = history.neighbours(t_ns)
    near = [p for p in (before, after) if p is not None]
    if not near or min(abs(t_ns - p.stamp_ns) for p in near) > tolerance_ns:
        return None
    vb, va = _velocity(before), _velocity(after)
    if before is not None and after is not None and vb is not None and va is not None and (
            after.stamp_ns != before.stamp_ns):
        s = (t_ns - before.stamp_ns) / (after.stamp_ns - before.stamp_ns)
        return (vb[0] + s * (va[0] - vb[0]), vb[1] + s * (va[1] - vb[1]))
    return _velocity(min(near, key=lambda p: abs(t_ns - p.stamp_ns)))


class DelayLine:
    """Holds images until the log time has passed their stamp by ``lookahead_ns``, and hands
    them on in stamp order (equal stamps in arrival order); never more than ``max_images``
    images or ``max_bytes`` of image data (the earliest stamped go on early, so images
    stamped far in the future cannot pile up, nor hold back the others)."""

    def __init__(self, lookahead_ns: int, max_images: int = 256,
                 max_bytes: int = 256 * 1024 * 1024) -> None:
        self.lookahead_ns = lookahead_ns
        self.max_images = max_images
        self.max_bytes = max_bytes
        self._heap: list[tuple[int, int, ImageMessage]] = []
        self._arrivals = 0
        self._bytes = 0
        self.last_stamp_ns: int | None = None
        """The stamp of the image handed on last."""

    def __len__(self) -> int:
        return len(self._heap)

    @property
    def clock_ns(self) -> int | None:
        """The earliest stamp an image still to come out has (None before any image)."""
        return self._heap[0][0] if self._heap else self.last_stamp_ns

    def push(self, image: ImageMessage) -> None:
        heapq.heappush(self._heap, (image.stamp_ns, self._arrivals, image))
        self._arrivals += 1
        self._bytes += len(image.data)

    def ready(self, now_ns: int) -> Iterator[ImageMessage]:
        """Images whose look-ahead has passed at log time ``now_ns`` (or that overflow the
        bounds), in stamp order."""
        h = self._heap
        while h and (h[0][0] + self.lookahead_ns < now_ns or len(h) > self.max_images
                     or self._bytes > self.max_bytes):
            yield self._pop()

    def _pop(self) -> ImageMessage:
        stamp, _, image = heapq.heappop(self._heap)
        self._bytes -= len(image.data)
        self.last_stamp_ns = stamp
        return image

    def drain(self) -> Iterator[ImageMessage]:
        while self._heap:
            yield self._pop()


E = TypeVar("E")


class FusionGrouper(Generic[E]):
    """Groups per-robot items (in stamp order) into steps: a step starts at the first item's
    stamp t0 and takes every item with stamp < t0 + window; a robot seen twice in one step
    keeps its latest item. Items arriving late join the open step."""

    def __init__(self, window_ns: int) -> None:
        self.window_ns = max(1, window_ns)
        self._t0: int | None = None
        self._items: dict[str, E] = {}

    def add(self, robot: str, stamp_ns: int, item: E) -> list[tuple[int, dict[str, E]]]:
        """Add an item; returns the steps it closed (0 or 1)."""
        closed = []
        if self._t0 is not None and stamp_ns >= self._t0 + self.window_ns:
            closed.append((self._t0, self._items))
            self._t0, self._items = None, {}
        if self._t0 is None:
            self._t0 = stamp_ns
        self._items[robot] = item
        return closed

    def flush(self) -> list[tuple[int, dict[str, E]]]:
        if self._t0 is None:
            return []
        out = [(self._t0, self._items)]
        self._t0, self._items = None, {}
        return out
