"""Fused accuracy of window fusion against the tracker on unsynchronised cameras.

    python benchmarks/bench_track.py [--seconds 2] [--speed 3.16] [--phases-ms 0,17,34]
    python benchmarks/bench_track.py --speed-of LOG [--runs 5]

Writes a synthetic log (tests/synthetic.py: the paper's ideal camera, exact poses, three
robots, 20 Hz cameras at their own phases, a ball rolling at a constant velocity, its true
velocity on /ground_truth/ball/odometry), replays it with each window fusion, the tracker
and the smoothed tracker, and prints one Markdown row each: fused position RMSE / p95 /
max [m], the velocity's median error [m/s] (tracker only) and the replay's wall time.

``--speed-of LOG`` instead times the replay of a recorded log (e.g. a ``match`` log) with
window fusion (``mean``) and with the tracker, ``--runs`` times each, interleaved (mean,
track, mean, track, ...) so a change of load falls on both; it prints the medians and the
tracker's cost over window fusion.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
MS = 1_000_000


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    parser.add_argument("--seconds", type=float, default=2.0)
    parser.add_argument("--speed", type=float, default=math.hypot(3.0, 1.0),
                        help="ball speed [m/s] along (3, -1) (default 3.16)")
    parser.add_argument("--phases-ms", default="0,17,34",
                        help="each robot's camera phase [ms] (0,0,0: synchronised)")
    parser.add_argument("--speed-of", type=Path, metavar="LOG",
                        help="time the replay of this log: mean fusion vs the tracker")
    parser.add_argument("--runs", type=int, default=5, help="--speed-of: runs of each")
    args = parser.parse_args(argv)
    if args.speed_of is not None:
        return speed_of(args.speed_of, args.runs)
    from replay import ReplayOptions, replay  # before tests/ joins the path (tests/replay)
    from replay.sinks import ResultsCollector

    sys.path.append(str(ROOT / "tests"))
    from synthetic import write_log

    phases = [int(p) for p in args.phases_ms.split(",")]
    direction = np.array([3.0, -1.0]) / math.hypot(3.0, 1.0)
    velocity = (float(direction[0] * args.speed), float(direction[1] * args.speed))
    print("| fusion | fused RMSE / p95 / max [m] | velocity median error [m/s] | wall [s] |\n"
          "|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "moving.mcap"
        write_log(log, ball=(0.5, 0.3), ball_velocity=velocity, duration_s=args.seconds,
                  image_hz=20.0, with_odometry=True,
                  camera_phases_ns={f"robot{i + 1}": p * MS for i, p in enumerate(phases)})
        for fusion, smooth in (("mean", False), ("weighted", False), ("robust", False),
                               ("track", False), ("track", True)):
            collector = ResultsCollector()
            t0 = time.perf_counter()
            replay(log, ReplayOptions(fusion=fusion, smooth=smooth, progress=False),
                   sinks=[collector])
            wall = time.perf_counter() - t0
            errors = np.array([s["error_m"] for s in collector.fused if s["error_m"] is not None])
            v = [s["velocity_error_m_s"] for s in collector.fused if "velocity_error_m_s" in s]
            v_text = f"{np.median(v):.3f}" if v else "-"
            label = fusion + (" --smooth" if smooth else "")
            print(f"| {label} | {math.sqrt(np.mean(errors ** 2)):.4f} / "
                  f"{np.percentile(errors, 95):.4f} / {errors.max():.4f} | {v_text} | "
                  f"{wall:.2f} |")
    return 0


def speed_of(log: Path, runs: int) -> int:
    """Replay ``log`` with mean fusion and with the tracker, interleaved; print medians."""
    from replay import ReplayOptions, replay
    from replay.sinks import ResultsCollector

    walls: dict[str, list[float]] = {"mean": [], "track": []}
    frames = 0
    for _ in range(runs):
        for fusion in walls:
            collector = ResultsCollector()
            t0 = time.perf_counter()
            replay(log, ReplayOptions(fusion=fusion, progress=False), sinks=[collector])
            walls[fusion].append(time.perf_counter() - t0)
            frames = len(collector.frames)
    mean, track = (float(np.median(walls[f])) for f in ("mean", "track"))
    print(f"{log.name}: {frames} frames, median of {runs} interleaved runs each: "
          f"mean {mean:.3f} s ({frames / mean:.1f} frames/s), track {track:.3f} s "
          f"({frames / track:.1f} frames/s): the tracker costs {100 * (track / mean - 1):+.1f}%")
    return 0


if __name__ == "__main__":
    sys.exit(main())
