"""Live viewing without a display: --connect to nothing and --rerun without a display fail
in seconds with one line; --serve binds 127.0.0.1, prints the URL, serves the web viewer
until SIGINT and then ends cleanly; a viewer that goes away mid-replay costs one line, and
the results are still written."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from dsp.errors import UsageError
from replay.options import ReplayOptions, RerunTarget
from replay.records import FrameResult
from replay.runner import replay
from replay.sink import SinkBase
from replay.sinks.rerun.live import ViewerServer, grpc_address, reachable

ROLLING = Path(__file__).resolve().parents[4] / "logs" / "golden" / "rolling.mcap"


def _run(*args: str, env: dict[str, str] | None = None) -> tuple[subprocess.CompletedProcess[str],
                                                              float]:
    t0 = time.monotonic()
    proc = subprocess.run([sys.executable, "-m", "replay.cli", str(ROLLING), *args],
                          capture_output=True, text=True, timeout=60, env=env)
    return proc, time.monotonic() - t0


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_connect_to_nothing_fails_fast_in_one_line() -> None:
    port = _free_port()
    proc, took = _run("--connect", f"rerun+http://127.0.0.1:{port}/proxy")
    assert proc.returncode == 1 and took < 20
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and f"no Rerun viewer is listening at 127.0.0.1:{port}" in lines[0]
    assert "Traceback" not in proc.stderr


def test_a_bad_connect_url_is_a_usage_error() -> None:
    proc, _ = _run("--connect", "http://127.0.0.1:9876")
    assert proc.returncode == 2 and "give a Rerun gRPC URL" in proc.stderr


def test_rerun_without_a_display_suggests_serve_or_save() -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    proc, took = _run("--rerun", env=env)
    assert proc.returncode == 1 and took < 20
    assert proc.stderr.count("\n") == 1
    assert "no display" in proc.stderr and "--serve" in proc.stderr and "--save" in proc.stderr


def test_bind_and_port_go_with_serve_only() -> None:
    proc, _ = _run("--port", "9000")
    assert proc.returncode == 2 and "--port only go with --serve" in proc.stderr


@pytest.mark.parametrize(("bind", "says"), [
    ("999.1.1.1", "--bind 999.1.1.1: not an IP address (e.g. 127.0.0.1, or 0.0.0.0 for every "
     "interface)"),
    ("192.0.2.1", "--bind 192.0.2.1: cannot listen on this address here ("),  # TEST-NET-1
])
def test_a_bind_address_that_cannot_be_listened_on_is_one_line(bind: str, says: str) -> None:
    with pytest.raises(UsageError) as err:
        ViewerServer(bind=bind, web_port=0, grpc_port=0)
    assert str(err.value).startswith(says)  # was: "--port 9090: already in use"


def _listening_address(port: int) -> str | None:
    """The local address a TCP socket listens on at ``port`` (Linux /proc/net/tcp)."""
    for line in Path("/proc/net/tcp").read_text().splitlines()[1:]:
        local, state = line.split()[1], line.split()[3]
        address, hex_port = local.split(":")
        if state == "0A" and int(hex_port, 16) == port:
            return ".".join(str(b) for b in reversed(bytes.fromhex(address)))
    return None


CTRL_C_IGNORED = pytest.mark.skipif(
    signal.getsignal(signal.SIGINT) is signal.SIG_IGN,
    reason="SIGINT is ignored here (started as a background job), and so in the children")


@CTRL_C_IGNORED
@pytest.mark.skipif(not Path("/proc/net/tcp").exists(), reason="reads Linux's socket table")
def test_serve_binds_localhost_prints_the_url_and_stops_on_sigint(tmp_path: Path) -> None:
    web, grpc = _free_port(), _free_port()
    out = tmp_path / "r.json"
    proc = subprocess.Popen(
        [sys.executable, "-m", "replay.cli", str(ROLLING), "--serve", "--port", str(web),
         "--grpc-port", str(grpc), "--out", str(out), "-q"],
        stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stderr is not None
        first = proc.stderr.readline()
        url = f"http://127.0.0.1:{web}/?url=rerun%2Bhttp%3A%2F%2F127.0.0.1%3A{grpc}%2Fproxy"
        assert url in first and "Ctrl-C" in first, first
        assert _listening_address(web) == "127.0.0.1"
        assert _listening_address(grpc) == "127.0.0.1"
        with urllib.request.urlopen(url, timeout=60) as page:
            assert page.status == 200 and b"<html" in page.read(4096).lower()
        done = proc.stderr.readline()
        while done.startswith("warning: "):  # robot1 of the rolling log never sees the ball
            done = proc.stderr.readline()
        assert "replay done; still serving" in done, done
        assert out.exists()
        time.sleep(0.5)
        assert proc.poll() is None, "it serves until Ctrl-C"
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=60) == 130  # Ctrl-C, as the README lists it
        assert "stopped serving" in proc.stderr.read()
        assert not reachable("127.0.0.1", web, 0.5) and not reachable("127.0.0.1", grpc, 0.5)
    finally:
        if proc.poll() is None:  # a failed check: Ctrl-C first, so its server stops too
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        for stream in (proc.stdout, proc.stderr):
            if stream is not None:
                stream.close()


def _children(pid: int) -> list[int]:
    path = Path(f"/proc/{pid}/task/{pid}/children")
    return [int(c) for c in path.read_text().split()] if path.exists() else []


@contextlib.contextmanager
def _serving() -> Iterator[tuple[subprocess.Popen[str], int, int, list[int]]]:
    """``dsp-replay --serve`` in a child, once it serves: (it, web port, gRPC port, its
    children); killed at the end if it still runs."""
    web, grpc = _free_port(), _free_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "replay.cli", str(ROLLING), "--serve", "--port", str(web),
         "--grpc-port", str(grpc), "-q"],
        stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    try:
        assert proc.stderr is not None
        assert "serving the Rerun web viewer" in proc.stderr.readline()
        children = _children(proc.pid)
        assert children, "the Rerun server runs as a child"
        yield proc, web, grpc, children
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        if proc.stderr is not None:
            proc.stderr.close()


def _running(pid: int) -> bool:
    stat = Path(f"/proc/{pid}/stat")
    try:
        return stat.read_text().split()[2] != "Z"
    except OSError:  # gone
        return False


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="lists children in /proc")
def test_sigterm_while_serving_stops_the_rerun_server_too() -> None:
    with _serving() as (proc, web, grpc, children):
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=60) == 130
        assert proc.stderr is not None and "Traceback" not in proc.stderr.read()
        assert not any(_running(c) for c in children), "outlived"
        assert not reachable("127.0.0.1", web, 0.5) and not reachable("127.0.0.1", grpc, 0.5)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Linux's parent-death signal")
def test_sigkill_while_serving_does_not_leave_the_rerun_server_listening() -> None:
    """SIGKILL cannot be caught: the server is started so that the system ends it with us."""
    with _serving() as (proc, web, grpc, children):
        proc.kill()
        proc.wait(timeout=30)

        def ended() -> bool:  # a zombie leader's other threads may still hold its sockets
            return not any(_running(c) for c in children) and not reachable(
                "127.0.0.1", web, 0.5) and not reachable("127.0.0.1", grpc, 0.5)

        deadline = time.monotonic() + 20
        while not ended() and time.monotonic() < deadline:
            time.sleep(0.1)
        assert ended(), "the server outlived a SIGKILL"


_CTRL_C_STORM = """
import os, signal, sys, threading, time
from replay.sinks.rerun.live import ViewerServer, reachable

late = []
signal.signal(signal.SIGINT, lambda *_: late.append(1))  # what serving hands back
server = ViewerServer(web_port=0, grpc_port=0).start()

def storm():
    time.sleep(0.3)
    for _ in range(200):
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.001)

sender = threading.Thread(target=storm)
sender.start()
stopped = server.serve_forever(poll_s=0.0005)  # most of the time inside Popen.poll
sender.join()
print(stopped, reachable("127.0.0.1", server.grpc_port, 0.5),
      reachable("127.0.0.1", server.web_port, 0.5))
"""


@pytest.mark.skipif(sys.platform.startswith("win"), reason="sends SIGINT to itself")
def test_ctrl_c_storm_while_serving_stops_the_server_once_and_never_hangs() -> None:
    """Ctrl-C landing inside ``Popen.poll`` (between its lock's acquire and its try) left the
    lock taken; the wait that reaps the server then blocked until a second Ctrl-C."""
    proc = subprocess.run([sys.executable, "-c", _CTRL_C_STORM], capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["True", "False", "False"], proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr


_CTRL_C_AT_START = """
import os, signal, threading, time
from replay.sinks.rerun.live import ViewerServer

threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT)).start()
try:
    ViewerServer(web_port=0, grpc_port=0, start_s=30).start()
except KeyboardInterrupt:
    try:  # 0: a child still runs; a pid: one that had ended, reaped now
        print("a child is left" if os.waitpid(-1, os.WNOHANG)[0] == 0 else "no child left")
    except ChildProcessError:
        print("no child left")
"""


@CTRL_C_IGNORED
@pytest.mark.skipif(sys.platform.startswith("win"), reason="a shell script as the server")
def test_ctrl_c_while_the_server_starts_stops_it(tmp_path: Path) -> None:
    never_listens = tmp_path / "rerun"
    never_listens.write_text("#!/bin/sh\nexec sleep 30\n")
    never_listens.chmod(0o755)
    env = {**os.environ, "RERUN_CLI_PATH": str(never_listens)}
    t0 = time.monotonic()
    proc = subprocess.run([sys.executable, "-c", _CTRL_C_AT_START], capture_output=True,
                          text=True, timeout=60, env=env)
    assert proc.stdout.strip() == "no child left", proc.stdout + proc.stderr
    assert time.monotonic() - t0 < 20  # not the 30 s the fake server sleeps


@pytest.mark.skipif(sys.platform.startswith("win"), reason="a shell script as the server")
@pytest.mark.parametrize("log", ["missing.mcap", ".", "notmcap.mcap"])
def test_serve_refuses_a_path_that_is_no_log_before_any_server_starts(tmp_path: Path,
                                                                      log: str) -> None:
    started = tmp_path / "started"
    server = tmp_path / "rerun"
    server.write_text(f"#!/bin/sh\ntouch {started}\nexec sleep 30\n")
    server.chmod(0o755)
    (tmp_path / "notmcap.mcap").write_text("not a log\n")
    proc = subprocess.run([sys.executable, "-m", "replay.cli", log, "--serve", "--port", "0",
                           "--grpc-port", "0"], capture_output=True, text=True, timeout=60,
                          cwd=tmp_path, env={**os.environ, "RERUN_CLI_PATH": str(server)})
    assert proc.returncode == 1
    assert proc.stderr.startswith(f"dsp-replay: error: {log}: ") and proc.stderr.count("\n") == 1
    assert "serving" not in proc.stderr and not started.exists()


class _StopViewer(SinkBase):
    """Stops the viewer after the first frame, then lets the liveness check come due."""

    def __init__(self, server: ViewerServer) -> None:
        self.server = server

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        if result.frame == 0:
            self.server.stop()
            time.sleep(1.1)


def test_a_viewer_that_goes_away_costs_one_line_and_the_results_are_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    server = ViewerServer(web_port=0, grpc_port=0).start()
    assert reachable(*grpc_address(server.grpc_url))
    out = tmp_path / "r.json"
    t0 = time.monotonic()
    summary = replay(ROLLING, ReplayOptions(rerun=RerunTarget("connect", server.grpc_url),
                                            out=out, progress=False),
                     sinks=[_StopViewer(server)])
    assert time.monotonic() - t0 < 30
    err = capsys.readouterr().err
    assert err.count("the Rerun viewer went away") == 1, err
    assert summary.frames == 12
    assert len(json.loads(out.read_text())["frames"]) == 12
