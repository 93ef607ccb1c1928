"""scripts/held_out_events.py on the committed image subset: its tables of what each event's
detector gets wrong, and of balls, false hits and misses on the field and beyond it, count
the per-image rows it writes beside --out."""

from __future__ import annotations

import csv
import json
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
REAL = ROOT / "estimator" / "detection" / "real"


def _counts(path: Path) -> tuple[int, int, int, int]:
    with path.open(encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    empty = [r for r in rows if r["balls"] == "0"]
    balls = [r for r in rows if r["balls"] != "0"]
    return (len(empty), sum(r["outcome"] == "fp" for r in empty),
            sum(r["outcome"] == "fp" for r in balls), sum(r["cx_px"] == "" for r in balls))


def _kinds(path: Path) -> tuple[int, ...]:
    with path.open(encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    balls = [r["balls_off_field"] == "1" for r in rows if r["balls"] != "0"]
    fp = [r["report_off_field"] == "1" for r in rows if r["outcome"] == "fp"]
    fn = [r["balls_off_field"] == "1" for r in rows if r["balls"] != "0" and r["outcome"] != "tp"]
    return tuple(x for kind in (balls, fp, fn) for x in (kind.count(False), kind.count(True)))


def test_the_misses_table_counts_the_rows(tmp_path: Path) -> None:
    (tmp_path / "g.txt").write_text("e r7\n")
    shutil.copy(REAL / "ball_check.onnx", tmp_path / "lovo-e.onnx")
    shutil.copy(REAL / "ball_generic.json", tmp_path / "generic-e.json")
    images = ROOT / "tests" / "data" / "msl-images" / "20220715"
    run = subprocess.run([sys.executable, str(ROOT / "scripts" / "held_out_events.py"),
                          str(images), "--groups", str(tmp_path / "g.txt"), "--checks",
                          str(tmp_path), "--out", str(tmp_path / "ho.json")],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300, check=False)
    assert run.returncode == 0, run.stderr
    rows = [line for line in run.stdout.splitlines() if line.startswith("| e |")]
    cells = [c.strip() for c in rows[0].strip("|").split("|")][1:]
    ten, none = _counts(tmp_path / "ho-10.csv"), _counts(tmp_path / "ho-0.csv")
    assert ten != none  # the generic model's false hits show in brackets
    assert cells == [f"{a}" if a == b else f"{a} ({b})" for a, b in zip(ten, none, strict=True)]
    kinds = [c.strip() for c in rows[1].strip("|").split("|")][1:]
    ten, none = _kinds(tmp_path / "ho-10.csv"), _kinds(tmp_path / "ho-0.csv")
    assert sum(ten[:2]) == 4 and sum(none[:2]) == 12  # every image with a ball, once
    assert kinds == [f"{a}" if a == b else f"{a} ({b})" for a, b in zip(ten, none, strict=True)]
    # 4 test images with ten frames, all 14 with none: the counts are of different rows
    with (tmp_path / "ho-0.csv").open(encoding="utf-8") as f:
        assert sum(1 for _ in f) - 1 == 14
    # one event: the totals are its figures, each column from its own set of rows (ten
    # frames' test images, every image with none, the same test images with none)
    table = [line for line in run.stdout.splitlines() if line.count("|") == 12]
    event = [c.strip() for c in table[2].strip("|").split("|")]
    total = [c.strip() for c in table[-1].strip("|").split("|")]
    assert event[0].startswith("e") and total[0] == "total", table
    assert total[1:] == event[1:], table
    doc = json.loads((tmp_path / "ho.json").read_text(encoding="utf-8"))
    assert doc["total"] == doc["e"], doc
    assert doc["total"]["no_frame"]["test_images"] == 14, doc["total"]
