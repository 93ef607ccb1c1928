"""Live viewing: a Rerun viewer that is there, or one line saying why not.

- :class:`ViewerServer` (``dsp-replay --serve``): the Rerun web viewer and its gRPC server,
  run as the ``rerun`` program that rerun-sdk ships, bound to ``--bind`` (127.0.0.1 unless
  asked: the data is not published to the network by default) on ``--port`` (the page to
  open) and ``--grpc-port``; it serves until Ctrl-C, and ends with the command (on Linux
  also when that is killed outright). (The SDK's own ``serve_grpc`` binds every interface
  and offers no address.)
- :func:`check_reachable` (``--connect``): a viewer must be listening at the URL, checked
  in about a second, before anything is logged.
- :func:`check_display` (``--rerun``): a viewer window needs a display; without one the
  message suggests ``--serve`` or ``--save``.
- :class:`Liveness`: while replaying, the viewer is checked about once a second; one that
  went away ends the viewing with one line, and the replay goes on to write its results.
"""

from __future__ import annotations

import contextlib
import ipaddress
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from types import TracebackType
from urllib.parse import quote, urlsplit

from dsp.checks import check_int
from dsp.errors import DspError, UsageError

__all__ = [
    "DEFAULT_BIND",
    "DEFAULT_GRPC_PORT",
    "DEFAULT_WEB_PORT",
    "MAX_PORT",
    "Liveness",
    "ViewerServer",
    "ViewerUnavailableError",
    "check_display",
    "check_reachable",
    "grpc_address",
    "reachable",
    "rerun_executable",
]

DEFAULT_BIND = "127.0.0.1"
DEFAULT_WEB_PORT = 9090
DEFAULT_GRPC_PORT = 9876
_SCHEMES = {"rerun": 9876, "rerun+http": 80, "rerun+https": 443}


class ViewerUnavailableError(DspError):
    """No Rerun viewer is reachable, or the one in use went away."""


def grpc_address(url: str) -> tuple[str, int]:
    """``rerun+http://127.0.0.1:9876/proxy`` -> ("127.0.0.1", 9876); a bad URL is a
    :class:`~dsp.errors.UsageError`."""
    parts = urlsplit(url)
    if parts.scheme not in _SCHEMES or parts.path != "/proxy" or not parts.hostname:
        raise UsageError(f"--connect {url!r}: give a Rerun gRPC URL such as "
                         "rerun+http://127.0.0.1:9876/proxy")
    try:
        port = parts.port or _SCHEMES[parts.scheme]
    except ValueError:
        raise UsageError(f"--connect {url!r}: the port is not a number") from None
    return parts.hostname, port


def reachable(host: str, port: int, timeout_s: float = 1.0) -> bool:
    """True when something accepts a TCP connection at ``host:port`` within ``timeout_s``."""
    try:
        with socket.create_connection((host, port), timeout=timeout_s):
            return True
    except OSError:
        return False


def check_reachable(url: str, timeout_s: float = 2.0) -> None:
    """Raise :class:`ViewerUnavailableError` unless a viewer listens at ``url``."""
    host, port = grpc_address(url)
    if not reachable(host, port, timeout_s):
        raise ViewerUnavailableError(
            f"--connect {url}: no Rerun viewer is listening at {host}:{port} (start one with "
            "`rerun`, or use --serve to watch in a browser, or --save FILE.rrd)")


def check_display() -> None:
    """Raise :class:`ViewerUnavailableError` when a viewer window could not be shown."""
    if sys.platform.startswith("linux") and not (
            os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise ViewerUnavailableError(
            "--rerun: no display to open a viewer window on (DISPLAY and WAYLAND_DISPLAY are "
            "unset); use --serve to watch in a browser, or --save FILE.rrd to open later")


def rerun_executable() -> Path:
    """The ``rerun`` program that rerun-sdk ships (``RERUN_CLI_PATH`` overrides)."""
    override = os.environ.get("RERUN_CLI_PATH")
    if override:
        return Path(override)
    import rerun_cli

    name = "rerun.exe" if sys.platform.startswith("win") else "rerun"
    return Path(rerun_cli.__file__).parent / name


def _check_bind(bind: str) -> None:
    """Refuse a ``--bind`` that is not an IP address, or not one of this machine's."""
    try:
        ipaddress.ip_address(bind)
    except ValueError:
        raise UsageError(f"--bind {bind}: not an IP address (e.g. 127.0.0.1, or 0.0.0.0 for "
                         "every interface)") from None
    with socket.socket(socket.AF_INET6 if ":" in bind else socket.AF_INET) as s:
        try:
            s.bind((bind, 0))
        except OSError as err:
            raise UsageError(f"--bind {bind}: cannot listen on this address here "
                             f"({err.strerror or err}); give one of this machine's") from None


def _port_free(bind: str, port: int) -> bool:
    with socket.socket(socket.AF_INET6 if ":" in bind else socket.AF_INET) as s:
        try:
            s.bind((bind, port))
        except OSError:
            return False
    return True


def _free_port(bind: str) -> int:
    with socket.socket(socket.AF_INET6 if ":" in bind else socket.AF_INET) as s:
        s.bind((bind, 0))
        return int(s.getsockname()[1])


_ENDS_WITH_PARENT = """\
import ctypes, os, signal, sys
ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
if os.getppid() != int(sys.argv[1]):
    sys.exit(0)  # the parent ended before the line above
os.execv(sys.argv[2], sys.argv[2:])
"""
"""Linux: the server is started through this, so that it is sent SIGTERM when the thread that
started it ends, however it ends (SIGKILL, a crash), and does not go on listening alone."""


@contextlib.contextmanager
def _signals_as_flag(asked: list[int]) -> Iterator[None]:
    """Within the block, SIGINT and SIGTERM append their number to ``asked`` instead of
    raising (in the main thread, and unless ignored; elsewhere signals are left alone)."""
    def note(signum: int, _frame: object) -> None:
        asked.append(signum)

    previous = []
    try:
        for sig in (signal.SIGINT, signal.SIGTERM):
            if signal.getsignal(sig) is not signal.SIG_IGN:  # nohup'd: stays ignored
                previous.append((sig, signal.signal(sig, note)))
    except ValueError:  # not the main thread
        pass
    try:
        yield
    finally:
        for sig, handler in previous:
            if handler is not None:  # None: set outside Python, cannot be put back
                signal.signal(sig, handler)


MAX_PORT = 65535
"""The largest TCP port."""


class ViewerServer:
    """The Rerun web viewer and gRPC server as a child process (see the module docstring).

    Port 0 picks a free port. Raises :class:`~dsp.errors.UsageError` for a port in use and
    :class:`ViewerUnavailableError` when the server does not start within ``start_s``."""

    def __init__(self, *, bind: str = DEFAULT_BIND, web_port: int = DEFAULT_WEB_PORT,
                 grpc_port: int = DEFAULT_GRPC_PORT, start_s: float = 15.0) -> None:
        check_int("--port", web_port, low=0, high=MAX_PORT)
        check_int("--grpc-port", grpc_port, low=0, high=MAX_PORT)
        _check_bind(bind)
        self.bind = bind
        self.web_port = web_port or _free_port(bind)
        self.grpc_port = grpc_port or _free_port(bind)
        self.start_s = start_s
        self._proc: subprocess.Popen[bytes] | None = None
        self._log = tempfile.TemporaryFile()
        self.extra_args: list[str] = []
        """More arguments for ``rerun``, e.g. an .rrd file to serve."""

    @property
    def host(self) -> str:
        """Where a browser on this machine reaches the server."""
        if self.bind in ("0.0.0.0", "::", ""):
            return "127.0.0.1"
        return f"[{self.bind}]" if ":" in self.bind else self.bind

    @property
    def grpc_url(self) -> str:
        return f"rerun+http://{self.host}:{self.grpc_port}/proxy"

    @property
    def web_url(self) -> str:
        """The page to open: the web viewer, connected to the gRPC server."""
        return f"http://{self.host}:{self.web_port}/?url={quote(self.grpc_url, safe='')}"

    def start(self) -> ViewerServer:
        for flag, port in (("--port", self.web_port), ("--grpc-port", self.grpc_port)):
            if not _port_free(self.bind, port):
                raise UsageError(f"{flag} {port}: already in use on {self.bind}; choose "
                                 f"another ({flag} 0 picks a free one)")
        exe = rerun_executable()
        if not (exe.is_file() and os.access(exe, os.X_OK)):
            raise ViewerUnavailableError(f"--serve: cannot run {exe}: not an executable file")
        cmd = [str(exe), "--serve-web", "--bind", self.bind, "--port", str(self.grpc_port),
               "--web-viewer-port", str(self.web_port), *self.extra_args]
        if sys.platform.startswith("linux"):  # ends with us, even when we are killed outright
            cmd = [sys.executable, "-c", _ENDS_WITH_PARENT, str(os.getpid()), *cmd]
        try:
            self._proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=self._log,
                                          stderr=subprocess.STDOUT)
        except OSError as err:
            raise ViewerUnavailableError(f"--serve: cannot run {exe}: {err}") from err
        try:
            self._wait_until_listening()
        except BaseException:  # Ctrl-C while it starts: it must not outlive us
            self.stop()
            raise
        return self

    def _wait_until_listening(self) -> None:
        assert self._proc is not None
        deadline = time.monotonic() + self.start_s
        host = self.host.strip("[]")
        while not (reachable(host, self.grpc_port, 0.5) and reachable(host, self.web_port, 0.5)):
            if self._proc.poll() is not None or time.monotonic() > deadline:
                detail = self._last_log_line()
                raise ViewerUnavailableError(
                    f"--serve: the Rerun server did not start on {self.bind}"
                    + (f": {detail}" if detail else ""))
            time.sleep(0.1)

    def _last_log_line(self) -> str:
        self._log.seek(0)
        lines = [ln for ln in self._log.read().decode(errors="replace").splitlines()
                 if ln.strip()]
        return lines[-1].strip()[:200] if lines else ""

    def alive(self) -> bool:
        return self._proc is not None and self._proc.poll() is None

    def serve_forever(self, poll_s: float = 0.25) -> bool:
        """Block until Ctrl-C or SIGTERM (or the server ends); then stop it. Ctrl-C here is
        the normal way to end serving, so it returns (True) instead of raising; False: the
        server ended by itself.

        While serving and stopping, the two signals only set a flag: an interrupt raised
        inside ``Popen.poll`` between its lock's acquire and its ``try`` leaves that lock
        taken, and the ``wait`` that reaps the server then blocks for good."""
        asked: list[int] = []
        with _signals_as_flag(asked):
            try:
                while self.alive() and not asked:
                    time.sleep(poll_s)
            finally:
                self.stop()
        return bool(asked)

    def stop(self, wait_s: float = 5.0) -> None:
        """Terminate the server; kill it if it has not ended after ``wait_s``. Never blocks
        for longer than twice that."""
        proc, self._proc = self._proc, None
        if proc is not None and proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=wait_s)
            except subprocess.TimeoutExpired:
                proc.kill()
                with contextlib.suppress(subprocess.TimeoutExpired):
                    proc.wait(timeout=wait_s)  # killed: the system reaps it if we cannot
        self._log.close()

    def __enter__(self) -> ViewerServer:
        return self.start()

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.stop()


class Liveness:
    """Checks, at most every ``interval_s``, that the viewer is still there."""

    def __init__(self, check: Callable[[], bool], *, interval_s: float = 1.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.check = check
        self.interval_s = interval_s
        self.clock = clock
        self.last = clock()

    def gone(self) -> bool:
        """True when the check is due and fails."""
        now = self.clock()
        if now - self.last < self.interval_s:
            return False
        self.last = now
        return not self.check()
