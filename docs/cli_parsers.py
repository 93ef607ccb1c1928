"""Each command's own ``build_parser()``, as the CLI reference pages show it.

sphinx-argparse reads a parser's help texts as reStructuredText, where ``*.mcap`` would open
an emphasis and ``name_`` a link; the texts are plain, so every character reStructuredText
gives a meaning to is escaped here, on a copy built for the page. The defaults are shown as
a user types them: ``0.05,1.0``, not the tuple ``(0.05, 1.0)``; ``paper``, not ``'paper'``;
none for a flag (``--no-progress``, whose stored True is no value to give). Nothing else is
changed: the options, their groups and help are the command's own.
"""

from __future__ import annotations

import argparse
import importlib
import re

__all__ = ["COMMANDS", "calibrate", "compare", "evaluate", "info", "record", "replay"]

COMMANDS = {
    "dsp-record": "recorder.cli",
    "dsp-replay": "replay.cli",
    "dsp-calibrate": "replay.calibrate.cli",
    "dsp-eval": "replay.evaluate.cli",
    "dsp-info": "replay.info.cli",
    "dsp-compare": "replay.compare.cli",
}
"""Each command and the module whose ``build_parser()`` it runs (``[project.scripts]``
names ``dsp.launch``, which imports these)."""

_SPECIAL = re.compile(r"([\\*`|_\[\]])")


def _escape(text: str | None) -> str | None:
    return None if text is None else _SPECIAL.sub(r"\\\1", text)


class _Typed:
    """A default as the text a user would type for it (sphinx-argparse prints ``str()``)."""

    def __init__(self, text: str) -> None:
        self.text = text

    def __str__(self) -> str:
        return self.text


def _typed(action: argparse.Action) -> object:
    """What the page shows as ``action``'s default (``argparse.SUPPRESS``: none)."""
    default = action.default
    if default is None or default is argparse.SUPPRESS:
        return default
    if action.nargs == 0 or isinstance(default, bool):  # a flag: present or not
        return argparse.SUPPRESS
    if isinstance(default, (tuple, list)):
        return _Typed(",".join(str(v) for v in default)) if default else argparse.SUPPRESS
    return _Typed(str(default))


def _escaped(module: str) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = importlib.import_module(module).build_parser()
    parser.description = _escape(parser.description)
    parser.epilog = _escape(parser.epilog)
    for group in parser._action_groups:
        group.description = _escape(group.description)
    for action in parser._actions:
        if action.help not in (None, argparse.SUPPRESS):
            action.help = _escape(action.help)  # %(default)s is filled in by the extension
        action.default = _typed(action)
    return parser


def record() -> argparse.ArgumentParser:
    return _escaped(COMMANDS["dsp-record"])


def replay() -> argparse.ArgumentParser:
    return _escaped(COMMANDS["dsp-replay"])


def calibrate() -> argparse.ArgumentParser:
    return _escaped(COMMANDS["dsp-calibrate"])


def evaluate() -> argparse.ArgumentParser:
    return _escaped(COMMANDS["dsp-eval"])


def info() -> argparse.ArgumentParser:
    return _escaped(COMMANDS["dsp-info"])


def compare() -> argparse.ArgumentParser:
    return _escaped(COMMANDS["dsp-compare"])
