"""Time the real-ball detector on 608 x 800 real camera images, beside a frame copy and the
paper's chain, on one core.

The images: every test image (after the first 10 by name) of each labelled folder under
../shared/real/msl-images when it is beside the repository, else the committed subset
(tests/data/msl-images). Each folder's ball model is fitted on its first 10 (with its venue
head on the shipped check). One run, side by side: each function's pass over a folder's
images takes turns with the others' (:func:`bench_detection.medians_ms`), so the
machine's load moves all figures together. OpenCV runs on one thread
(``cv2.setNumThreads(1)``); the figures are wall-clock medians per image, with the 90th
percentile of the detector beside them.

``--generic``: every folder's detector is the shipped generic ball model instead (no frame
of the venue fitted, no venue head), as at a venue with no labelled frame.

Run: python benchmarks/bench_real_detection.py [--repeat 3] [--generic]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt
from bench_detection import medians_ms

from dsp.ball_file import shipped_check, shipped_generic
from dsp.labelled import find_labelled, labelled_folders
from estimator.detection import detect_ball
from estimator.detection.real import BallCheck, RealBallDetector
from replay.calibrate.ball import fit_from_folder

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "real" / "msl-images"
SUBSET = ROOT / "tests" / "data" / "msl-images"


def _p90(detector: RealBallDetector, frames: list[npt.NDArray[np.uint8]]) -> list[float]:
    out = []
    for frame in frames:
        t0 = time.perf_counter()
        detector.detect(frame)
        out.append(1e3 * (time.perf_counter() - t0))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3,
                        help="passes of each function over the images")
    parser.add_argument("--generic", action="store_true",
                        help="the shipped generic ball model instead of each folder's fit")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    root = SHARED if SHARED.is_dir() else SUBSET
    check = shipped_check()
    print(f"median ms per image, one run, cv2 threads {cv2.getNumThreads()}, images of {root}")
    every: dict[str, list[float]] = {"real": [], "paper": [], "copy": []}
    singles: list[float] = []
    for folder in labelled_folders(root):
        model = (shipped_generic() if args.generic
                 else fit_from_folder(folder, train_count=10, check=check))
        detector = RealBallDetector(model, BallCheck(check))
        frames = [item.read(0)[0] for item in find_labelled(folder)[10:]]
        detector.detect(frames[0])  # the network's first call sets it up
        ms = medians_ms({"real": detector.detect, "paper": detect_ball,
                         "copy": lambda f: f.copy()}, frames, args.repeat)
        for key, value in ms.items():
            every[key] += [value] * len(frames)
        singles += _p90(detector, frames)
        print(f"{folder.relative_to(root).as_posix():14s} {len(frames):4d} images   real "
              f"{ms['real']:6.2f} ms ({ms['real'] / ms['copy']:4.0f}x copy)   paper chain "
              f"{ms['paper']:6.2f} ms   frame.copy() {ms['copy']:5.3f} ms")
    real, paper, copy = (statistics.median(every[k]) for k in ("real", "paper", "copy"))
    p90 = float(np.percentile(singles, 90))
    print(f"{'all':14s} {len(singles):4d} images   real {real:6.2f} ms ({real / copy:4.0f}x "
          f"copy, p90 {p90:.2f} ms)   paper chain {paper:6.2f} ms   frame.copy() {copy:5.3f} ms")


if __name__ == "__main__":
    main()
