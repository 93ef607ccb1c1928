"""dsp-replay's outputs: never on the input, never two on one file, a folder or a full disk
is one line, results are strict JSON, and names from the log cannot drive the terminal."""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from synthetic import write_log

from replay.cli import format_summary
from replay.cli import main as replay_main
from replay.sinks import ResultsWriter

ESCAPES = "\x1b]0;x\x07\x1b[2J"
"""Retitles the terminal (OSC 0) and clears the screen (CSI 2J) when printed raw."""


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = replay_main([*(str(a) for a in argv), "--no-progress"])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_log(tmp_path_factory.mktemp("log") / "in.mcap", duration_s=0.3).path


def one_line(err: str) -> None:
    assert err.count("\n") == 1 and "Traceback" not in err, err


def test_the_input_log_is_never_an_output(log: Path, tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    before = log.read_bytes()
    code, out, err = run([log, "--out-mcap", log, "--force"], capsys)
    assert code == 2 and out == ""
    assert err == (f"dsp-replay: error: --out-mcap {log} is the input log; an output never "
                   "overwrites an input, choose another file\n")
    hard = tmp_path / "hard.mcap"  # the same file under another name
    os.link(log, hard)
    code, _, err = run([log, "--out-mcap", hard, "--force"], capsys)
    assert code == 2 and "is the input log" in err
    sym = tmp_path / "sym.mcap"
    sym.symlink_to(log)
    code, _, err = run([sym, "--out-mcap", log, "--force"], capsys)
    assert code == 2 and "is the input log" in err
    assert log.read_bytes() == before


def test_two_outputs_never_share_a_file(log: Path, tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    results = tmp_path / "r.json"
    code, _, err = run([log, "--out", results, "--save", results], capsys)
    assert code == 2 and "--save" in err and "must end in .rrd" in err
    one_line(err)
    rrd = tmp_path / "r.rrd"
    rrd.symlink_to(results)  # r.rrd -> r.json: one file under two names
    code, _, err = run([log, "--out", results, "--save", rrd], capsys)
    assert code == 2
    assert err == f"dsp-replay: error: --out and --save both name {rrd}; give each output " \
                  "its own file\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.rrd"]


def test_an_output_that_is_a_folder_is_one_line_and_leaves_nothing(
        log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "r.json"
    folder.mkdir()
    for force in ([], ["--force"]):
        code, out, err = run([log, "--out", folder, *force], capsys)
        assert code == 2 and out == ""
        assert err == f"dsp-replay: error: --out {folder}: is a folder; give a file name\n"
    code, _, err = run([log, "--out", tmp_path / "missing" / "r.json"], capsys)
    assert code == 2 and "does not exist; create it first" in err
    one_line(err)
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"] and not any(folder.iterdir())


def test_a_full_disk_is_one_line_naming_the_results_file(
        log: Path, tmp_path: Path, full_disk: Callable[[int], None],
        capsys: pytest.CaptureFixture[str]) -> None:
    full_disk(100)
    out = tmp_path / "r.json"
    code, stdout, err = run([log, "--out", out], capsys)
    assert code == 1 and stdout == ""
    assert err == f"dsp-replay: error: {out}: cannot write: No space left on device\n"
    assert list(tmp_path.iterdir()) == []  # neither the output nor a temporary file


def _strict(text: str) -> Any:
    def refuse(name: str) -> None:
        raise ValueError(f"not JSON: {name}")

    return json.loads(text, parse_constant=refuse)


def test_results_are_strict_json_even_with_non_finite_numbers(tmp_path: Path) -> None:
    from replay.sinks import ResultsHeader
    from replay.stats import ReplayStats

    stats = ReplayStats(("robot1",))
    header = ResultsHeader(file="x.mcap", sha256="0" * 64, robots=("robot1",),
                           options={"window_s": math.inf, "start_s": math.nan})
    out = tmp_path / "r.json"
    writer = ResultsWriter(out, header=header, stats=stats)
    writer.close(ok=True)
    doc = _strict(out.read_text())
    assert doc["options"] == {"window_s": None, "start_s": None}


def test_strict_json_helper() -> None:
    from dsp.jsonio import dumps, finite

    assert _strict(dumps({"a": [math.nan, 1.5, (math.inf, -math.inf)]})) == \
        {"a": [None, 1.5, [None, None]]}
    assert finite({"k": "nan"}) == {"k": "nan"}


def test_the_summary_never_prints_inf(log: Path, tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    from replay.runner import replay

    summary = replay(log)
    robot = next(iter(summary.per_robot))
    bad = summary.per_robot[robot].__class__(**{
        **summary.per_robot[robot].__dict__, "rmse_m": math.inf, "max_error_m": math.nan})
    text = format_summary(summary.__class__(**{
        **summary.__dict__, "per_robot": {**summary.per_robot, robot: bad}, "wall_s": 0.0}))
    assert "inf" not in text and "nan" not in text
    assert f"{robot:10}" in text


def test_names_from_the_log_are_escaped_in_summaries_and_errors(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    robot = f"r{ESCAPES}"
    good = write_log(tmp_path / "esc.mcap", duration_s=0.3,
                     robots={robot: (-3.0, 0.0, 0.0), "robot2": (-1.0, 2.0, -math.pi / 2)})
    code, out, err = run([good.path], capsys)
    assert code == 0 and err == ""
    assert "\x1b" not in out and "\x07" not in out
    assert "r\\x1b]0;x\\x07\\x1b[2J" in out  # visible, and the table keeps its rows
    bad = write_log(tmp_path / "esc-noposes.mcap", duration_s=0.3, with_poses=False,
                    robots={robot: (-3.0, 0.0, 0.0)})
    code, out, err = run([bad.path], capsys)
    assert code == 1 and out == ""
    assert "\x1b" not in err and "\x07" not in err and "r\\x1b]0;x\\x07\\x1b[2J" in err
    one_line(err)


def test_a_batch_never_writes_over_one_of_its_logs(log: Path, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    victim = out_dir / "in.estimates.mcap"  # where the batch puts in.mcap's estimates
    victim.write_bytes(log.read_bytes())
    before = victim.read_bytes()
    code, _, err = run([log, victim, "--out-dir", out_dir, "--estimates", "--force"], capsys)
    assert code == 2, err
    assert err == (f"dsp-replay: error: the output in.estimates.mcap {victim} is the input log "
                   f"{victim}; an output never overwrites an input, choose another file\n")
    assert victim.read_bytes() == before and [p.name for p in out_dir.iterdir()] == [victim.name]


def test_batch_errors_escape_names_from_the_log(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    bad = write_log(tmp_path / "esc.mcap", duration_s=0.3, with_poses=False,
                    robots={f"r{ESCAPES}": (-3.0, 0.0, 0.0)})
    code, _, err = run([bad.path, "--out-dir", tmp_path / "out", "--workers", "1"], capsys)
    assert code == 1
    assert "r\\x1b]0;x\\x07\\x1b[2J" in err and "\x1b" not in err and "\x07" not in err


def test_every_written_output_is_named_once_rrd_included(
        log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rrd, out = tmp_path / "run.rrd", tmp_path / "run.json"
    code, stdout, _ = run([log, "--save", rrd, "--out", out], capsys)
    assert code == 0 and rrd.is_file() and out.is_file()
    wrote = [line for line in stdout.splitlines() if line.startswith("wrote ")]
    assert wrote == [f"wrote {out}", f"wrote {rrd}"]
