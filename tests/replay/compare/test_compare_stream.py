"""dsp-compare reads a results file's frames and steps item by item (never the whole
document at once): the tables are those of the document as json.loads gives it, however
the file is laid out, and a problem is still one line naming the file."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from dsp.errors import InputError
from replay.compare.load import parse_results

ROOT = Path(__file__).resolve().parents[3]
GOLDEN = ROOT / "logs" / "golden" / "match.corrected-track.json"


def _tables(path: Path, text: str) -> tuple[object, ...]:
    run = parse_results(path, text)
    assert run is not None
    return run.log_file, run.sha256, run.options, run.parts, run.frames, run.steps


@pytest.mark.parametrize("layout", ["compact", "indented", "unsorted"])
def test_any_layout_gives_the_same_tables(tmp_path: Path, layout: str) -> None:
    doc = json.loads(GOLDEN.read_text())
    text = {"compact": json.dumps(doc, separators=(",", ":")),
            "indented": json.dumps(doc, indent=3, sort_keys=True),
            "unsorted": json.dumps(dict(reversed(list(doc.items()))))}[layout]
    tables = _tables(GOLDEN, text)
    assert tables == _tables(GOLDEN, GOLDEN.read_text())
    assert len(tables[4]) == len(doc["frames"])  # type: ignore[arg-type]


def test_json_of_another_format_is_not_a_results_file_even_with_odd_lists() -> None:
    text = json.dumps({"frames": [1, 2], "fused": "no", "format": "something else"})
    assert parse_results(Path("other.json"), text) is None


@pytest.mark.parametrize(("edit", "message"), [
    (lambda d: {**d, "frames": [*d["frames"], 5]}, "'frames' is not a list of objects"),
    (lambda d: {**d, "fused": {"a": 1}}, "'fused' is not a list of objects"),
    (lambda d: {k: v for k, v in d.items() if k != "frames"}, "'frames' is not a list"),
])
def test_a_bad_list_is_one_line(edit: object, message: str) -> None:
    doc = json.loads(GOLDEN.read_text())
    text = json.dumps(edit(doc))  # type: ignore[operator]
    with pytest.raises(InputError, match=message) as info:
        parse_results(Path("r.json"), text)
    assert str(info.value).startswith("r.json: ") and "\n" not in str(info.value)


@pytest.mark.parametrize("text", ['{"frames": [], "frames": []}', '{"format": 1,}', "{",
                                  '{"frames": [{"a": NaN}]}', '{"a": 1} 2'])
def test_what_is_not_json_is_one_line(text: str) -> None:
    with pytest.raises(InputError, match=r"^r\.json: not JSON \("):
        parse_results(Path("r.json"), text)
