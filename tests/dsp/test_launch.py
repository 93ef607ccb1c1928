"""The commands' entry points: Ctrl-C while a command is still importing is one line and exit
130, never a KeyboardInterrupt traceback; each entry point runs its command."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

CHILD = """
import importlib, os, signal, sys
import dsp.launch as launch
real = importlib.import_module
def interrupted_import(name):
    os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C as the command's modules load
    return real(name)
launch.importlib.import_module = interrupted_import
sys.exit(getattr(launch, sys.argv[1])())
"""


@pytest.mark.parametrize(("entry", "prog"), [("replay", "dsp-replay"), ("info", "dsp-info"),
                                             ("record", "dsp-record"), ("evaluate", "dsp-eval"),
                                             ("compare", "dsp-compare"),
                                             ("calibrate", "dsp-calibrate")])
def test_ctrl_c_during_import_is_one_line_and_130(entry: str, prog: str) -> None:
    proc = subprocess.run([sys.executable, "-c", CHILD, entry], capture_output=True,
                          text=True, timeout=60, check=False)
    assert (proc.returncode, proc.stderr, proc.stdout) == (130, f"{prog}: interrupted\n", "")


def test_an_entry_point_runs_its_command() -> None:
    proc = subprocess.run([sys.executable, "-c", "import sys, dsp.launch as l; "
                           "sys.exit(l.info())", "--version"], capture_output=True, text=True,
                          timeout=60, check=False)
    assert proc.returncode == 0 and proc.stdout.startswith("dsp-info ")


def test_the_scripts_are_the_entry_points() -> None:
    text = (Path(__file__).resolve().parents[2] / "pyproject.toml").read_text()
    scripts = text.split("[project.scripts]")[1].split("\n[")[0]
    entries = dict(line.replace('"', "").split(" = ") for line in scripts.splitlines()
                   if " = " in line and not line.startswith("#"))
    assert entries == {
        "dsp-record": "dsp.launch:record", "dsp-replay": "dsp.launch:replay",
        "dsp-calibrate": "dsp.launch:calibrate", "dsp-eval": "dsp.launch:evaluate",
        "dsp-info": "dsp.launch:info", "dsp-compare": "dsp.launch:compare"}


STUCK = """
import sys, threading, types
import dsp.launch as launch

class Stuck:
    '''A native writer that failed: whoever collects it waits for ever.'''
    def __del__(self):
        threading.Event().wait()

def main():
    launch.end_without_finalising(Stuck())
    print("prog: error: out.rrd: cannot write", file=sys.stderr)
    return 1

sys.modules["stuck_command"] = types.SimpleNamespace(main=main)
sys.exit(launch._launch("prog", "stuck_command"))
"""


def test_a_command_with_a_stuck_writer_still_ends() -> None:
    """Guards the end of a replay whose Rerun file writer failed (a file-size limit): its
    error printed, the command exits with its code instead of waiting for ever when the
    interpreter collects the writer."""
    proc = subprocess.run([sys.executable, "-c", STUCK], capture_output=True, text=True,
                          timeout=60, check=False)
    assert (proc.returncode, proc.stderr) == (1, "prog: error: out.rrd: cannot write\n")
