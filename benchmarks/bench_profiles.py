"""Benchmark the profiles side by side: frames/s of each on one log, and the ratio to the
pipeline without the profiles' parts (the corrected estimator and the tracker on the
believed poses: ``ReplayOptions()`` made one by one).

    python benchmarks/bench_profiles.py LOG [--runs 5] [--threads 0]

Record the log first, e.g. a realistic 1080x1080 JPEG match::

    dsp-record m.mcap --scenario match --camera mirror --realism field --duration 10 \\
        --image-format jpeg

Each run replays the log in a fresh child process (``replay()`` writing results JSON, as
``dsp-replay --out``); the variants run interleaved, so the machine's other work falls on
all alike. Printed per variant: the median frames/s of the whole call, the median CPU time
(user + sys, all threads) a frame, and the fused RMSE; then each variant's frames/s and CPU
as a ratio to the plain pipeline's, measured in the same run, and to the floor: reading and
decoding the same log's images (the mcap library and ``cv2.imdecode``, one thread, warm: the
second of two passes in one process, with the replay's malloc setting; as
``benchmarks/bench_replay.py`` times it), interleaved with the variants too.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from bench_replay import FLOOR  # noqa: E402  (the same floor, timed the same way)

CHILD = r"""
import json, resource, sys, time
from pathlib import Path
from replay import ReplayOptions, replay
from replay.memory import keep_image_buffers
from replay.profiles import options_for
log, out, variant, threads = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3], int(sys.argv[4])
keep_image_buffers()  # as dsp-replay does first
kw = dict(out=out, force=True, progress=False, threads=threads or None)
options = ReplayOptions(**kw) if variant == "plain" else options_for(variant, **kw)
r0 = resource.getrusage(resource.RUSAGE_SELF)
t0 = time.perf_counter()
s = replay(log, options)
wall = time.perf_counter() - t0
r1 = resource.getrusage(resource.RUSAGE_SELF)
cpu = r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime
print(json.dumps({"frames": s.frames, "frames_per_s": s.frames / wall,
                  "cpu_ms": cpu / s.frames * 1e3, "rmse_m": s.fused.rmse_m}))
"""

VARIANTS = ("plain", "fast", "best")


def _floor(log: Path) -> dict[str, float]:
    """One warm read + decode pass over the log's images (bench_replay.py's floor)."""
    proc = subprocess.run([sys.executable, "-c", FLOOR, str(log), "keep"], cwd=ROOT,
                          capture_output=True, text=True, check=True)
    out: dict[str, float] = json.loads(proc.stdout.strip().splitlines()[-1])
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("log", type=Path, help="the MCAP log to replay")
    p.add_argument("--runs", type=int, default=5, help="runs per variant (default 5)")
    p.add_argument("--threads", type=int, default=0,
                   help="dsp-replay --threads (default 0: the cores)")
    args = p.parse_args(argv)
    if not args.log.is_file():
        print(f"bench_profiles.py: error: {args.log}: no such log", file=sys.stderr)
        return 1
    if args.runs < 1:
        print(f"bench_profiles.py: error: --runs {args.runs}: give at least 1", file=sys.stderr)
        return 2
    print(f"{args.log.name}: median of {args.runs} interleaved runs, each in a fresh process; "
          f"load average {os.getloadavg()[0]:.1f} at the start, {os.cpu_count()} cores")
    runs: dict[str, list[dict[str, float]]] = {v: [] for v in VARIANTS}
    floors: list[dict[str, float]] = []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.runs):
            floors.append(_floor(args.log))
            for v in VARIANTS:
                proc = subprocess.run(
                    [sys.executable, "-c", CHILD, str(args.log), str(Path(tmp) / "r.json"), v,
                     str(args.threads)], cwd=ROOT, capture_output=True, text=True)
                if proc.returncode != 0:
                    last = (proc.stderr.strip().splitlines() or ["no output"])[-1]
                    print(f"bench_profiles.py: error: {args.log}: {last}", file=sys.stderr)
                    return 1
                runs[v].append(json.loads(proc.stdout.strip().splitlines()[-1]))
    med = {v: {k: statistics.median(r[k] for r in rs) for k in ("frames_per_s", "cpu_ms")}
           for v, rs in runs.items()}
    base = med["plain"]
    floor = statistics.median(f["frames_per_s"] for f in floors)
    floor_cpu = statistics.median(f["cpu_ms"] for f in floors)
    print(f"floor (read + decode, 1 thread, warm) {floor:6.1f} frames/s, CPU {floor_cpu:5.2f} "
          "ms a frame")
    for v in VARIANTS:
        name = "plain pipeline" if v == "plain" else f"--profile {v}"
        print(f"{name:16s} {int(runs[v][0]['frames']):5d} frames  "
              f"{med[v]['frames_per_s']:6.1f} frames/s "
              f"({med[v]['frames_per_s'] / base['frames_per_s']:4.2f}x plain)  "
              f"CPU {med[v]['cpu_ms']:6.2f} ms a frame "
              f"({med[v]['cpu_ms'] / base['cpu_ms']:4.2f}x plain)  "
              f"fused RMSE {runs[v][0]['rmse_m']:.4f} m; "
              f"{med[v]['frames_per_s'] / floor:4.2f}x the floor")
    print(f"load average {os.getloadavg()[0]:.1f} at the end")
    return 0


if __name__ == "__main__":
    sys.exit(main())
