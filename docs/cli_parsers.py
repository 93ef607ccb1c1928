"""Each command's own ``build_parser()``, as the CLI reference pages show it.

sphinx-argparse reads a parser's help texts as reStructuredText, where ``*.mcap`` would open
an emphasis and ``name_`` a link; the texts are plain, so every character reStructuredText
gives a meaning to is escaped here, on a copy built for the page. Nothing else is changed:
the options, their groups, defaults and help are the command's own.
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


def _escaped(module: str) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = importlib.import_module(module).build_parser()
    parser.description = _escape(parser.description)
    parser.epilog = _escape(parser.epilog)
    for group in parser._action_groups:
        group.description = _escape(group.description)
    for action in parser._actions:
        if action.help not in (None, argparse.SUPPRESS):
            action.help = _escape(action.help)  # %(default)s is filled in by the extension
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
