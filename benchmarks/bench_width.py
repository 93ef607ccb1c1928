"""Time ``--width-range`` per detection: the blob's width beside the ball's detection.

Replays a log (default ``logs/golden/lobs.mcap``) once, and at every frame with a detected
ball a sink times, on the replay's own thread with OpenCV on one core
(``cv2.setNumThreads(1)``), in CPU time of that thread (``time.thread_time``: what other
processes on a busy machine do not move), taking turns: the ball's detection in the frame's
image (``detect_ball``, what every replay does) and the width's range of that detection's
outline (:func:`estimator.width.width_range`, what ``--width-range`` adds). Each is run
``--repeat`` times a frame (the width takes microseconds, below one call's timer
resolution) and its mean per call kept. It prints each one's median per frame and the
width as a fraction of the detection.

Run: python benchmarks/bench_width.py [LOG] [--repeat N]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from dsp.cli import run_main
from estimator.detection import detect_ball
from estimator.width import width_range
from replay import ReplayOptions, replay
from replay.records import FrameResult
from replay.sink import SinkBase

ROOT = Path(__file__).resolve().parents[1]


class _Timer(SinkBase):
    def __init__(self, repeat: int) -> None:
        self.repeat = repeat
        self.ms: dict[str, list[float]] = {"detection": [], "width": []}

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        det = result.detection
        if image_bgr is None or det is None:
            return
        centroid = (float(det.cx_px), float(det.cy_px))
        t0 = time.thread_time()
        for _ in range(self.repeat):
            detect_ball(image_bgr)
        t1 = time.thread_time()
        for _ in range(self.repeat):
            width_range(det.outline_px, result.centre_px, centroid)
        t2 = time.thread_time()
        self.ms["detection"].append(1e3 * (t1 - t0) / self.repeat)
        self.ms["width"].append(1e3 * (t2 - t1) / self.repeat)


def main(argv: Sequence[str] | None = None) -> None:
    p = argparse.ArgumentParser(prog="bench_width.py", allow_abbrev=False,
                                description=__doc__.splitlines()[0])
    p.add_argument("log", nargs="?", type=Path, default=ROOT / "logs" / "golden" / "lobs.mcap")
    p.add_argument("--repeat", type=int, default=20, metavar="N",
                   help="calls of each per frame (default 20)")
    args = p.parse_args(argv)
    if args.repeat < 1:
        p.error(f"--repeat {args.repeat}: give at least 1 call")
    cv2.setNumThreads(1)
    timer = _Timer(args.repeat)
    replay(args.log, ReplayOptions(threads=1, progress=False, quiet=True), sinks=[timer])
    med = {k: statistics.median(v) for k, v in timer.ms.items()}
    print(f"{args.log.name}: {len(timer.ms['width'])} detections, CPU time of one thread, "
          f"one core, {args.repeat} calls each")
    print(f"median per detection: detection {med['detection']:.3f} ms, width "
          f"{1e3 * med['width']:.1f} us ({med['width'] / med['detection']:.1%} of the "
          f"detection)")


if __name__ == "__main__":
    sys.exit(run_main("bench_width.py", main))  # a missing or bad log: one line, exit 1
