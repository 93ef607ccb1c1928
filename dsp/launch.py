"""The commands' entry points (``[project.scripts]``): Ctrl-C is one line from the first instant.

A command's own module imports numpy, OpenCV, mcap, Rerun and more before its ``main``
runs (half a second, longer on a busy machine); a Ctrl-C meanwhile would end in a
``KeyboardInterrupt`` traceback from whichever import it hit. Each entry point here first
installs a SIGINT handler that prints ``prog: interrupted`` and exits 130 at once (nothing has
been written yet), then imports the command, restores Python's own handler and calls the
command's ``main``, whose :func:`dsp.cli.run_main` turns a later Ctrl-C into the same line
after cleaning up. Rerun's native log is off unless ``RUST_LOG`` is set. This module
imports nothing but a few modules of the standard library, so the window before the handler
is the interpreter's own start-up. A command whose native writer is stuck ends at once once
its main returns (:func:`end_without_finalising`).
"""

from __future__ import annotations

import contextlib
import importlib
import os
import signal
import sys
from types import FrameType

__all__ = [
    "calibrate",
    "compare",
    "end_without_finalising",
    "evaluate",
    "info",
    "record",
    "replay",
]

EXIT_INTERRUPTED = 130
"""As :data:`dsp.errors.EXIT_INTERRUPTED` (not imported: that would import the package's
errors before the handler is in place, for no gain)."""


_stuck: list[object] = []
"""What :func:`end_without_finalising` was given: kept, so it is never collected."""


def end_without_finalising(stuck: object) -> None:
    """A native writer that failed (Rerun's, under a file-size limit) blocks whoever
    collects or shuts it down, without a time limit. Keep ``stuck`` referenced, and end the
    command, once its main has returned (its error printed, its outputs settled), with
    :func:`os._exit`, which skips the interpreter's finalisation, instead of never ending."""
    _stuck.append(stuck)


def _launch(prog: str, module: str) -> int:
    def interrupted(_signum: int, _frame: FrameType | None) -> None:
        os.write(2, f"{prog}: interrupted\n".encode())
        os._exit(EXIT_INTERRUPTED)

    previous = signal.signal(signal.SIGINT, interrupted)
    # the commands say each problem in one line of their own: Rerun's native log lines
    # (timestamped, coloured) only repeat it, unless the user asks for them
    os.environ.setdefault("RUST_LOG", "off")
    try:
        command = importlib.import_module(module)
    finally:
        signal.signal(signal.SIGINT, previous)
    code: int = command.main()
    if _stuck:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        os._exit(code)
    return code


def record() -> int:
    """``dsp-record``."""
    return _launch("dsp-record", "recorder.cli")


def replay() -> int:
    """``dsp-replay``."""
    return _launch("dsp-replay", "replay.cli")


def calibrate() -> int:
    """``dsp-calibrate``."""
    return _launch("dsp-calibrate", "replay.calibrate.cli")


def evaluate() -> int:
    """``dsp-eval``."""
    return _launch("dsp-eval", "replay.evaluate.cli")


def info() -> int:
    """``dsp-info``."""
    return _launch("dsp-info", "replay.info.cli")


def compare() -> int:
    """``dsp-compare``."""
    return _launch("dsp-compare", "replay.compare.cli")
