"""Decode and detect images ahead of the replay, in a small thread pool.

Decoding a PNG or JPEG, finding the ball and (``--localise lines``) the field lines need
nothing but the image, and OpenCV releases
the GIL while it works, so they can run in threads while the main thread reads the log and
estimates, fuses and writes in log order. :class:`Ahead` takes the images in the order the
runner will ask for them (:meth:`Ahead.push`), keeps at most ``depth`` of them in flight and
hands each one's result back when the runner reaches it (:meth:`Ahead.take`). Results are
taken in push order whatever the thread count, and the work is a pure function of the
image message, so a replay's outputs are the same bytes with 1 thread or many. Memory: at
most ``depth`` decoded images wait in the pool, however long the look-ahead.

With ``threads`` 1 there is no pool: :meth:`Ahead.take` does the work in the caller.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from replay.estimation import Detected, detect
from replay.localise import LocalisedPoints
from replay.log import DEFAULT_MAX_PIXELS, ImageMessage, decode_image, image_problem
from replay.plugins import Detector
from replay.real_ball import BallFinder

__all__ = ["Ahead", "Decoded", "LinePointsFn", "decode_and_detect"]

LinePointsFn = Callable[[str, "np.ndarray | None"], "LocalisedPoints | None"]
"""(robot, image) -> the image's field-line points (:meth:`replay.localise.Localiser.points`)."""


@dataclass(frozen=True)
class Decoded:
    """One image message decoded (None: it does not decode), its detection and, when
    localising, its field-line points."""

    image: np.ndarray | None
    detected: Detected
    seconds: float
    """Wall time of the decoding, detection and line points."""
    problem: str | None = None
    """Why the image does not decode, when it does not (:func:`replay.log.image_problem`)."""
    points: LocalisedPoints | None = None


def decode_and_detect(msg: ImageMessage, *, max_pixels: int = DEFAULT_MAX_PIXELS,
                      finder: BallFinder | None = None, detector: Detector | None = None,
                      line_points: LinePointsFn | None = None) -> Decoded:
    """Decode an image message (none over ``max_pixels``), detect the ball in it (the
    paper's chain, ``finder``'s real detector or ``detector``, one from outside) and, with
    ``line_points``, find its field lines (pure, thread-safe)."""
    t0 = time.perf_counter()
    image = decode_image(msg, max_pixels=max_pixels)
    detected = detect(image, finder, detector)
    points = None if line_points is None else line_points(msg.robot, image)
    problem = None if image is not None else image_problem(msg, max_pixels=max_pixels)
    return Decoded(image, detected, time.perf_counter() - t0, problem, points)


class Ahead:
    """``work`` applied to pushed image messages ahead of time, in ``threads`` threads, with
    at most ``depth`` results in flight; results are taken in push order."""

    def __init__(self, threads: int, *, depth: int | None = None,
                 work: Callable[[ImageMessage], Decoded] = decode_and_detect) -> None:
        if threads < 1:
            raise ValueError(f"threads = {threads}; must be >= 1")
        self.threads = threads
        self.depth = max(1, depth if depth is not None else 2 * threads)
        self.work = work
        self._pool = (ThreadPoolExecutor(threads, thread_name_prefix="replay-decode")
                      if threads > 1 else None)
        self._waiting: deque[ImageMessage] = deque()
        self._flight: deque[tuple[ImageMessage, Future[Decoded]]] = deque()

    @property
    def in_flight(self) -> int:
        """Images submitted to the pool whose results are not taken yet."""
        return len(self._flight)

    def push(self, msg: ImageMessage) -> None:
        """An image the caller will :meth:`take`, in this order."""
        if self._pool is None:
            return
        self._waiting.append(msg)
        self._fill()

    def _fill(self) -> None:
        assert self._pool is not None
        while self._waiting and len(self._flight) < self.depth:
            msg = self._waiting.popleft()
            self._flight.append((msg, self._pool.submit(self.work, msg)))

    def take(self, msg: ImageMessage) -> Decoded:
        """The result for ``msg``: from the pool when it was pushed, else computed here."""
        if self._flight and self._flight[0][0] is msg:
            _, future = self._flight.popleft()
            result = future.result()
        else:
            if self._waiting and self._waiting[0] is msg:
                self._waiting.popleft()
            result = self.work(msg)
        if self._pool is not None:
            self._fill()
        return result

    def close(self) -> None:
        """Drop what is still waiting and stop the threads."""
        self._waiting.clear()
        for _, future in self._flight:
            future.cancel()
        self._flight.clear()
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)

    def __enter__(self) -> Ahead:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
