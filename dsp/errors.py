"""The project's one error tree: every error raised on purpose carries its exit code.

The commands' main wrapper (:func:`dsp.cli.run_main`) prints any :class:`DspError` as one
line ``prog: error: message`` and exits with its :attr:`~DspError.exit_code`. Packages add
subclasses only where a name adds meaning (``replay.errors.NotMcapError``, ...). The
estimator keeps its own small base (``estimator.errors.EstimatorError``) so it stays pure.

Exit codes: 1 bad input, 2 usage (bad option values or combinations, as argparse's own),
3 refused overwrite, 130 interrupted (Ctrl-C).
"""

from __future__ import annotations

from pathlib import Path

__all__ = [
    "EXIT_INPUT",
    "EXIT_INTERRUPTED",
    "EXIT_OUTPUT_EXISTS",
    "EXIT_USAGE",
    "CalibrationError",
    "DspError",
    "InputError",
    "OutputError",
    "OutputExistsError",
    "UsageError",
    "os_error_text",
]

EXIT_INPUT = 1
EXIT_USAGE = 2
EXIT_OUTPUT_EXISTS = 3
EXIT_INTERRUPTED = 130


class DspError(Exception):
    """Base class: a known, explainable failure; the message names the value and the fix."""

    exit_code = EXIT_INPUT


class UsageError(DspError):
    """An option value is out of range or inconsistent with another option or the input."""

    exit_code = EXIT_USAGE


class InputError(DspError):
    """An input file is missing or cannot be used."""

    exit_code = EXIT_INPUT


class CalibrationError(InputError):
    """A calibration file or a log's camera metadata cannot be used."""

    def __init__(self, source: Path | str, detail: str) -> None:
        super().__init__(f"{source}: unusable calibration: {detail}")


class OutputError(DspError):
    """An output cannot be written (full disk, read-only or missing folder, ...); the message
    names the output, never a temporary file."""

    exit_code = EXIT_INPUT

    def __init__(self, path: Path | str, detail: BaseException | str) -> None:
        if isinstance(detail, OSError):
            detail = detail.strerror or str(detail)
        super().__init__(f"{path}: cannot write: {detail}")
        self.path = Path(path)


class OutputExistsError(DspError):
    """An output file exists already and ``--force`` was not given."""

    exit_code = EXIT_OUTPUT_EXISTS

    def __init__(self, path: Path | str) -> None:
        super().__init__(f"{path}: output exists already (use --force to overwrite)")
        self.path = Path(path)


def os_error_text(err: OSError) -> str:
    """An OS error in the project's form, ``path: what went wrong``, not Python's
    ``[Errno 30] Read-only file system: 'path'``."""
    what = err.strerror or str(err)
    if err.filename is None:
        return what
    if err.filename2 is not None:
        return f"{err.filename} -> {err.filename2}: {what}"
    return f"{err.filename}: {what}"
