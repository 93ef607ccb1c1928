"""Every numeric option of every command, walked from the parsers, refuses what no range
allows (NaN, infinities, 1e308, a 40-digit whole number either way) before any work: one
line naming the option, exit 2, nothing written. A new numeric option without a range fails
here (it would run the work with the number instead)."""

from __future__ import annotations

import importlib
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.dsp.test_vocabulary import COMMANDS, _parser

BASE = {
    "dsp-record": ["s.mcap", "--scenario", "match", "--frames", "1"],
    "dsp-replay": ["missing.mcap"],
    "dsp-calibrate": ["-o", "c.json"],
    "dsp-eval": ["--suite", "match", "--out-dir", "ev", "--count", "1", "--duration", "0.05",
                 "--workers", "1"],
    "dsp-info": ["missing.mcap"],
    "dsp-compare": ["a.json", "b.json"],
}
IMAGES = ["--suite", "images", "imgs", "--out-dir", "ev"]
"""dsp-eval's options of the image suite are checked there."""
IMAGE_OPTIONS = {"--train-count", "--train-from", "--ball-class", "--threshold"}

FLOATS = ("nan", "inf", "-inf", "1e308", "-1e308")
INTS = ("9" * 40, "-" + "9" * 40)


def _numeric() -> Iterator[tuple[str, str, str]]:
    for prog in COMMANDS:
        for action in _parser(prog)._actions:
            if not action.option_strings or action.type in (None, Path, str):
                continue
            flag = action.option_strings[-1]
            values = INTS if action.type is int else FLOATS
            for value in values:
                yield prog, flag, value


CASES = list(_numeric())


def test_the_walk_finds_the_numeric_options() -> None:
    """The walk is not empty: each command with numbers has its options in it."""
    flags = {(p, f) for p, f, _ in CASES}
    assert len(flags) >= 45
    assert {("dsp-record", "--rate"), ("dsp-replay", "--window"), ("dsp-eval", "--count"),
            ("dsp-compare", "--replicates"), ("dsp-eval", "--ball-class")} <= flags


@pytest.mark.parametrize(("prog", "flag", "value"), CASES,
                         ids=[f"{p}:{f}={v[:6]}" for p, f, v in CASES])
def test_a_number_out_of_every_range_is_refused_before_any_work(
        prog: str, flag: str, value: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    base = BASE[prog]
    if prog == "dsp-eval" and flag in IMAGE_OPTIONS:
        (tmp_path / "imgs").mkdir()
        base = IMAGES
    main = importlib.import_module(COMMANDS[prog]).main
    code = main([*base, f"{flag}={value}"])
    out, err = capsys.readouterr()
    assert code == 2, err
    assert err.startswith(f"{prog}: error: ") and flag in err.splitlines()[0], err
    assert err.count("\n") <= 2 and "Traceback" not in err and out == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == (["imgs"] if base is IMAGES else [])
