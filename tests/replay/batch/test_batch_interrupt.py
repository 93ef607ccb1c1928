"""Ctrl-C on a batch on a process pool: the workers are stopped at once (SIGTERM, no
clean-up of their own), and the hidden temporaries of the logs they were writing are
removed, so an interrupted batch leaves nothing but the outputs it finished."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from synthetic import write_log
from waiting import wait_for

from dsp.errors import EXIT_INTERRUPTED

SLOW = """
import os, time
if os.environ.get("DSP_SLOW_FRAMES"):
    import replay.runner as runner
    emit = runner._Stream._emit_frame
    def slow(self, result, image):
        time.sleep(0.5)
        emit(self, result, image)
    runner._Stream._emit_frame = slow
"""
"""Every frame half a second slower, in the command and in each worker (a sitecustomize
module runs in every Python process that starts with it on the path)."""



@pytest.mark.skipif(sys.platform == "win32", reason="sends SIGINT to a child")
def test_an_interrupted_pool_batch_leaves_no_temporary(tmp_path: Path) -> None:
    logs, out, site = tmp_path / "logs", tmp_path / "out", tmp_path / "site"
    for d in (logs, site):
        d.mkdir()
    for name in ("a", "b"):
        write_log(logs / f"{name}.mcap", duration_s=0.5)
    (site / "sitecustomize.py").write_text(SLOW)
    env = {**os.environ, "DSP_SLOW_FRAMES": "1",
           "PYTHONPATH": os.pathsep.join([str(site), *sys.path])}
    child = subprocess.Popen(
        [sys.executable, "-c", "import sys; from dsp.launch import replay; sys.exit(replay())",
         str(logs), "--out-dir", str(out), "--estimates", "--workers", "2", "-q",
         "--no-progress"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
        text=True)
    try:
        # both logs in progress: each its results JSON and estimates MCAP being written
        assert wait_for(lambda: len(list(out.glob(".*.tmp"))) == 4, 120.0), \
            sorted(p.name for p in out.glob("*")) if out.exists() else "no output folder"
        child.send_signal(signal.SIGINT)
        _, err = child.communicate(timeout=60)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    assert child.returncode == EXIT_INTERRUPTED, err
    assert sorted(p.name for p in out.iterdir()) == []
