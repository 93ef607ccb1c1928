"""Benchmark dsp-compare's memory: peak RSS against the size of the results files it reads.

    python benchmarks/bench_compare_memory.py [--steps 10000 100000 300000]

For each ``--steps`` count it writes two results files of that many fused steps (and as
many frames), made of the golden ``scenario1.corrected-track.json``'s items repeated at
new stamps and laid out as ``dsp-replay --out`` writes them (one item a line, sorted keys),
then runs ``dsp-compare A B -q`` in a child process and reads the child's own peak resident
set (``os.wait4``). It prints a Markdown table: the input size, the peak, the peak less the
command's floor (``dsp-compare --version``: Python, numpy and the imports) and that
difference over the input size, the number that says whether memory grows in proportion.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "logs" / "golden" / "scenario1.corrected-track.json"
STEP_NS = 16_666_667


def _write(path: Path, steps: int, shift: float) -> None:
    """A results file of ``steps`` fused steps and ``steps`` frames."""
    doc = json.loads(GOLDEN.read_text())
    frames, fused = doc.pop("frames"), doc.pop("fused")
    with path.open("w", encoding="utf-8") as f:
        f.write("{\n")
        for key in sorted(doc):  # the header first, then the two long lists
            f.write(f"{json.dumps(key)}: {json.dumps(doc[key], sort_keys=True)},\n")
        for name, items in (("frames", frames), ("fused", fused)):
            f.write(f'"{name}": [\n')
            for k in range(steps):
                item = dict(items[k % len(items)])
                item["stamp_ns"] = k * STEP_NS
                if "robot" in item:
                    item["robot"] = f"robot{k % 3 + 1}"
                if item.get("error_m") is not None:
                    item["error_m"] = round(item["error_m"] + shift * (k % 7), 6)
                end = ",\n" if k < steps - 1 else "\n"
                f.write("  " + json.dumps(item, sort_keys=True) + end)
            f.write("],\n" if name == "frames" else "]\n")
        f.write("}\n")


def _peak_mib(argv: list[str]) -> float:
    """The child's own peak resident set [MiB]."""
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} exited {proc.returncode}")
    return usage.ru_maxrss / 1024.0  # kB on Linux


def main() -> None:
    p = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, nargs="+", default=[10_000, 100_000, 300_000])
    args = p.parse_args()
    exe = [sys.executable, "-m", "replay.compare.cli"]
    floor = _peak_mib([*exe, "--version"])
    print(f"floor (dsp-compare --version): {floor:.0f} MiB\n")
    print("| steps | input (2 files) MiB | peak MiB | peak - floor MiB | (peak - floor) / input |")
    print("|---:|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for steps in args.steps:
            a, b = Path(tmp) / f"a-{steps}.json", Path(tmp) / f"b-{steps}.json"
            _write(a, steps, 0.0)
            _write(b, steps, 0.0001)
            size = (a.stat().st_size + b.stat().st_size) / 2**20
            peak = _peak_mib([*exe, str(a), str(b), "--replicates", "100", "-q"])
            print(f"| {steps} | {size:.1f} | {peak:.0f} | {peak - floor:.0f} | "
                  f"{(peak - floor) / size:.2f} |", flush=True)
            a.unlink()
            b.unlink()


if __name__ == "__main__":
    main()
