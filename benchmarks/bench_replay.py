"""Benchmark replay: peak RSS and wall time on a short log and one 10x longer.

    python benchmarks/bench_replay.py [--seconds 2] [--factor 10]
    python benchmarks/bench_replay.py --recorded [--seconds 1.2]

By default the logs are synthetic (tests/synthetic.py: tiny PNGs, fast to make); with
``--recorded`` they are simulator recordings of the ``rolling`` scenario (full 1080 x 1080
omni images at 10 Hz, three robots), so the figures include real image decoding.

Each replay runs in a fresh child process, so peak RSS is that replay's alone (the child's
VmHWM from /proc, else resource.getrusage); results JSON and estimates MCAP are written as
well. Memory should stay flat: the long log's peak RSS about the short one's.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, resource, sys, time
from pathlib import Path
from replay import ReplayOptions, replay
log, out = Path(sys.argv[1]), Path(sys.argv[2])
t0 = time.perf_counter()
s = replay(log, ReplayOptions(out=out / "r.json", out_mcap=out / "e.mcap", force=True,
                              progress=False))
wall = time.perf_counter() - t0
# Peak RSS of this program alone: VmHWM belongs to the address space exec made, while
# ru_maxrss also counts the parent's pages the child had before exec (the parent may hold
# a whole pybullet world after recording).
try:
    hwm = [l for l in open("/proc/self/status") if l.startswith("VmHWM:")]
    rss_kib = int(hwm[0].split()[1])
except (OSError, IndexError, ValueError):
    rss_kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
print(json.dumps({"frames": s.frames, "wall_s": wall, "peak_rss_mib": rss_kib / 1024,
                  "frames_per_s": s.frames / wall, "fused_rmse_m": s.fused.rmse_m}))
"""


def measure(log: Path, out: Path) -> dict[str, float]:
    proc = subprocess.run([sys.executable, "-c", CHILD, str(log), str(out)], cwd=ROOT,
                          capture_output=True, text=True, check=True)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=2.0, help="short log length [s]")
    p.add_argument("--factor", type=int, default=10, help="how much longer the long log is")
    p.add_argument("--recorded", action="store_true",
                   help="record the rolling scenario instead of writing synthetic logs")
    args = p.parse_args()
    sys.path.insert(0, str(ROOT / "tests"))
    from synthetic import write_log

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        long_s = args.seconds * args.factor
        for name, secs in (("short", args.seconds), (f"{args.factor}x", long_s)):
            log = d / f"{name}.mcap"
            if args.recorded:
                from recorder.record import RecordOptions, record

                record(log, RecordOptions(scenario="rolling", duration_s=secs))
            else:
                write_log(log, duration_s=secs)
            r = measure(log, d)
            r.update(name=name, seconds=secs, log_mib=log.stat().st_size / 2**20)
            rows.append(r)
    print(f"{'log':6} {'sim_s':>6} {'MiB':>6} {'frames':>7} {'wall_s':>7} {'fps':>7} "
          f"{'peak_rss_MiB':>13}")
    for r in rows:
        print(f"{r['name']:6} {r['seconds']:6.1f} {r['log_mib']:6.2f} {r['frames']:7d} "
              f"{r['wall_s']:7.2f} {r['frames_per_s']:7.1f} {r['peak_rss_mib']:13.1f}")
    growth = rows[1]["peak_rss_mib"] - rows[0]["peak_rss_mib"]
    print(f"peak RSS growth for {args.factor}x the log: {growth:+.1f} MiB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
