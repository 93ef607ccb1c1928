"""The command-line toolkit every ``dsp-*`` command is built from.

One place for what the four commands share:

- :func:`add_common_arguments`: ``--version`` always; ``--camera`` (choices: the estimator's
  camera models), ``--renderer`` (choices :data:`RENDERERS`), ``--force`` and the progress
  flags ``--progress`` / ``--no-progress`` / ``-q, --quiet`` where asked for.
- One progress rule, :func:`progress_enabled`: an explicit ``--progress`` / ``--no-progress``
  wins; otherwise ``--quiet`` means no progress; otherwise a bar when stderr is a terminal
  and, when it is not (a pipe, a CI log), a plain line every few seconds.
  ``--quiet`` also silences the summary (:func:`echo`), never a ``warning:`` line on stderr
  (what says the results may be wrong). :func:`dsp.progress.progress_bar`
  makes either (library code uses it too; nothing outside a command imports this module).
- :func:`run_main`: the one ``main`` wrapper. Exit codes: 0 done; 1 bad input
  (:class:`~dsp.errors.InputError`, an ``OSError``); 2 usage (argparse's own and
  :class:`~dsp.errors.UsageError`); 3 refused overwrite (:class:`~dsp.errors.OutputExistsError`);
  130 interrupted (Ctrl-C, or SIGTERM, which ends a command the same way, children
  included). Any :class:`~dsp.errors.DspError` ends in one line
  ``prog: error: message`` on stderr, without a traceback; control characters in it (from
  names in a log) are escaped, as in everything :func:`echo` prints.

Importing this module imports neither pybullet nor mcap.
"""

from __future__ import annotations

import argparse
import contextlib
import difflib
import os
import signal
import sys
from collections.abc import Callable, Iterator, Sequence
from importlib import metadata
from types import FrameType
from typing import IO, NoReturn

from dsp.contract import RENDERERS
from dsp.errors import EXIT_INPUT, EXIT_INTERRUPTED, DspError, os_error_text
from dsp.text import printable

__all__ = [
    "DISTRIBUTION",
    "MAX_ERROR_CHARS",
    "RENDERERS",
    "Parser",
    "add_common_arguments",
    "echo",
    "progress_enabled",
    "run_main",
    "version",
]

DISTRIBUTION = "dual-sight"
"""The installed distribution whose version ``--version`` prints."""


class Parser(argparse.ArgumentParser):
    """Every command's option parser: a mistake is one line and a one-line hint, exit 2.

    argparse's own :meth:`~argparse.ArgumentParser.error` prints the whole usage block
    (18-21 lines for the larger commands) before the message; the message is what a user
    needs, and ``--help`` is one command away. Abbreviations are refused (``allow_abbrev``
    False), so an option added later cannot change what an old command line means; a
    misspelt option gets the closest of the parser's own (``did you mean --pose-sigma?``),
    as Python 3.14's ``suggest_on_error`` does."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]

    def error(self, message: str) -> NoReturn:  # argparse's hook for every parse error
        self.exit(2, printable(f"{self.prog}: error: {message}{self._suggestion(message)}") +
                  f"\nTry '{self.prog} --help' for the options.\n")

    def _suggestion(self, message: str) -> str:
        """`` (did you mean --pose-sigma?)`` for an unrecognised option close to one of the
        parser's long options (difflib's ratio, its default cutoff 0.6), else ``""``."""
        head = "unrecognized arguments: "
        if not message.startswith(head):
            return ""
        known = sorted(s for s in self._option_string_actions if s.startswith("--"))
        guesses: list[str] = []
        for token in message[len(head):].split():
            name = token.split("=", 1)[0]
            if name.startswith("-") and name not in known:
                close = difflib.get_close_matches(name, known, n=1)
                guesses += [g for g in close if g not in guesses]
        return f" (did you mean {' or '.join(guesses)}?)" if guesses else ""


def version() -> str:
    """The installed version of the project ("unknown" when it is not installed)."""
    try:
        return metadata.version(DISTRIBUTION)
    except metadata.PackageNotFoundError:
        return "unknown"


def add_common_arguments(
    parser: argparse.ArgumentParser,
    *,
    camera: str | None = None,
    renderer: bool = False,
    force: bool = False,
    progress: bool = True,
) -> None:
    """Add the shared options to ``parser``: ``--version`` always, and

    - ``--camera`` when ``camera`` names its default model,
    - ``--renderer`` when ``renderer``,
    - ``--force`` (overwrite existing outputs) when ``force``,
    - ``--progress`` / ``--no-progress`` and ``-q, --quiet`` when ``progress``.
    """
    parser.add_argument("--version", action="version", version=f"%(prog)s {version()}")
    if camera is not None:
        from estimator.camera import CAMERA_MODELS

        if camera not in CAMERA_MODELS:
            raise ValueError(f"default camera {camera!r} is not one of {CAMERA_MODELS}")
        parser.add_argument("--camera", choices=CAMERA_MODELS, default=camera,
                            help="omni camera model (default %(default)s)")
    if renderer:
        parser.add_argument("--renderer", choices=RENDERERS, default="auto",
                            help="pybullet renderer (default: EGL if it loads, else "
                            "TinyRenderer; env DSP_RENDERER overrides auto)")
    if force:
        parser.add_argument("--force", action="store_true", help="overwrite existing outputs")
    if progress:
        bar = parser.add_mutually_exclusive_group()
        bar.add_argument("--progress", dest="progress", action="store_true", default=None,
                         help="always show a progress bar on stderr")
        bar.add_argument("--no-progress", dest="progress", action="store_false",
                         help="never show a progress bar (default: when stderr is a terminal "
                         "and not --quiet)")
        parser.add_argument("-q", "--quiet", action="store_true",
                            help="print no summary (warnings still are)")


def progress_enabled(args: argparse.Namespace, stream: IO[str] | None = None) -> bool | None:
    """The one rule: ``--progress`` / ``--no-progress`` if given; else none with ``--quiet``;
    else a bar when ``stream`` (default stderr) is a terminal, and when it is not (a pipe, a
    log file) None: plain progress lines every :data:`LINE_INTERVAL_S` seconds."""
    explicit: bool | None = getattr(args, "progress", None)
    if explicit is not None:
        return explicit
    if getattr(args, "quiet", False):
        return False
    stream = sys.stderr if stream is None else stream
    isatty = getattr(stream, "isatty", None)
    return True if isatty is not None and isatty() else None


def echo(args: argparse.Namespace, text: str) -> None:
    """Print ``text`` (a summary, a "wrote ..." line) on stdout unless ``--quiet``; control
    characters (from names in a log) are escaped (:func:`dsp.text.printable`)."""
    if not getattr(args, "quiet", False):
        print(printable(text, lines=True))


MAX_ERROR_CHARS = 1000
"""The longest error line a command prints; the rest is cut to ``...`` (a log naming 10,000
robots, an option thousands of characters long)."""


def _fail(prog: str, message: str) -> None:
    # one line, whatever a name from a log holds (newlines, escape sequences), and not a page
    print(printable(f"{prog}: {message}", limit=MAX_ERROR_CHARS), file=sys.stderr)


@contextlib.contextmanager
def _terminate_as_interrupt() -> Iterator[None]:
    """SIGTERM ends a command as Ctrl-C does (outputs discarded, children such as the Rerun
    server stopped, exit 130) instead of killing it where it stands."""
    def terminate(_signum: int, _frame: FrameType | None) -> None:
        raise KeyboardInterrupt

    try:
        previous = signal.signal(signal.SIGTERM, terminate)
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _escape_unencodable() -> None:
    """Print what the terminal's encoding cannot hold as escapes: a file name that is not
    UTF-8 (a lone surrogate in Python) would otherwise end a ``print`` in a traceback under
    a strict UTF-8 locale (``en_US.UTF-8``)."""
    for stream in (sys.stdout, sys.stderr):
        if getattr(stream, "errors", None) == "strict":
            with contextlib.suppress(AttributeError, ValueError, OSError):
                stream.reconfigure(errors="backslashreplace")  # type: ignore[union-attr]


def run_main(prog: str, fn: Callable[[Sequence[str] | None], int | None],
             argv: Sequence[str] | None = None) -> int:
    """Run a command's ``fn(argv)`` and turn how it ended into an exit code (see the module
    docstring); never lets a known error or Ctrl-C end in a traceback."""
    _escape_unencodable()
    try:
        with _terminate_as_interrupt():
            code = fn(argv)
    except SystemExit as exc:  # argparse: --help / --version (0), bad arguments (2)
        if exc.code is None or isinstance(exc.code, int):
            return exc.code or 0
        _fail(prog, f"error: {exc.code}")
        return EXIT_INPUT
    except DspError as err:
        if err.exit_code == EXIT_INTERRUPTED:
            _fail(prog, str(err))
        else:
            _fail(prog, f"error: {err}")
        return err.exit_code
    except KeyboardInterrupt:
        _fail(prog, "interrupted")
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # `dsp-info LOG | head`: the reader has what it wanted
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # so the flush at exit does not fail again
        return EXIT_INPUT
    except OSError as err:
        _fail(prog, f"error: {os_error_text(err)}")
        return EXIT_INPUT
    return 0 if code is None else code
