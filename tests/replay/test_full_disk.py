"""A disk that fills up under every output kind, for real: the command runs in a child whose
file-size limit (RLIMIT_FSIZE, SIGXFSZ ignored) makes the operating system refuse writes
past a few bytes, as a full disk does. One line naming the output, exit 1, no temporary file,
no raw escape sequence, no hang."""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from synthetic import write_log

OUTPUTS = [("--out", "r.json"), ("--out-mcap", "e.mcap"), ("--out-csv", "r.csv"),
           ("--plot", "p.png"), ("--save", "r.rrd")]


def limited(room: int) -> None:
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (room, room))


def run_limited(command: str, args: list[str], room: int) -> subprocess.CompletedProcess[str]:
    """``command`` (a dsp.launch entry point) run with ``args`` in a child that may write
    files of ``room`` bytes at most; Rerun's own log lines off, as the commands set them."""
    env = {k: v for k, v in os.environ.items() if k != "RUST_LOG"}
    return subprocess.run(
        [sys.executable, "-c", f"import sys; from dsp.launch import {command}; "
         f"sys.exit({command}())", *args],
        preexec_fn=lambda: limited(room), capture_output=True, text=True, timeout=120,
        env=env, check=False)


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_log(tmp_path_factory.mktemp("log") / "in.mcap", duration_s=1.0).path


CASES = [(flag, name, when) for flag, name in OUTPUTS for when in ("full", "fills")
         if (flag, when) != ("--save", "fills")]
""""fills": room for the first few kilobytes. Not for an .rrd: when the disk fills within
its first kilobytes Rerun's own writer can block for good, which is why a disk with under
1 MiB free is refused before it starts (a file-size limit is not seen that way)."""


@pytest.mark.parametrize(("flag", "name", "when"), CASES)
def test_a_full_disk_is_one_line_and_leaves_nothing(log: Path, tmp_path: Path, flag: str,
                                                    name: str, when: str) -> None:
    room = 0 if when == "full" else 3000
    out = tmp_path / name
    proc = run_limited("replay", [str(log), flag, str(out), "-q", "--no-progress"], room)
    assert proc.returncode == 1, proc.stderr
    assert proc.stderr.startswith(f"dsp-replay: error: {out}: cannot write: "), proc.stderr
    assert proc.stderr.count("\n") == 1 and "\x1b" not in proc.stderr, proc.stderr
    assert list(tmp_path.iterdir()) == []


def _two_runs(log: Path, tmp_path: Path) -> tuple[Path, Path]:
    """The results of two replays of ``log`` (a.json the paper's, b.json the default's) in
    ``runs/``, and an empty ``out/`` folder for what dsp-compare writes."""
    from replay.cli import main as replay_main

    runs, out = tmp_path / "runs", tmp_path / "out"
    runs.mkdir()
    out.mkdir()
    for name, extra in (("a.json", ["--profile", "paper"]), ("b.json", [])):
        assert replay_main([str(log), "--out", str(runs / name), "-q", "--no-progress",
                            *extra]) == 0
    return runs, out


@pytest.mark.parametrize("room", [0, 20_000])
def test_a_full_disk_under_compare_save_is_one_line(log: Path, tmp_path: Path,
                                                     room: int) -> None:
    runs, out = _two_runs(log, tmp_path)
    rrd = out / "c.rrd"
    proc = run_limited("compare", [str(runs / "a.json"), str(runs / "b.json"), "--log",
                                   str(log), "--save", str(rrd), "-q"], room)
    assert proc.returncode == 1, proc.stderr
    assert proc.stderr.startswith(f"dsp-compare: error: {rrd}: cannot write: "), proc.stderr
    assert proc.stderr.count("\n") == 1 and "\x1b" not in proc.stderr, proc.stderr
    assert list(out.iterdir()) == []


def test_a_file_size_limit_too_small_for_an_rrd_is_refused_before_it_starts(
        log: Path, tmp_path: Path) -> None:
    """Rerun's writer can block for good when a limit stops it in its first kilobytes (a
    third of the runs under 2-30 kB), so a limit under 1 MiB is refused at the start."""
    out = tmp_path / "r.rrd"
    proc = run_limited("replay", [str(log), "--save", str(out), "-q", "--no-progress"], 20_000)
    assert proc.returncode == 1, proc.stderr
    assert proc.stderr == (f"dsp-replay: error: {out}: cannot write: File too large (a "
                           "file-size limit of 19 KiB)\n"), proc.stderr
    assert list(tmp_path.iterdir()) == []


def test_a_file_size_limit_above_a_mib_under_compare_save_is_one_line(tmp_path: Path) -> None:
    """Past the 1 MiB refused at the start (the .rrd of a 2 s log holds 2 MB or more), the
    writer a limit stops is one line, exit 1, no file, however it stops: with a flush that
    fails, or (tests/replay/compare/test_side_by_side.py) at the very end, in silence."""
    log = write_log(tmp_path / "in.mcap", duration_s=2.0).path
    runs, out = _two_runs(log, tmp_path)
    rrd = out / "c.rrd"
    proc = run_limited("compare", [str(runs / "a.json"), str(runs / "b.json"), "--log",
                                   str(log), "--save", str(rrd)], 1_100_000)
    assert proc.returncode == 1, proc.stderr
    assert proc.stderr.startswith(f"dsp-compare: error: {rrd}: cannot write: "), proc.stderr
    assert proc.stderr.count("\n") == 1 and "wrote" not in proc.stdout, proc.stdout
    assert list(out.iterdir()) == []
