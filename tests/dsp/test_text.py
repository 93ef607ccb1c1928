"""dsp.text.printable: names from a log cannot drive the terminal."""

from __future__ import annotations

import argparse

import pytest

from dsp.cli import echo, run_main
from dsp.errors import InputError
from dsp.text import printable


@pytest.mark.parametrize(("raw", "shown"), [
    ("/robot1/pose", "/robot1/pose"),
    ("r\x1b]0;x\x07\x1b[2J", "r\\x1b]0;x\\x07\\x1b[2J"),  # OSC retitle + CSI clear screen
    ("a\x9b2J", "a\\x9b2J"),  # the one-byte C1 CSI
    ("evil\u202etxt.mcap", "evil\\u202etxt.mcap"),  # right-to-left override
    ("zero\u200bwidth", "zero\\u200bwidth"),
    ("two\nlines\r", "two\\x0alines\\x0d"),
    ("tab\tkept, été, 日本", "tab\tkept, été, 日本"),
])
def test_control_and_format_characters_are_escaped(raw: str, shown: str) -> None:
    assert printable(raw) == shown


def test_newlines_kept_only_when_asked() -> None:
    assert printable("a\nb\x1b", lines=True) == "a\nb\\x1b"


def test_errors_and_summaries_are_escaped(capsys: pytest.CaptureFixture[str]) -> None:
    def fail(argv: object) -> int:
        raise InputError("topic /r\x1b[2J\nsecond line")

    assert run_main("dsp-x", fail, []) == 1
    err = capsys.readouterr().err
    assert err == "dsp-x: error: topic /r\\x1b[2J\\x0asecond line\n"
    echo(argparse.Namespace(quiet=False), "row r\x1b[2J\nrow 2")
    assert capsys.readouterr().out == "row r\\x1b[2J\nrow 2\n"


def test_sizes_are_binary_units_everywhere() -> None:
    from dsp.text import format_bytes

    assert [format_bytes(n) for n in (0, 1023, 1024, 69_630_000, 3 << 30)] == [
        "0 B", "1023 B", "1.0 KiB", "66.4 MiB", "3.0 GiB"]
