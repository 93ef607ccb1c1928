"""dsp-info: a log at a glance, --json for scripts, --check for integrity."""

from __future__ import annotations

import json
import random
import re
import struct
from pathlib import Path

import pytest
from fuzzing import GOLDEN, m_summary, records, seed_log
from mcap.writer import CompressionType

from dsp.text import format_bytes
from replay.info.cli import main


def test_golden_log_at_a_glance(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([str(GOLDEN / "rolling.mcap")]) == 0
    out = capsys.readouterr().out
    for needle in ("duration:    1.750 s", "robots:      robot1, robot2, robot3",
                   "scenario:    name rolling, seed 0", "robot2 ideal", "renderer:    egl",
                   "/robot1/omni/image/compressed",
                   "sensor_msgs/msg/CompressedImage", "messages:    76",
                   "default pipeline:\n  line fit: yes (field 18x12, camera models of 3 "
                   "robots)\n  3-D track: yes (3 robots)\n  pose covariance: not in the log"):
        assert needle in out, needle
    assert re.search(r"chunks: +\d+ \(zstd \d+;", out)



@pytest.mark.parametrize("compression", [CompressionType.ZSTD, CompressionType.NONE])
def test_chunk_sizes_say_which_is_which(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                        compression: CompressionType) -> None:
    log = tmp_path / "log.mcap"
    log.write_bytes(seed_log("scenario2", compression=compression, chunk_size=32 * 1024))
    assert main([str(log), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert main([str(log)]) == 0
    out = capsys.readouterr().out
    uncompressed = f"{format_bytes(doc['uncompressed_bytes'])} uncompressed), summary:"
    if compression == CompressionType.ZSTD:
        assert doc["chunk_bytes"] < doc["uncompressed_bytes"]
        assert f"; {format_bytes(doc['chunk_bytes'])} compressed, {uncompressed}" in out
    else:
        assert f" (none {doc['chunks']}; {uncompressed}" in out
    assert "->" not in out



def test_a_file_name_s_escape_sequence_never_reaches_the_terminal(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A name holding ESC ] 0 ; ... BEL would retitle the terminal: every line dsp-info
    prints a path in (file:, the template's header, wrote ...) shows it escaped."""
    hostile = "\x1b]0;owned\x07"
    shown = "\\x1b]0;owned\\x07"
    log = tmp_path / f"run{hostile}.mcap"
    log.write_bytes((GOLDEN / "rolling.mcap").read_bytes())
    assert main([str(log)]) == 0
    out = capsys.readouterr().out
    assert f"file:        {tmp_path}/run{shown}.mcap (" in out
    assert main([str(log), "--cameras-template"]) == 0
    out = capsys.readouterr().out
    assert f"# The cameras of run{shown}.mcap, from its dsp.cameras metadata" in out
    cams = tmp_path / f"cams{hostile}.yaml"
    assert main([str(log), "--cameras-template", "-o", str(cams)]) == 0
    assert capsys.readouterr().out == f"wrote {tmp_path}/cams{shown}.yaml\n"
    assert f"run{shown}.mcap" in cams.read_text() and "\x1b" not in cams.read_text()
    assert main([str(log), "--check"]) == 0
    assert "\x1b" not in "".join(capsys.readouterr())


def test_json_and_check(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([str(GOLDEN / "scenario2.mcap"), "--json", "--check"]) == 0
    doc = json.loads(capsys.readouterr().out)
    manifest = json.loads((GOLDEN / "manifest.json").read_text())["scenes"]["scenario2"]
    assert {t["topic"]: t["messages"] for t in doc["topics"]} == manifest["topics"]
    assert doc["checked"] and doc["problems"] == [] and doc["robots"] == [
        "robot1", "robot2", "robot3"]


def _damaged(tmp_path: Path, how: str) -> Path:
    seed = seed_log("scenario2", compression=CompressionType.LZ4, chunk_size=32 * 1024)
    if how == "chunk":
        chunk = [r for r in records(seed) if r.op == 0x06][1]
        buf = bytearray(seed)
        buf[chunk.offset + 9 + 100] ^= 4
        data = bytes(buf)
    elif how == "crc":
        chunk = next(r for r in records(seed) if r.op == 0x06)
        buf = bytearray(seed)
        struct.pack_into("<I", buf, chunk.offset + 9 + 24, 7)
        data = bytes(buf)
    else:
        rng = random.Random(0)
        while True:
            data, what, _ = m_summary(seed, rng)
            if how in what:
                break
    path = tmp_path / f"{how}.mcap"
    path.write_bytes(data)
    return path


@pytest.mark.parametrize("how", ["chunk", "crc", "dup chunk index", "drop chunk index",
                                 "topic"])
def test_check_finds_damage(tmp_path: Path, how: str,
                            capsys: pytest.CaptureFixture[str]) -> None:
    path = _damaged(tmp_path, how)
    assert main([str(path), "--check"]) == 1
    captured = capsys.readouterr()
    assert "problem(s)" in captured.out
    assert captured.err.count("\n") == 1 and str(path) in captured.err
    # without --check a damage the summary reveals is a one-line error (1) or, for damage
    # inside a chunk, not looked for
    code = main([str(path)])
    err = capsys.readouterr().err
    assert code in (0, 1) and "Traceback" not in err
    if code:
        assert err.count("\n") == 1


def test_not_a_log(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "x.mcap"
    bad.write_bytes(b"\x89MCAP0\r\n\x01")
    assert main([str(bad)]) == 1
    assert capsys.readouterr().err.count("\n") == 1
    assert main([str(tmp_path / "missing.mcap")]) == 1
