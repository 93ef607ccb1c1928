"""Benchmark replay: frames per second beside the floor, and peak RSS as the log grows.

    python benchmarks/bench_replay.py --recorded [--seconds 6] [--threads 1,0] [--malloc]
        [--profile best|fast|paper|plain]
    python benchmarks/bench_replay.py [--seconds 2] [--factor 10]

``--recorded``: records the ``rolling`` scenario (full 1080 x 1080 omni images at 10 Hz,
three robots: 180 frames in 6 s) once as PNG and once as JPEG, and for each log prints, in
the same run, the floor and the replay with each ``--threads`` value (0: the default, the
cores; 1: serial). The floor is warm: the mcap library and ``cv2.imdecode`` over the same
log in one thread, run twice in one process, the second run timed (the first run's figure
is printed beside it). The replay (``replay()`` writing results JSON and estimates MCAP,
as ``dsp-replay --out --out-mcap``, with ``--profile``'s pipeline: dsp-replay's default unless
given) gives frames/s with its start-up (the whole call), in
its loop (first to last frame) and the start-up to the first frame; each as a ratio to the
floor. Each figure is the median of ``--runs`` runs, each in a fresh child process.

Without ``--recorded``: synthetic logs (tests/synthetic.py: tiny PNGs, fast to make), a
short one and one ``--factor`` times longer; peak RSS should stay flat (the streaming
replay's memory does not grow with the log).

Each child also gives its CPU time (user + sys) and minor page faults a frame (the floor's
over its timed run, the replay's over the whole call): less sensitive to other work on the
machine than wall time. The replay's child first calls
:func:`replay.memory.keep_image_buffers`, as ``dsp-replay`` does, so freed image buffers are
reused instead of faulted in again; ``--malloc`` runs each replay without it as well. As the
floor must be the fastest way to do the same work, the floor also runs with the same malloc
setting (set through ``ctypes``, as anyone could), and every ratio is given against both.

Peak RSS is the child's own (VmHWM from /proc, else resource.getrusage); results JSON and
estimates MCAP are written as well.
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

from replay.profiles import DEFAULT_PROFILE, PROFILE_CHOICES

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import time
T_PROCESS = time.perf_counter()  # (the interpreter's own start-up is before this)
import json, resource, sys
from pathlib import Path
from replay import ReplayOptions, replay
from replay.memory import keep_image_buffers
from replay.profiles import options_for
log, out, threads = Path(sys.argv[1]), Path(sys.argv[2]), int(sys.argv[3])
profile = sys.argv[5]
if sys.argv[4] == "keep":
    keep_image_buffers()  # as dsp-replay does first
from replay import SinkBase
class Clock(SinkBase):
    first = last = None
    def frame(self, result, image_bgr):
        self.last = time.perf_counter()
        self.first = self.first or self.last
clock = Clock()
r0 = resource.getrusage(resource.RUSAGE_SELF)
t0 = time.perf_counter()
kw = dict(out=out / "r.json", out_mcap=out / "e.mcap", force=True, progress=False,
          threads=threads or None)
options = ReplayOptions(**kw) if profile == "plain" else options_for(profile, **kw)
s = replay(log, options, sinks=[clock])
wall = time.perf_counter() - t0
r1 = resource.getrusage(resource.RUSAGE_SELF)
loop_fps = (s.frames - 1) / (clock.last - clock.first)  # between the first and last frame
# Peak RSS of this program alone: VmHWM belongs to the address space exec made, while
# ru_maxrss also counts the parent's pages the child had before exec (the parent may hold
# a whole pybullet world after recording).
try:
    hwm = [l for l in open("/proc/self/status") if l.startswith("VmHWM:")]
    rss_kib = int(hwm[0].split()[1])
except (OSError, IndexError, ValueError):
    rss_kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
print(json.dumps({"frames": s.frames, "wall_s": wall, "peak_rss_mib": rss_kib / 1024,
                  "frames_per_s": s.frames / wall, "fused_rmse_m": s.fused.rmse_m,
                  "loop_frames_per_s": loop_fps, "start_s": clock.first - t0,
                  "process_s": time.perf_counter() - T_PROCESS,
                  "cpu_ms": (r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime) / s.frames
                  * 1e3, "faults": (r1.ru_minflt - r0.ru_minflt) / s.frames}))
"""


FLOOR = r"""
import json, resource, sys, time
import cv2, numpy as np
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
# the floor, warm: the mcap library and cv2.imdecode over the same log, in one thread, run
# twice in this process and the second run timed (the first pays for the first touch of
# freshly allocated image buffers and the libraries' own start-up)
if sys.argv[2:] == ["keep"]:  # the replay's own malloc setting, given to the floor too
    import ctypes
    mallopt = ctypes.CDLL(None).mallopt
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt(-3, 32 << 20)  # M_MMAP_THRESHOLD
    mallopt(-1, 16 << 20)  # M_TRIM_THRESHOLD
def once(path):
    n = 0
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, _, _, msg in reader.iter_decoded_messages():
            if schema.name == "sensor_msgs/msg/CompressedImage":
                cv2.imdecode(np.frombuffer(msg.data, np.uint8), cv2.IMREAD_COLOR)
                n += 1
            elif schema.name == "sensor_msgs/msg/Image":
                np.frombuffer(msg.data, np.uint8).copy()
                n += 1
    return n
t0 = time.perf_counter(); once(sys.argv[1]); cold = time.perf_counter() - t0
r0 = resource.getrusage(resource.RUSAGE_SELF)
t0 = time.perf_counter(); n = once(sys.argv[1]); wall = time.perf_counter() - t0
r1 = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"frames": n, "wall_s": wall, "frames_per_s": n / wall,
                  "cold_frames_per_s": n / cold, "faults": (r1.ru_minflt - r0.ru_minflt) / n,
                  "cpu_ms": (r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime) / n * 1e3}))
"""


def _child(code: str, *args: str) -> dict[str, float]:
    proc = subprocess.run([sys.executable, "-c", code, *args], cwd=ROOT,
                          capture_output=True, text=True, check=True)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def measure(log: Path, out: Path, threads: int = 0, *, keep: bool = True,
            profile: str = DEFAULT_PROFILE) -> dict[str, float]:
    return _child(CHILD, str(log), str(out), str(threads), "keep" if keep else "default",
                  profile)


KEYS = ("frames_per_s", "loop_frames_per_s", "start_s", "process_s", "peak_rss_mib", "cpu_ms",
        "faults")


def _row(fmt: str, name: str, runs: list[dict[str, float]], fps0: float, fps1: float) -> str:
    med = {k: statistics.median(r[k] for r in runs) for k in KEYS}
    return (f"{fmt:4s} replay(), {name:16s} with start-up {med['frames_per_s']:6.1f} "
            f"frames/s = {med['frames_per_s'] / fps0:4.2f}x the floor "
            f"({med['frames_per_s'] / fps1:4.2f}x the tuned floor); in the loop "
            f"{med['loop_frames_per_s']:6.1f} = "
            f"{med['loop_frames_per_s'] / fps0:4.2f}x "
            f"({med['loop_frames_per_s'] / fps1:4.2f}x); start-up to the first frame "
            f"{med['start_s']:5.2f} s (whole process {med['process_s']:5.2f} s); "
            f"peak RSS {med['peak_rss_mib']:6.1f} MiB; CPU (user + sys, all "
            f"threads, with start-up) {med['cpu_ms']:5.2f} ms a frame, "
            f"{med['faults']:4.0f} page faults a frame")


def speed(args: argparse.Namespace) -> int:
    """Replay frames/s beside the single-thread read + decode floor, PNG and JPEG."""
    from recorder.record import RecordOptions, record

    threads = [int(t) for t in args.threads.split(",")]
    print(f"rolling, {args.seconds:g} s, 3 robots, 10 Hz; the replay's pipeline: "
          f"{args.profile}; median of {args.runs} runs, one "
          "run of the script (figures side by side; the machine is shared and noisy); load "
          f"average {os.getloadavg()[0]:.1f} at the start")
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        for fmt in ("png", "jpeg"):
            log = d / f"rolling-{fmt}.mcap"
            record(log, RecordOptions(scenario="rolling", duration_s=args.seconds,
                                      image_format=fmt))
            floor: list[dict[str, float]] = []
            tuned: list[dict[str, float]] = []  # the floor with the replay's malloc setting
            variants = [(n, keep) for n in threads for keep in (True, False)[:1 + args.malloc]]
            runs: dict[tuple[int, bool], list[dict[str, float]]] = {v: [] for v in variants}
            for _ in range(args.runs):  # interleaved, so the load falls on all alike
                floor.append(_child(FLOOR, str(log)))
                tuned.append(_child(FLOOR, str(log), "keep"))
                for n, keep in variants:
                    runs[n, keep].append(measure(log, d, n, keep=keep, profile=args.profile))
            fps0 = statistics.median(r["frames_per_s"] for r in floor)
            mib = log.stat().st_size / 2**20
            cold0 = statistics.median(r["cold_frames_per_s"] for r in floor)
            cpu0, flt0 = (statistics.median(r[k] for r in floor) for k in ("cpu_ms", "faults"))
            print(f"{fmt:4s} {int(floor[0]['frames']):4d} frames {mib:6.1f} MiB  floor "
                  f"(mcap + cv2.imdecode, 1 thread, warm: 2nd run in-process) {fps0:6.1f} "
                  f"frames/s (1st run {cold0:6.1f}); CPU {cpu0:5.2f} ms a frame, "
                  f"{flt0:4.0f} page faults a frame")
            fps1 = statistics.median(r["frames_per_s"] for r in tuned)
            cpu1, flt1 = (statistics.median(r[k] for r in tuned) for k in ("cpu_ms", "faults"))
            print(f"{fmt:4s} the same floor with the replay's malloc setting (freed buffers "
                  f"kept mapped) {fps1:6.1f} frames/s; CPU {cpu1:5.2f} ms a frame, "
                  f"{flt1:4.0f} page faults a frame")
            for n, keep in variants:
                name = (f"--threads {n}" if n else "default threads") + ("" if keep else
                                                                        ", malloc as is")
                print(_row(fmt, name, runs[n, keep], fps0, fps1))
        print(f"load average {os.getloadavg()[0]:.1f} at the end, on {os.cpu_count()} cores (wall "
              "figures suffer from other work; CPU time and page faults much less)")
    return 0


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--seconds", type=float, default=None,
                   help="log length [s] (default 2; --recorded: 6)")
    p.add_argument("--factor", type=int, default=10, help="how much longer the long log is")
    p.add_argument("--recorded", action="store_true",
                   help="record the rolling scenario (PNG and JPEG): frames/s beside the floor")
    p.add_argument("--threads", default="0,1",
                   help="--recorded: comma-separated --threads values (0: the default)")
    p.add_argument("--runs", type=int, default=3, help="--recorded: runs per figure")
    p.add_argument("--profile", default=DEFAULT_PROFILE, choices=(*PROFILE_CHOICES, "plain"),
                   help="the replay's pipeline: a profile (default: dsp-replay's own, "
                   f"{DEFAULT_PROFILE}) or plain (ReplayOptions(): the corrected estimator and "
                   "the tracker on the believed poses)")
    p.add_argument("--malloc", action="store_true",
                   help="--recorded: each replay also without keep_image_buffers (glibc's "
                   "malloc left as it is), interleaved")
    args = p.parse_args()
    if args.recorded:
        args.seconds = args.seconds or 6.0
        return speed(args)
    args.seconds = args.seconds or 2.0
    sys.path.insert(0, str(ROOT / "tests"))
    from synthetic import write_log

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        long_s = args.seconds * args.factor
        for name, secs in (("short", args.seconds), (f"{args.factor}x", long_s)):
            log = d / f"{name}.mcap"
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
