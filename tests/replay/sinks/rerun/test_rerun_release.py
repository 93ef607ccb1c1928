"""Library use: replay() called 100 times in one process with a save target leaves no native
Rerun thread behind and keeps memory flat, and every .rrd it saved is whole."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from synthetic import write_log

from replay import ReplayOptions, RerunTarget, replay


def threads() -> int:
    return len(os.listdir("/proc/self/task"))


def rss_kib() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise AssertionError("no VmRSS")


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="counts threads in /proc")
def test_a_hundred_saved_replays_keep_threads_and_memory_flat(tmp_path: Path) -> None:
    from rerun_bindings import check_for_rrd_footer

    log = write_log(tmp_path / "in.mcap", duration_s=0.1).path
    counts, rss = [], []
    for i in range(100):
        rrd = tmp_path / f"r{i % 2}.rrd"
        replay(log, ReplayOptions(rerun=RerunTarget("save", str(rrd)), progress=False,
                                  force=True))
        assert check_for_rrd_footer(str(rrd))  # closed whole before it was renamed
        counts.append(threads())
        rss.append(rss_kib())
    assert max(counts[10:]) <= counts[9], counts  # no thread per replay (was four)
    assert rss[-1] - rss[9] < 40_000, rss  # KiB over 90 replays
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.mcap", "r0.rrd", "r1.rrd"]
