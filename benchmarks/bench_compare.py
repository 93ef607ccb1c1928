"""Benchmark dsp-compare on two batch folders: its time beside the command's start-up floor.

    python benchmarks/bench_compare.py [--logs 20] [--steps 2000] [--repeat 5]
    python benchmarks/bench_compare.py --folders A B        # two real --out-dir folders

Without ``--folders`` it writes two folders of ``--logs`` results files each (a 10 s match
replayed with the tracker has about 2000 fused steps and 1800 frames: ``--steps`` steps and
0.9 x as many frames per log, errors drawn from seeded distributions, B's a little
smaller). Each run is a child process (``dsp-compare A B --out ... --out-csv ... --out-md
...``), so the time includes Python's start and the imports, as a user sees it; the floor
is ``dsp-compare --version`` (start-up and imports alone), run interleaved with it. It
prints the medians (wall and CPU time: on a shared machine the CPU time says more) and
checks that every run wrote the same bytes.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROBOTS = ("robot1", "robot2", "robot3")


def _doc(i: int, steps: int, scale: float, seed: int) -> dict[str, object]:
    rng = np.random.default_rng([i, seed])
    err = np.abs(rng.normal(0, scale, steps))
    vel = np.abs(rng.normal(0, 0.1, steps))
    fused = [{"step": k, "stamp_ns": k * 16_666_667, "truth": {"x_m": 0.0, "y_m": 0.0},
              "x_m": 0.0, "y_m": 0.0, "error_m": round(float(err[k]), 6),
              "velocity_error_m_s": round(float(vel[k]), 6)} for k in range(steps)]
    frames = [{"frame": k, "robot": ROBOTS[k % 3], "stamp_ns": k * 16_666_667,
               "detection": {"cx_px": 1.0} if rng.random() < 0.9 else None}
              for k in range(int(0.9 * steps))]
    return {"format": "dsp-replay-results", "version": 1,
            "log": {"file": f"match-{i}.mcap", "sha256": f"{i:064x}", "robots": list(ROBOTS)},
            "options": {"method": "corrected", "fusion": "track"}, "frames": frames,
            "fused": fused, "summary": {}}


def _make(root: Path, logs: int, steps: int) -> tuple[Path, Path]:
    a, b = root / "a", root / "b"
    for folder, scale, seed in ((a, 0.02, 1), (b, 0.019, 2)):
        folder.mkdir()
        for i in range(logs):
            (folder / f"match-{i}.json").write_text(json.dumps(_doc(i, steps, scale, seed)))
    return a, b


CPU: list[float] = []


def _time(argv: list[str]) -> float:
    """Wall time of the child; its CPU time (user + system) goes to CPU."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(argv, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    CPU.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    return wall


def main() -> None:
    p = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    p.add_argument("--logs", type=int, default=20)
    p.add_argument("--steps", type=int, default=2000)
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--folders", nargs=2, type=Path, metavar=("A", "B"))
    args = p.parse_args()
    exe = [sys.executable, "-m", "replay.compare.cli"]
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        a, b = args.folders if args.folders else _make(root, args.logs, args.steps)
        runs, floor, outputs = [], [], set()
        for r in range(args.repeat):
            out = root / f"run{r}"
            out.mkdir()
            floor.append(_time([*exe, "--version"]))
            runs.append(_time([*exe, str(a), str(b), "-q", "--out", str(out / "c.json"),
                               "--out-csv", str(out / "c.csv"), "--out-md", str(out / "c.md")]))
            outputs.add(tuple((out / n).read_bytes() for n in ("c.json", "c.csv", "c.md")))
        n = len(list(Path(a).glob("*.json")))
        print(f"dsp-compare, {n} logs a side, {args.repeat} runs (load average "
              f"{os.getloadavg()[0]:.2f}):")
        print(f"  median {statistics.median(runs):.2f} s (min {min(runs):.2f}, max "
              f"{max(runs):.2f}); start-up floor (--version) {statistics.median(floor):.2f} s")
        print(f"  CPU time: median {statistics.median(CPU[1::2]):.2f} s; the floor's "
              f"{statistics.median(CPU[0::2]):.2f} s")
        print(f"  outputs byte-identical across runs: {len(outputs) == 1}")


if __name__ == "__main__":
    main()
