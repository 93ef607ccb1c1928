"""Library use: replay() called 100 times in one process with a save target leaves no native
Rerun thread behind and keeps memory flat, and every .rrd it saved is whole."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from synthetic import write_log

CHILD = """
import gc, json, os, sys
from pathlib import Path
from replay import ReplayOptions, RerunTarget, replay
from rerun_bindings import check_for_rrd_footer

def status_kib(key):
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1])
    raise SystemExit("no " + key)

log, out = Path(sys.argv[1]), Path(sys.argv[2])
counts, rss, size, whole = [], [], [], []
for i in range(100):
    rrd = out / f"r{i % 2}.rrd"
    replay(log, ReplayOptions(rerun=RerunTarget("save", str(rrd)), progress=False, force=True))
    whole.append(check_for_rrd_footer(str(rrd)))  # closed whole before it was renamed
    counts.append(len(os.listdir("/proc/self/task")))
    gc.collect()  # what the replay left for the collector is not a leak
    rss.append(status_kib("VmRSS"))
    size.append(status_kib("VmSize"))
print(json.dumps({"counts": counts, "rss": rss, "size": size, "whole": whole}))
"""
"""A program that replays one log 100 times with a save target, in a process of its own: a
test worker's memory after hundreds of other tests grows and shrinks with what they left."""


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="counts threads in /proc")
def test_a_hundred_saved_replays_keep_threads_and_memory_flat(tmp_path: Path) -> None:
    log = write_log(tmp_path / "in.mcap", duration_s=0.1).path
    out = tmp_path / "out"
    out.mkdir()
    run = subprocess.run([sys.executable, "-c", CHILD, str(log), str(out)], cwd=out,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    measured = json.loads(run.stdout.splitlines()[-1])
    counts, rss, size = measured["counts"], measured["rss"], measured["size"]
    assert all(measured["whole"])
    # no thread per replay (was four: 360 more over these 90)
    assert max(counts[10:]) <= counts[9] + 2, counts
    # the allocator settles over the first replays; after that nothing grows with each one
    # (each used to keep four threads, one reserving ~2.9 GiB of address space). A leak
    # raises the floor (the least of 25 replays) of every 25 replays over the 25 before, a
    # one-off step only one of them (1 MiB a replay: +25 MiB each time)
    assert size[-1] - size[49] < 256 * 1024, size[::10]
    floors = [min(rss[i:i + 25]) for i in (25, 50, 75)]
    assert min(floors[1] - floors[0], floors[2] - floors[1]) < 16 * 1024, (floors, rss[::5])
    assert sorted(p.name for p in out.iterdir()) == ["r0.rrd", "r1.rrd"]
