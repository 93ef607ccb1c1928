"""replay.memory: with glibc's thresholds fixed, freed image-sized buffers stay mapped and
the next ones reuse their pages instead of faulting in fresh ones."""

from __future__ import annotations

import json
import platform
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

# Rounds of four 1080 x 1080 x 3 buffers alive at once (a few images in flight), filled, then
# all freed: 14 MB of free heap top, over glibc's adaptive trim threshold (twice one buffer),
# so by default it goes back to the kernel and the next round faults every page in again.
# Both in one process, the default first (the tuning cannot be undone); the module is run
# from its file, without importing the replay package (OpenCV, mcap).
CHURN = r"""
import json, resource, runpy, sys
import numpy as np
def faults():
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt
def per_round(n=8):
    f0 = faults()
    for _ in range(n):
        alive = [np.ones((1080, 1080, 3), np.uint8) for _ in range(4)]
        del alive
    return (faults() - f0) / n
per_round(2)  # warm: the thresholds have adapted, the heap has grown
default = per_round()
assert runpy.run_path(sys.argv[1])["keep_image_buffers"]()
per_round(1)
print(json.dumps([default, per_round()]))
"""


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="glibc malloc tuning")
def test_freed_image_buffers_are_reused_not_faulted_in_again() -> None:
    proc = subprocess.run([sys.executable, "-c", CHURN, str(ROOT / "replay" / "memory.py")],
                          capture_output=True, text=True, check=True)
    default, kept = json.loads(proc.stdout)
    pages = 4 * 1080 * 1080 * 3 / 4096  # one round's buffers, in 4 kB pages
    assert default > 0.5 * pages  # by default every round faults its buffers in again
    assert kept < 0.05 * pages


def test_dsp_replay_keeps_image_buffers(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import replay.cli

    calls: list[bool] = []
    keep = replay.cli.keep_image_buffers
    monkeypatch.setattr(replay.cli, "keep_image_buffers", lambda: calls.append(keep()) or True)
    log = ROOT / "logs" / "golden" / "scenario2.mcap"
    assert replay.cli.main([str(log), "--out", str(tmp_path / "r.json"), "-q"]) == 0
    assert calls == [platform.libc_ver()[0] == "glibc"]
    # the same bytes as the golden results of the default (made without the tuning)
    assert (tmp_path / "r.json").read_bytes() == \
        (ROOT / "logs" / "golden" / "scenario2.profile-best.json").read_bytes()
