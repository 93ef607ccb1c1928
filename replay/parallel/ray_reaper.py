"""Ends the local Ray instance a command started when the command is killed outright.

Run as a script (no project import: it starts at once) by :func:`start_reaper`, beside a
command that started a local Ray (``ray.init(address="local")``). Ray's own processes
share the fate of the command, but not all of them: killed with SIGKILL (or by the OOM
killer), the command leaves Ray's ``DashboardAgent`` and ``RuntimeEnvAgent`` running for a
minute or more (each waits for a GCS that died with the command, to report its raylet's
death). The reaper keeps a list of the command's descendants (with their start times, so a
reused pid is never taken for one of them); when the pipe from the command reads end of
file, the command is gone, and the reaper kills every one of them still running, then
exits. A command that ends normally stops the reaper first (:func:`stop_reaper`) and then
shuts Ray down itself. Linux only (it reads ``/proc``); elsewhere it does nothing.
"""

from __future__ import annotations

import contextlib
import os
import select
import signal
import subprocess
import sys
from pathlib import Path

__all__ = ["start_reaper", "stop_reaper"]

POLL_S = 0.25
"""How often the list of the command's descendants is refreshed."""


def _stat(pid: int) -> tuple[int, int] | None:
    """(parent pid, start time in clock ticks) of process ``pid``; None when it is gone."""
    try:
        fields = (Path("/proc") / str(pid) / "stat").read_bytes().rsplit(b")", 1)[1].split()
    except (OSError, IndexError):
        return None
    return int(fields[1]), int(fields[19])


def _descendants(roots: set[int]) -> dict[int, int]:
    """Every running process below ``roots`` (not the roots): pid -> start time."""
    children: dict[int, list[tuple[int, int]]] = {}
    for entry in os.scandir("/proc"):
        if entry.name.isdigit() and (st := _stat(int(entry.name))) is not None:
            children.setdefault(st[0], []).append((int(entry.name), st[1]))
    found: dict[int, int] = {}
    todo = list(roots)
    while todo:
        for pid, start in children.get(todo.pop(), []):
            if pid not in found and pid not in roots:
                found[pid] = start
                todo.append(pid)
    return found


def reap(command: int) -> None:
    """Watch ``command`` (the reaper's parent) until stdin reads end of file, then kill
    every descendant it had that still runs."""
    known: dict[int, int] = {}
    me = os.getpid()
    while True:
        known.update(_descendants({command}))
        known.pop(me, None)
        ready, _, _ = select.select([sys.stdin], [], [], POLL_S)
        if ready and not os.read(sys.stdin.fileno(), 4096):
            break
    known.update(_descendants(set(known)))  # what the last ones started meanwhile
    for pid, start in known.items():
        st = _stat(pid)
        if st is not None and st[1] == start and pid != me:
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)


def start_reaper() -> subprocess.Popen[bytes] | None:
    """Start the reaper of this process's descendants; None where it cannot run."""
    if not Path("/proc/self/stat").exists():
        return None  # pragma: no cover - no /proc
    try:
        return subprocess.Popen(
            [sys.executable, "-S", "-E", str(Path(__file__).resolve()), str(os.getpid())],
            stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            start_new_session=True)  # Ctrl-C at the terminal is the command's to handle
    except OSError:
        return None


def stop_reaper(reaper: subprocess.Popen[bytes] | None) -> None:
    """Stop the reaper without its reaping (the command ends Ray itself)."""
    if reaper is None:
        return
    reaper.kill()
    reaper.wait()
    if reaper.stdin is not None:
        reaper.stdin.close()


if __name__ == "__main__":
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    reap(int(sys.argv[1]))
