"""Time ``--localise lines`` per frame: a replay with it beside the same replay without.

Replays a log (default ``logs/golden/match.mcap``: 3 robots, ideal camera, 1080 x 1080 PNG
frames) on one thread with OpenCV on one core (``cv2.setNumThreads(1)``), the two modes
taking turns ``--repeat`` times so the machine's load moves both figures together, and
prints the median wall time per frame of each, their difference (what the field lines cost
a frame: the line points and the pose fit) and the ratio. The difference is the cost on one
core; ``dsp-replay --threads N`` runs the line points and fits in its look-ahead threads.

Run: python benchmarks/bench_localise.py [LOG] [--repeat 5]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import cv2

from replay import ReplayOptions, replay

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("log", nargs="?", type=Path, default=ROOT / "logs" / "golden" / "match.mcap")
    p.add_argument("--repeat", type=int, default=5)
    args = p.parse_args()
    cv2.setNumThreads(1)
    per_frame: dict[str, list[float]] = {"none": [], "lines": []}
    frames = 0
    for _ in range(args.repeat):
        for mode in per_frame:
            t0 = time.perf_counter()
            summary = replay(args.log, ReplayOptions(localise=mode, threads=1, progress=False,
                                                     quiet=True))
            per_frame[mode].append((time.perf_counter() - t0) / summary.frames)
            frames = summary.frames
    med = {m: statistics.median(v) * 1e3 for m, v in per_frame.items()}
    print(f"{args.log.name}: {frames} frames, {args.repeat} replays per mode, one core")
    print(f"median per frame: without {med['none']:.1f} ms, --localise lines "
          f"{med['lines']:.1f} ms; the lines cost {med['lines'] - med['none']:.1f} ms a frame "
          f"(x{med['lines'] / med['none']:.2f})")


if __name__ == "__main__":
    main()
