"""Bounded JSON in (dsp.jsonio.loads): deep nesting and overlong numbers are refused in one
line naming the file, by every reader of JSON a user or a log supplies."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from dsp import jsonio, metadata
from dsp.ball_file import read_ball_file
from dsp.camera_file import read_camera_file
from dsp.errors import InputError
from dsp.jsonio import MAX_DEPTH, MAX_INT_DIGITS, JsonLimitError
from replay.cameras import read_calibration
from replay.compare.cli import main as compare_main

DEEP = "[" * 100_000 + "]" * 100_000
LONG_INT = '{"a": ' + "9" * 100_000 + "}"


def test_within_the_limits_it_is_json_loads() -> None:
    text = json.dumps({"a": "[[[{{ \\\" \\\\", "b": [1, -2.5e-3, {"c": [None, True]}],
                       "n": "9" * 500, "d": 10**30})
    assert jsonio.loads(text) == json.loads(text)
    nested = "[" * MAX_DEPTH + "]" * MAX_DEPTH
    assert jsonio.loads(nested) == json.loads(nested)
    assert jsonio.loads("9" * MAX_INT_DIGITS) == int("9" * MAX_INT_DIGITS)


@pytest.mark.parametrize(("text", "message"), [
    (DEEP, "nested 100000 levels deep"),
    ("[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1), f"nested {MAX_DEPTH + 1} levels deep"),
    ('{"a": ' * (MAX_DEPTH + 1) + "1" + "}" * (MAX_DEPTH + 1), "levels deep"),
    (LONG_INT, f"a number of more than {MAX_INT_DIGITS} digits"),
    ("[-" + "1" * (MAX_INT_DIGITS + 1) + "]", "digits"),
    ('["\\\\", ' + "[" * 80 + "]" * 80 + "]", "levels deep"),  # an escaped backslash ends no string
])
def test_beyond_the_limits_is_refused(text: str, message: str) -> None:
    with pytest.raises(JsonLimitError, match=message):
        jsonio.loads(text)


def test_brackets_and_digits_inside_strings_do_not_count() -> None:
    text = json.dumps({"s": "[" * 1000 + "9" * 1000, "t": '\\"[[[['})
    assert jsonio.loads(text)["s"].startswith("[[[")


@pytest.mark.parametrize("text", [DEEP, LONG_INT])
def test_a_ball_model_a_calibration_and_a_camera_file_say_so_in_one_line(
        tmp_path: Path, text: str) -> None:
    for name, read in (("ball.json", read_ball_file), ("cal.json", read_calibration),
                       ("cameras.json", read_camera_file)):
        path = tmp_path / name
        path.write_text(text)
        with pytest.raises(InputError) as info:
            read(path)
        line = str(info.value)
        assert line.startswith(str(path)) and "\n" not in line and len(line) < 300, line


def test_log_metadata_says_so_in_one_line() -> None:
    with pytest.raises(metadata.MetadataError, match=r"params is not JSON .*levels deep"):
        metadata.ScenarioMetadata.from_metadata({"name": "x", "seed": "0",
                                                  "params": '{"a": ' + DEEP + "}"})
    with pytest.raises(metadata.MetadataError, match="digits"):
        metadata.CamerasMetadata.from_metadata({"robot1": LONG_INT})


@pytest.mark.parametrize("text", [DEEP, LONG_INT])
def test_dsp_compare_says_so_in_one_line(tmp_path: Path, text: str,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(text)
    b.write_text(text)
    assert compare_main([str(a), str(b)]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"dsp-compare: error: {a}") and err.count("\n") == 1, err


def _reference(text: str) -> tuple[int, int]:
    """The deepest nesting and the longest digit run outside strings, char by char."""
    depth = deepest = digits = longest = 0
    in_string = escaped = False
    for ch in text:
        if in_string:
            if escaped:
                escaped = False
            elif ch == "\\":
                escaped = True
            elif ch == '"':
                in_string = False
            continue
        digits = digits + 1 if ch.isdigit() else 0
        longest = max(longest, digits)
        if ch == '"':
            in_string = True
        elif ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif ch in "]}":
            depth -= 1
    return deepest, longest


@pytest.mark.parametrize("chunk", [1, 2, 3, 7, 64])
def test_the_checks_piece_by_piece_see_what_a_whole_pass_sees(
        chunk: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """Guards the pieces' boundaries: an escape, a string or a number cut across two
    pieces is seen as a whole pass sees it, on seeded random documents."""
    import random

    monkeypatch.setattr(jsonio, "CHUNK_CHARS", chunk)
    rng = random.Random(chunk)

    def value(level: int) -> object:
        kind = rng.randrange(6 if level < 70 else 3)
        if kind == 0:
            return rng.randrange(10 ** rng.randrange(1, 130))
        if kind == 1:
            return "".join(rng.choice('ab[]{}"\\\\0123456789') for _ in range(rng.randrange(9)))
        if kind == 2:
            return rng.random()
        if kind in (3, 4):
            return [value(level + 1) for _ in range(rng.randrange(1, 3))]
        return {str(i): value(level + 1) for i in range(rng.randrange(1, 3))}

    outcomes = set()
    for _ in range(60):
        doc = value(0)
        for _ in range(rng.choice((0, 0, 60, 66))):  # some deep, near the limit either way
            doc = [doc] if rng.random() < 0.5 else {"k": doc}
        text = json.dumps(doc)
        deepest, longest = _reference(text)
        refused = deepest > MAX_DEPTH or longest > MAX_INT_DIGITS
        outcomes.add(refused)
        if refused:
            with pytest.raises(JsonLimitError):
                jsonio.check_limits(text)
        else:
            jsonio.check_limits(text)
            assert jsonio.loads(text) == json.loads(text)
    assert outcomes == {True, False}
