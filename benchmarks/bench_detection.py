"""Time detect_ball on 1080 x 1080 omni frames, beside one frame copy of the same frames.

Two sets of frames: the recorded ones of the golden logs of a ball on the ground
(``logs/golden/*.mcap`` but ``lobs``: 60 frames, the ball in 56, the set the README's figures
were measured on), taken in turn so that every call meets a frame not in the cache,
as a replay does; and one synthetic frame (a green field with white lines, an orange ball
with a shaded limb, a dark robot body) taken again and again, so it stays in the cache.
For each: the median time per frame of detect_ball (the coarse-to-fine search, the
default), of detect_ball on the whole image (``search_stride_px=1``, the reference path),
of detect_ball looking for a magenta ball, a colour not in the frames (the coarse search
alone: the rows are tested, nothing is found, no chain runs), of ``frame.copy()``
(touching every byte once), and of summing every third row (``cv2.sumElems(frame[::3])``:
reading the rows the search tests, its memory floor), and the ratios to the copy. One
run, side by side: each pass over the frames (the synthetic frame: 20 calls) runs one
function, and the functions' passes take turns, so the machine's load moves all figures
together.

Run: python benchmarks/bench_detection.py [--repeat 10]
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from estimator.detection import DetectionParams, detect_ball

ROOT = Path(__file__).resolve().parents[1]


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


def medians_ms(fns: dict[str, Callable[[npt.NDArray[np.uint8]], object]],
               frames: list[npt.NDArray[np.uint8]], repeat: int) -> dict[str, float]:
    """Median ms per frame of each function, their passes over the frames interleaved (each
    pass starts with the next function in turn), so that a change in the machine's load
    falls on all of them alike."""
    times: dict[str, list[float]] = {name: [] for name in fns}
    names = list(fns)
    for k in range(repeat):
        for name in names[k % len(names):] + names[:k % len(names)]:
            fn, out = fns[name], times[name]
            for frame in frames:
                t0 = time.perf_counter()
                fn(frame)
                out.append(time.perf_counter() - t0)
    return {name: 1e3 * statistics.median(t) for name, t in times.items()}


def recorded_frames() -> list[npt.NDArray[np.uint8]]:
    from replay.log import ImageMessage, LogReader, decode_image

    frames = []
    for log in sorted((ROOT / "logs" / "golden").glob("*.mcap")):
        if log.stem == "lobs":  # added later: the set stays the one the figures were made on
            continue
        with LogReader(log) as reader:
            for msg in reader.messages():
                if isinstance(msg, ImageMessage) and (img := decode_image(msg)) is not None:
                    frames.append(img)
    return frames


def row(name: str, frames: list[npt.NDArray[np.uint8]], params: DetectionParams,
        repeat: int) -> str:
    whole = dataclasses.replace(params, search_stride_px=1)
    absent = dataclasses.replace(params, hsv_lower=(140, 150, 150), hsv_upper=(160, 255, 255))
    for frame in frames[:5]:  # warm up (and the cached colour tests)
        detect_ball(frame, params)
        detect_ball(frame, absent)
    ms = medians_ms({"fast": lambda f: detect_ball(f, params),
                     "ref": lambda f: detect_ball(f, whole),
                     "search": lambda f: detect_ball(f, absent),
                     "copy": lambda f: f.copy(),
                     "rows": lambda f: cv2.sumElems(f[::3])}, frames, repeat)
    fast, ref, search, copy, rows = (ms[k] for k in ("fast", "ref", "search", "copy", "rows"))
    return (f"{name:28s} detect_ball {fast:6.3f} ms ({fast / copy:4.1f}x)   whole image "
            f"{ref:6.3f} ms ({ref / copy:5.1f}x)   search alone (magenta) {search:6.3f} ms "
            f"({search / copy:3.1f}x)   frame.copy() {copy:6.3f} ms   every third row read "
            f"{rows:6.3f} ms ({rows / copy:3.1f}x)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--repeat", type=int, default=10,
                        help="passes of each function over the frames")
    args = parser.parse_args()
    frame = make_frame()
    params = DetectionParams(ignore_radius_px=100.0)
    if detect_ball(frame, params) is None:
        raise SystemExit("benchmark frame: no ball detected")
    recorded = recorded_frames()
    print(f"median ms per 1080x1080 frame, one run; cv2 threads {cv2.getNumThreads()}")
    print(row(f"recorded ({len(recorded)} frames, cold)", recorded, DetectionParams(),
              args.repeat))
    print(row("synthetic (1 frame, cached)", [frame] * 20, params, args.repeat))


if __name__ == "__main__":
    main()
