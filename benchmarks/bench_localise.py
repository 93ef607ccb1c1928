"""Time ``--localise lines`` per frame: its two stages beside the ball's detection.

Replays a log (default ``logs/golden/match.mcap``) once, and at every frame a sink times,
on the replay's own thread with OpenCV on one core (``cv2.setNumThreads(1)``), in CPU time
of that thread (``time.thread_time``: what other processes on a busy machine do not move):
the ball's detection in the frame's image (``detect_ball``, what every replay does), the
line points (:meth:`replay.localise.Localiser.points`) and the pose fit around the believed
pose (:meth:`~replay.localise.Localiser.fit`) as the replay runs it, from the robot's last
correction carried to the frame (:meth:`~replay.localise.Localiser.start`), and beside it
the same fit from the belief, every stage (what every fit cost before); each frame's calls
taking turns. It prints each one's median per frame [ms] and the lines' total as a ratio
to the detection.
The one-time grids (distance grid, one ground grid per camera model) are timed apart.
``dsp-replay --threads N`` runs the line points in its look-ahead threads and the fits on
its own thread, in frame order.

Run: python benchmarks/bench_localise.py [LOG]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import cv2
import numpy as np

from dsp import contract
from estimator.detection import detect_ball
from replay import ReplayOptions, replay
from replay.cameras import cameras_for
from replay.localise import Localiser
from replay.log import LogReader
from replay.records import FrameResult
from replay.sink import SinkBase

ROOT = Path(__file__).resolve().parents[1]


class _Timer(SinkBase):
    def __init__(self, localiser: Localiser) -> None:
        self.localiser = localiser
        self.ms: dict[str, list[float]] = {"detection": [], "line points": [], "fit": [],
                                           "fit from the belief": []}

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        if image_bgr is None or result.pose is None:
            return
        t0 = time.thread_time()
        detect_ball(image_bgr)
        t1 = time.thread_time()
        points = self.localiser.points(result.robot, image_bgr)
        start = self.localiser.start(result.robot, result.stamp_ns, result.pose)
        t2 = time.thread_time()
        fit = self.localiser.fit(points, result.pose, start)
        t3 = time.thread_time()
        self.localiser.fit(points, result.pose)
        t4 = time.thread_time()
        self.localiser.settle(result.robot, result.stamp_ns, result.pose, fit, points)
        for key, dt in zip(self.ms, (t1 - t0, t2 - t1, t3 - t2, t4 - t3), strict=True):
            self.ms[key].append(1e3 * dt)


def main() -> None:
    p = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    p.add_argument("log", nargs="?", type=Path, default=ROOT / "logs" / "golden" / "match.mcap")
    args = p.parse_args()
    cv2.setNumThreads(1)
    with LogReader(args.log) as reader:
        info = reader.info
        cameras = cameras_for(info.robots, log=str(args.log), metadata=info.cameras.camera_set(
            f"{args.log}: metadata {contract.CAMERAS_METADATA}"))
    assert info.scenario is not None, f"{args.log}: no scenario metadata naming the field"
    t0 = time.thread_time()
    localiser = Localiser(info.scenario.field, cameras.models, sigma_m=0.05, sigma_deg=1.0)
    setup_ms = 1e3 * (time.thread_time() - t0)
    timer = _Timer(localiser)
    replay(args.log, ReplayOptions(threads=1, progress=False, quiet=True), sinks=[timer])
    med = {k: statistics.median(v) for k, v in timer.ms.items()}
    lines = med["line points"] + med["fit"]  # as the replay fits: from the last correction
    print(f"{args.log.name}: {len(timer.ms['fit'])} frames, CPU time of one thread, one core")
    print("median per frame: " + ", ".join(f"{k} {v:.1f} ms" for k, v in med.items())
          + f"; the lines {lines:.1f} ms (x{lines / med['detection']:.2f} the detection)")
    print(f"once per replay: the grids, {setup_ms:.0f} ms")


if __name__ == "__main__":
    main()
