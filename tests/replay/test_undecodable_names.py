"""File names that are not UTF-8 (a USB stick written by another system, ``bad\\xff.mcap``):
Python sees each undecodable byte as a lone surrogate, which a strict UTF-8 stream, Rerun's
writer and matplotlib's fonts all refuse. Every command writes and prints such a name as its
escape (``bad\\udcff``), or refuses it in one line where a writer cannot take it at all."""

from __future__ import annotations

import io
import json
import os
import sys
from pathlib import Path

import pytest
from synthetic import write_log

from replay.calibrate.cli import main as calibrate_main
from replay.cli import main as replay_main
from replay.compare.cli import main as compare_main
from replay.info.cli import main as info_main

BAD = os.fsdecode(b"bad\xff")
"""``bad`` and a byte that is no UTF-8: ``"bad\\udcff"`` in Python."""
SHOWN = "bad\\udcff"


def strict_stdout(monkeypatch: pytest.MonkeyPatch) -> io.BytesIO:
    """The terminal of a user under ``en_US.UTF-8``: stdout encodes strictly. (Set in the
    test itself: pytest puts its own capture back after each fixture.)"""
    raw = io.BytesIO()
    monkeypatch.setattr(sys, "stdout", io.TextIOWrapper(raw, encoding="utf-8",
                                                        errors="strict", write_through=True))
    return raw


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    try:
        (tmp_path / BAD).mkdir()
    except (OSError, UnicodeEncodeError):  # a file system that takes only UTF-8 names
        pytest.skip("this file system takes no file name that is not UTF-8")
    return tmp_path / BAD


def test_a_batch_over_logs_named_in_other_bytes_writes_every_summary(
        folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    stdout = strict_stdout(monkeypatch)
    write_log(folder / f"{BAD}.mcap", duration_s=0.3)
    out = tmp_path / "out"
    assert replay_main([str(folder), "--out-dir", str(out), "--no-progress"]) == 0
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [f"{BAD}.json", "batch-summary.json", "batch-summary.csv", "batch-summary.md"])
    csv = (out / "batch-summary.csv").read_text(encoding="utf-8").splitlines()
    assert csv[1].startswith(f"{SHOWN}.mcap,ok,")
    assert f"| {SHOWN}.mcap | ok |" in (out / "batch-summary.md").read_text(encoding="utf-8")
    assert json.loads((out / "batch-summary.json").read_text())["logs"][0]["log"] \
        .endswith(f"{BAD}.mcap")
    assert f"| {SHOWN}.mcap | ok |" in stdout.getvalue().decode("utf-8")


def test_a_recording_into_a_folder_named_in_other_bytes_is_refused_in_one_line(
        folder: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = write_log(tmp_path / "in.mcap", duration_s=0.3).path
    assert replay_main([str(log), "--save", str(folder / "x.rrd"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err == (f"dsp-replay: error: --save {folder.parent}/{SHOWN}/x.rrd: Rerun writes "
                   "only to a path in UTF-8; choose another name\n")
    assert list(folder.iterdir()) == []


def test_a_camera_template_and_a_calibration_plot_named_in_other_bytes(
        folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    stdout = strict_stdout(monkeypatch)
    log = write_log(tmp_path / "in.mcap", duration_s=0.3).path
    template = folder / f"{BAD}.yaml"
    assert info_main([str(log), "--cameras-template", "-o", str(template)]) == 0
    assert f"wrote {folder.parent}/{SHOWN}/{SHOWN}.yaml" in stdout.getvalue().decode()
    assert "robot1" in template.read_text(encoding="utf-8")
    measured = folder / f"{BAD}.csv"
    rows = [f"{r},{b},{0.02 * r + 1e-4 * r * r:.4f},{b}" for r in range(40, 300, 20)
            for b in (0, 90, 180, 270)]
    measured.write_text("r_px,bearing_deg,range_m,angle_deg\n" + "\n".join(rows) + "\n")
    plot = folder / f"{BAD}.png"
    assert calibrate_main(["--from-measurements", str(measured), "--image-size", "640x640",
                           "--centre", "320,320", "-o", str(folder / "cal.json"),
                           "--plot", str(plot), "--no-progress"]) == 0
    assert plot.read_bytes().startswith(b"\x89PNG")


def test_compare_tables_and_plot_named_in_other_bytes(
        folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    strict_stdout(monkeypatch)
    log = write_log(tmp_path / "in.mcap", duration_s=0.3).path
    a, b = folder / f"{BAD}-a.json", folder / f"{BAD}-b.json"
    assert replay_main([str(log), "--out", str(a), "--no-progress"]) == 0
    assert replay_main([str(log), "--out", str(b), "--profile", "paper", "--no-progress"]) == 0
    outs = [folder / f"{BAD}.{ext}" for ext in ("csv", "md", "png")]
    assert compare_main([str(a), str(b), "--out-csv", str(outs[0]), "--out-md", str(outs[1]),
                         "--plot", str(outs[2])]) == 0
    assert all(p.stat().st_size > 0 for p in outs)
    assert SHOWN in outs[1].read_text(encoding="utf-8")
