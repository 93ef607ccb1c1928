"""The scripts a user runs by hand meet bad input as the commands do: one line naming the
file and the problem, exit 1, no traceback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _run(script: str, *args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(ROOT / "scripts" / script), *args], cwd=cwd,
                          capture_output=True, text=True, timeout=120, check=False)


@pytest.mark.parametrize("what", ["missing", "folder", "not-mcap"])
@pytest.mark.parametrize("command", ["convert", "measure"])
def test_team_example_names_a_source_it_cannot_use(tmp_path: Path, what: str,
                                                   command: str) -> None:
    source = {"missing": tmp_path / "nope.mcap", "folder": tmp_path,
              "not-mcap": tmp_path / "notes.txt"}[what]
    if what == "not-mcap":
        source.write_text("not a log\n")
    out = tmp_path / "out.mcap"
    run = _run("team_example.py", command, str(source), str(out), cwd=tmp_path)
    lines = run.stderr.strip().splitlines()
    assert run.returncode == 1, run.stderr
    assert len(lines) == 1 and lines[0].startswith("team_example.py: error: "), run.stderr
    assert str(source) in lines[0] and "Traceback" not in run.stderr
    assert not out.exists()


@pytest.mark.parametrize(("content", "problem"), [
    (None, "cannot read"), ("", "not JSON"), ("[1, 2]", "not a report"),
    ('{"findings": []}', "not a report"), ("{", "not JSON")])
def test_fuzz_merge_names_a_report_it_cannot_use(tmp_path: Path, content: str | None,
                                                 problem: str) -> None:
    report = tmp_path / "r.json"
    if content is not None:
        report.write_text(content)
    run = _run("fuzz_replay.py", "--merge", str(report), cwd=tmp_path)
    lines = run.stderr.strip().splitlines()
    assert run.returncode == 1, run.stderr
    assert len(lines) == 1 and lines[0].startswith(f"fuzz_replay.py: error: {report}: ")
    assert problem in lines[0] and "Traceback" not in run.stderr


def test_held_out_events_names_a_missing_check(tmp_path: Path) -> None:
    """A grouping whose event has no held-out check in --checks: one line naming the file."""
    (tmp_path / "g.txt").write_text("e r7\n")
    images = ROOT / "tests" / "data" / "msl-images" / "20220715"
    run = _run("held_out_events.py", str(images), "--groups", str(tmp_path / "g.txt"),
               "--checks", str(tmp_path), cwd=tmp_path)
    lines = run.stderr.strip().splitlines()
    assert run.returncode == 1 and len(lines) == 1, run.stderr
    assert lines[0].startswith("held_out_events.py: error: ") and "lovo-e.onnx" in lines[0]
