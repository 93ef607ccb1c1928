"""Time detect_ball on a realistic 1080 x 1080 omni frame, against one frame copy.

A green field with white lines, an orange ball (anti-aliased, with a shaded limb) and a
dark robot body in the image centre. Prints the median time per frame of detect_ball and
of ``frame.copy()`` (the cost of touching every byte once), and their ratio.

Run: python benchmarks/bench_detection.py [--repeat 200]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import cv2
import numpy as np
import numpy.typing as npt

from estimator.detection import DetectionParams, detect_ball


def make_frame(size: int = 1080) -> npt.NDArray[np.uint8]:
    """A deterministic synthetic omni frame (BGR)."""
    rng = np.random.default_rng(0)
    frame = np.empty((size, size, 3), np.uint8)
    frame[:] = (40, 140, 40)  # green field
    noise = rng.integers(-6, 7, size=(size, size, 3))
    frame = np.clip(frame.astype(np.int16) + noise, 0, 255).astype(np.uint8)
    c = size // 2 - 1
    white = (235, 235, 235)
    cv2.line(frame, (0, 300), (size - 1, 330), white, 6, cv2.LINE_AA)  # a touch line
    cv2.line(frame, (760, 0), (740, size - 1), white, 6, cv2.LINE_AA)  # the halfway line
    cv2.circle(frame, (740, 540), 240, white, 6, cv2.LINE_AA)  # the centre circle
    cv2.circle(frame, (c, c), 90, (25, 25, 25), -1, cv2.LINE_AA)  # the robot's own body
    cv2.circle(frame, (420, 260), 16, (0, 50, 115), -1, cv2.LINE_AA)  # shaded limb
    cv2.circle(frame, (418, 258), 12, (0, 110, 255), -1, cv2.LINE_AA)  # the orange ball
    return frame


def median_ms(fn: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=200)
    args = parser.parse_args()
    frame = make_frame()
    params = DetectionParams(ignore_radius_px=100.0)
    ball = detect_ball(frame, params)
    if ball is None:
        raise SystemExit("benchmark frame: no ball detected")
    for _ in range(5):  # warm up
        detect_ball(frame, params)
    detect = median_ms(lambda: detect_ball(frame, params), args.repeat)
    copy = median_ms(frame.copy, args.repeat)
    where = f"({ball.cx_px:.2f}, {ball.cy_px:.2f}) px"
    print(f"frame 1080x1080 BGR, ball at {where}, {args.repeat} runs")
    print(f"detect_ball : {detect:8.3f} ms/frame (median)")
    print(f"frame.copy(): {copy:8.3f} ms/frame (median)")
    print(f"ratio       : {detect / copy:8.1f}x")


if __name__ == "__main__":
    main()
