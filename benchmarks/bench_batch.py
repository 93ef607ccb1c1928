"""Benchmark scale-out: serial vs a local process pool vs Ray, on the same work, side by side.

    python benchmarks/bench_batch.py [--count 6] [--workers 2] [--repeat 1] [--no-ray]
                                     [--renderer auto|egl|tiny]

One command prints everything (a Markdown table, the load average before and after each run):

1. ``dsp-eval --suite random --count N`` (pybullet recording + 6 replays per scene), each
   run in a fresh folder, with ``--workers 1``, ``--workers W``, ``--ray`` joining a
   running local Ray head with W CPUs (as on a cluster: RAY_ADDRESS) and ``--ray`` starting
   its own local Ray (no RAY_ADDRESS); the logs and tables must be byte-identical.
2. ``dsp-replay LOGS --out-dir`` over the N logs the serial run recorded, the same three
   ways; every output must be byte-identical.
3. The per-task overhead: ``map_tasks`` over no-op tasks, for the pool (its start included)
   and Ray (connected), as (time for M tasks - time for 2) / (M - 2).

Each command runs in a child process, so the times include imports and start-up, as a user
sees them. The serial run's CPU time (user + system, from ``getrusage``) over its wall time
says how many cores it already keeps busy (EGL's software renderer draws in threads), which
bounds what W workers can gain: min(W, cores) / that; the pool's speed-up is printed as a
share of that ceiling. Runs of the modes are interleaved (repeat r:
serial, pool, ray) so a change of load on a shared machine falls on all of them; the load
average is printed beside each.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _noop(x: int) -> int:
    return x


def _load() -> str:
    return "/".join(f"{v:.1f}" for v in os.getloadavg())


def _cpu_s() -> float:
    """CPU seconds (user + system) of this process's finished children."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


CPU: dict[str, list[float]] = {}
"""Per command kind, the serial runs' CPU seconds / wall seconds."""


def _run(cmd: list[str], env: dict[str, str], kind: str = "") -> float:
    t0, c0 = time.perf_counter(), _cpu_s()
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        sys.exit(f"bench_batch: {' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr}")
    if kind:
        CPU.setdefault(kind, []).append((_cpu_s() - c0) / wall)
    return wall


def _slug(mode: str) -> str:
    return "".join(c for c in mode if c.isalnum())


def _files(d: Path, pattern: str) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(d.glob(pattern))}


def _compare(runs: dict[str, dict[str, bytes]]) -> str:
    first = next(iter(runs.values()))
    same = all(files == first for files in runs.values())
    return f"byte-identical ({len(first)} files)" if same else "DIFFERENT"


def _modes(workers: int, ray_address: str | None) -> dict[str, tuple[list[str], dict[str, str]]]:
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
    modes = {"--workers 1": (["--workers", "1"], env),
             f"--workers {workers}": (["--workers", str(workers)], env)}
    if ray_address is not None:
        modes["--ray"] = (["--ray"], {**env, "RAY_ADDRESS": ray_address})
        # no RAY_ADDRESS: the command starts (and stops) its own local Ray
        modes["--ray, own Ray"] = (["--ray", "--workers", str(workers)], env)
    return modes


def _bench(tmp: Path, kind: str, label: str, args: list[str], workers: int, repeat: int,
           ray_address: str | None) -> tuple[dict[str, list[float]], str]:
    """``python -m <args> --out-dir DIR -q <mode flags>`` in each mode, ``repeat`` times
    interleaved; the times per mode and whether every run wrote the same bytes."""
    modes = _modes(workers, ray_address)
    times: dict[str, list[float]] = {m: [] for m in modes}
    outputs: dict[str, dict[str, bytes]] = {}
    for r in range(repeat):
        for mode, (flags, env) in modes.items():
            out = tmp / f"{kind}-{r}-{_slug(mode)}"
            load = _load()
            wall = _run([sys.executable, "-m", *args, "--out-dir", str(out), "-q", *flags], env,
                        kind if flags == ["--workers", "1"] else "")
            times[mode].append(wall)
            outputs[f"{mode} #{r}"] = _files(out, "*")
            print(f"  {label} {mode}: {wall:.1f} s (load {load} -> {_load()})", flush=True)
    return times, _compare(outputs)


def bench_eval(tmp: Path, count: int, workers: int, repeat: int, ray_address: str | None,
               renderer: str) -> tuple[dict[str, list[float]], str, Path]:
    """dsp-eval --suite random in each mode (its logs and tables compared)."""
    times, check = _bench(tmp, "eval", "dsp-eval", [
        "replay.evaluate.cli", "--suite", "random", "--count", str(count),
        "--renderer", renderer], workers, repeat, ray_address)
    return times, check, tmp / f"eval-0-{_slug('--workers 1')}"


def bench_replay(tmp: Path, logs: Path, workers: int, repeat: int,
                 ray_address: str | None) -> tuple[dict[str, list[float]], str]:
    """A dsp-replay batch of ``logs`` in each mode."""
    return _bench(tmp, "replay", "dsp-replay batch", ["replay.cli", str(logs), "--estimates"],
                  workers, repeat, ray_address)


def _per_task(run: Callable[[int], None], tasks: int) -> tuple[float, float, float]:
    """(seconds for the first 2 tasks, for 2 more, per further task): the first use starts
    the fork server / Ray's workers and imports the project in them."""
    times = []
    for n in (2, 2, tasks):
        t0 = time.perf_counter()
        run(n)
        times.append(time.perf_counter() - t0)
    first, t2, tm = times
    return first, t2, (tm - t2) / (tasks - 2)


def bench_overhead(workers: int, tasks: int,
                   use_ray: bool) -> dict[str, tuple[float, float, float]]:
    sys.path.insert(0, str(ROOT))
    from replay.parallel import Workers, map_tasks

    out = {"pool": _per_task(
        lambda n: map_tasks(_noop, list(range(n)), Workers(count=workers)) and None, tasks)}
    if use_ray:
        out["ray"] = _per_task(
            lambda n: map_tasks(_noop, list(range(n)), Workers(ray=True)) and None, tasks)
    return out


def _start_ray(workers: int) -> tuple[str | None, float]:
    """A local Ray head in this process (the commands join it with RAY_ADDRESS); None when
    Ray is not installed."""
    try:
        import ray
    except ImportError:
        print("Ray is not installed: pip install -e '.[ray]'; skipping the Ray runs")
        return None, 0.0
    import logging

    t0 = time.perf_counter()
    ctx = ray.init(address="local", num_cpus=workers, include_dashboard=False,
                   logging_level=logging.ERROR, log_to_driver=False)
    return str(ctx.address_info["gcs_address"]), time.perf_counter() - t0


def _row(what: str, times: dict[str, list[float]], check: str) -> str:
    med = {m: statistics.median(t) for m, t in times.items()}
    serial, *rest = med
    cells = [f"{med[m]:.1f} s" for m in med]
    ratios = [f"{med[serial] / med[m]:.2f}x" for m in rest]
    ray_vs_pool = " / ".join(f"{100 * (med[m] / med[rest[0]] - 1):+.0f}%"
                             for m in med if m.startswith("--ray"))
    return f"| {what} | " + " | ".join(cells + ratios) + f" | {ray_vs_pool} | {check} |"


def _ceiling(what: str, times: dict[str, list[float]], busy: float, workers: int,
             renderer: str) -> str:
    """The pool's speed-up as a share of the CPU ceiling: the serial run already keeps
    ``busy`` cores busy, so W workers on min(W, cores) cores gain at most that / busy."""
    med = [statistics.median(t) for t in times.values()]
    cores = min(workers, os.cpu_count() or 1)
    ceiling = cores / max(busy, 1.0)
    speed_up = med[0] / med[1]
    return (f"{what} --workers 1 keeps {busy:.2f} cores busy (CPU time / wall time, children "
            f"included, renderer {renderer}): {workers} workers on {cores} cores can be at "
            f"most {ceiling:.2f}x faster; they are {speed_up:.2f}x, "
            f"{100 * speed_up / ceiling:.0f}% of that ceiling")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--count", type=int, default=6, help="random scenes (default 6)")
    p.add_argument("--workers", type=int, default=2, help="pool size and Ray CPUs (default 2)")
    p.add_argument("--repeat", type=int, default=1, help="runs of each mode (medians)")
    p.add_argument("--tasks", type=int, default=402, help="no-op tasks for the overhead")
    p.add_argument("--no-ray", action="store_true", help="leave out the Ray runs")
    p.add_argument("--renderer", choices=("auto", "egl", "tiny"), default="auto",
                   help="dsp-eval's pybullet renderer (default auto: EGL if it loads)")
    args = p.parse_args()
    print(f"{os.cpu_count()} CPUs; load average {_load()} (1/5/15 min) at the start")
    ray_address, ray_start_s = (None, 0.0) if args.no_ray else _start_ray(args.workers)
    tmp = Path(tempfile.mkdtemp(prefix="bench-batch-"))
    try:
        eval_times, eval_check, logs = bench_eval(tmp, args.count, args.workers, args.repeat,
                                                  ray_address, args.renderer)
        replay_times, replay_check = bench_replay(tmp, logs, args.workers, args.repeat,
                                                  ray_address)
        overhead = bench_overhead(args.workers, args.tasks, ray_address is not None)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
        if ray_address is not None:
            import ray

            ray.shutdown()
    modes = list(eval_times)
    print(f"\nload average at the end: {_load()}\n")
    print("| work | " + " | ".join(modes) + " | " + " | ".join(
        f"speed-up {m}" for m in modes[1:]) + " | ray vs pool (joined / own) | outputs |")
    print("|---" * (2 * len(modes) + 2) + "|")
    print(_row(f"`dsp-eval --suite random --count {args.count}`", eval_times, eval_check))
    print(_row(f"`dsp-replay` batch of those {args.count} logs", replay_times, replay_check))
    print()
    for kind, what, times in (("eval", "dsp-eval", eval_times),
                              ("replay", "dsp-replay batch", replay_times)):
        print(_ceiling(what, times, statistics.median(CPU[kind]), args.workers, args.renderer))
    for name, (first, t2, per) in overhead.items():
        print(f"{name}: 2 no-op tasks {first:.2f} s the first time, {t2:.2f} s the next "
              f"(start-up), then {1e3 * per:.2f} ms per further task ({args.tasks} tasks)")
    if ray_address is not None:
        print(f"ray: starting a local instance took {ray_start_s:.1f} s (paid by each "
              "--ray command when no RAY_ADDRESS is set)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
