"""A --ray command killed outright (SIGKILL, the OOM killer) takes the local Ray it started
with it: Ray's dashboard and runtime-env agents were left running on (for a minute or more,
waiting for a GCS that had died with the command)."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
from waiting import wait_for

pytest.importorskip("ray", reason="Ray is not installed (pip install -e '.[ray]')")

HERE = Path(__file__).resolve().parent
CHILD = """
import sys
from replay.parallel.pool import map_tasks
from replay.parallel.tasks import Workers
import sleepy
map_tasks(sleepy.nap, [f"{sys.argv[1]}/t{i}" for i in range(2)], Workers(count=1, ray=True))
"""


def _ray_processes(folder: Path) -> dict[int, str]:
    """The processes with a file open in ``folder`` (the Ray instance's temporary folder:
    Ray's processes rename themselves and overwrite their environment): pid -> name."""
    found = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and int(entry.name) != os.getpid():
            try:
                if any(os.readlink(fd).startswith(str(folder))
                       for fd in (entry / "fd").iterdir()):
                    found[int(entry.name)] = (entry / "cmdline").read_bytes().split(
                        b"\0")[0].decode(errors="replace")
            except OSError:
                continue
    return found



@pytest.mark.skipif(not Path("/proc/self/fd").exists(), reason="finds processes in /proc")
def test_a_ray_command_killed_outright_leaves_no_ray_process(tmp_path: Path) -> None:
    # Ray's own temporary folder, with a short name (its sockets' paths are limited)
    folder = Path(tempfile.mkdtemp(prefix="dsp-ray-"))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(HERE), *sys.path]),
           "RAY_TMPDIR": str(folder)}
    env.pop("RAY_ADDRESS", None)
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(tmp_path)], env=env,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        assert wait_for(lambda: any(tmp_path.glob("*.started")), 120.0), "no task started"
        agents = lambda: sum("Agent" in n for n in _ray_processes(folder).values())  # noqa: E731
        assert wait_for(lambda: agents() == 2, 30.0), _ray_processes(folder)
        child.send_signal(signal.SIGKILL)
        child.wait(timeout=30)
        # Ray's processes end with the command, its agents too, within a few seconds (the
        # agents alone took over a minute)
        assert wait_for(lambda: not _ray_processes(folder), 20.0), _ray_processes(folder)
    finally:
        for pid in _ray_processes(folder):  # on failure: leave none behind
            os.kill(pid, signal.SIGKILL)
        shutil.rmtree(folder, ignore_errors=True)
