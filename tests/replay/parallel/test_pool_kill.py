"""A command killed outright (SIGKILL, the OOM killer) cannot stop its pool workers; they
see it gone and end within a moment, instead of running on and writing for nobody."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import uuid
from pathlib import Path

import pytest
from waiting import wait_for

HERE = Path(__file__).resolve().parent
CHILD = """
import sys
from replay.parallel.pool import map_tasks
from replay.parallel.tasks import Workers
import sleepy
map_tasks(sleepy.nap, [f"{sys.argv[1]}/t{i}" for i in range(4)], Workers(count=2))
"""


def _marked(mark: str) -> list[int]:
    """The processes whose environment holds ``mark``."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if mark.encode() in (entry / "environ").read_bytes():
                    found.append(int(entry.name))
            except OSError:
                continue
    return found



@pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="finds processes in /proc")
def test_pool_workers_end_when_their_command_is_killed(tmp_path: Path) -> None:
    mark = f"DSP_POOL_TEST={uuid.uuid4().hex}"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(HERE), *sys.path]),
           mark.split("=")[0]: mark.split("=")[1]}
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(tmp_path)], env=env,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        started = lambda: len(list(tmp_path.glob("*.started"))) == 2  # noqa: E731
        assert wait_for(started, 60.0), "the workers never started"
        child.send_signal(signal.SIGKILL)
        child.wait(timeout=30)
        # the workers (and the fork server after them) end within a second or two
        assert wait_for(lambda: not _marked(mark), 10.0), _marked(mark)
    finally:
        for pid in _marked(mark):  # on failure: leave no sleeper behind
            os.kill(pid, signal.SIGKILL)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t0.started", "t1.started"]


def _state(pid: int) -> bytes:
    return (Path("/proc") / str(pid) / "stat").read_bytes().rsplit(b")", 1)[1].split()[0]


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")
def test_a_command_that_ended_but_is_not_yet_reaped_is_not_running() -> None:
    """A command killed outright while its own parent has not yet waited for it is a zombie:
    a signal still reaches its pid, but the workers must see it gone, not running."""
    from replay.parallel.pool import _running

    assert _running(os.getpid())
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    try:
        # not waited for (poll would reap it): the ended child stays a zombie
        assert wait_for(lambda: _state(child.pid) == b"Z", 30.0), _state(child.pid)
        os.kill(child.pid, 0)  # still a pid a signal reaches...
        assert not _running(child.pid)  # ...but not running
    finally:
        child.wait()
