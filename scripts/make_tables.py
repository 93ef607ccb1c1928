"""Write the accuracy and speed tables of the README and the documentation site.

    python scripts/make_tables.py            # rewrite the tables (README.md, docs/generated/)
    python scripts/make_tables.py --check    # exit 1 if a table is not what this script writes

The accuracy figures come from the golden results in ``logs/golden/`` (what
``scripts/make_golden.py`` wrote and ``tests/replay/test_golden.py`` replays byte for byte),
so they change only when the goldens do; the speed is measured here, on this machine, by
replaying the golden logs in this process (a few seconds), and the table says when, at
which commit and on how many cores. Nothing is typed by hand: ``tests/test_tables.py``
fails when a table in the README or the site is not in the form this script writes, or
when its accuracy figures are not the goldens'.

The README holds its table between ``<!-- table:headline -->`` and
``<!-- /table:headline -->``; the site includes ``docs/generated/headline.md`` and
``docs/generated/golden.md``.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
import os
import re
import statistics
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "logs" / "golden"
README = ROOT / "README.md"
GENERATED = ROOT / "docs" / "generated"
BEGIN, END = "<!-- table:headline -->", "<!-- /table:headline -->"

SCENES: dict[str, tuple[str, ...]] = {
    "the paper's four scenes, a still ball": ("scenario1", "scenario2", "scenario3",
                                             "scenario4"),
    "a rolling ball": ("rolling",),
    "a match: free-running cameras, boxes of the ball's colour": ("match",),
    "a lob, the ball in the air": ("lobs",),
}
"""Headline rows: each pools the fused steps of its golden logs."""

COLUMNS = {"profile-best": "default (dsp-replay LOG)",
           "paper-mean": "the paper (eq. 3-14, mean)",
           "corrected-mean": "corrected, mean",
           "corrected-track": "corrected, tracker",
           "corrected-ballistic": "corrected, 3-D (ballistic)"}
"""Headline columns: golden configurations (``<method>-<fusion>``); a log not replayed
with one (the 3-D fusions are replayed on the lob only) shows "-"."""

SPEED_LOGS = ("scenario1", "rolling", "match", "lobs")
SPEED_RUNS = 3


def _summary(scene: str, config: str) -> dict[str, object]:
    doc = json.loads((GOLDEN / f"{scene}.{config}.json").read_text(encoding="utf-8"))
    summary: dict[str, object] = doc["summary"]
    return summary


def pooled_rmse_m(scenes: Sequence[str], config: str) -> tuple[float, int]:
    """The fused RMSE over the scenes' fused steps together, and how many steps had one."""
    total, count = 0.0, 0
    for scene in scenes:
        if not (GOLDEN / f"{scene}.{config}.json").is_file():
            continue
        fused = _summary(scene, config)["fused"]
        assert isinstance(fused, dict)
        n, rmse = int(fused["errors"]), fused["rmse_m"]
        if n and rmse is not None:
            total += float(rmse) ** 2 * n
            count += n
    return (math.sqrt(total / count) if count else math.nan), count


def _metres(value: float) -> str:
    return "-" if math.isnan(value) else f"{value:.3f} m"


def accuracy_rows() -> list[list[str]]:
    """One row per headline scene: its frames, then the fused RMSE of each column."""
    rows = []
    for label, scenes in SCENES.items():
        frames = sum(int(str(_summary(s, "paper-mean")["frames"])) for s in scenes)
        cells = [label, str(frames)]
        for config in COLUMNS:
            rmse, _ = pooled_rmse_m(scenes, config)
            cells.append(_metres(rmse))
        rows.append(cells)
    return rows


def golden_rows() -> list[list[str]]:
    """Every golden log under every configuration it was replayed with."""
    manifest = json.loads((GOLDEN / "manifest.json").read_text(encoding="utf-8"))
    configs = [f"{c['method']}-{c['fusion']}" for c in manifest["configs"]]
    rows = []
    for scene in sorted(manifest["scenes"]):
        extra = manifest.get("extra_configs", {}).get(scene, [])
        for config in configs + [f"{c['method']}-{c['fusion']}" for c in extra]:
            s = _summary(scene, config)
            rmse, steps = pooled_rmse_m((scene,), config)
            rows.append([scene, config, str(s["frames"]), str(steps), _metres(rmse)])
    return rows


def speed_frames() -> int:
    """How many frames one pass over the speed logs replays (from their golden results)."""
    return sum(int(str(_summary(name, "corrected-track")["frames"])) for name in SPEED_LOGS)


def measure_speed() -> str:
    """Replay each speed log ``SPEED_RUNS`` times in this process: frames a second, the
    median run of each log summed."""
    sys.path.insert(0, str(ROOT))
    os.environ.setdefault("RUST_LOG", "off")
    from replay import replay
    from replay.profiles import options_for

    seconds = 0.0
    for name in SPEED_LOGS:
        times = []
        for _ in range(SPEED_RUNS):
            t0 = time.perf_counter()
            replay(GOLDEN / f"{name}.mcap", options_for(progress=False))
            times.append(time.perf_counter() - t0)
        seconds += statistics.median(times)
    return f"{speed_frames() / seconds:.0f}"


def speed_rows(frames_per_s: str) -> list[list[str]]:
    return [["the default pipeline in process (read, decode, detect, fit the lines, locate, "
             "track; set-up included)",
             f"the golden {', '.join(SPEED_LOGS)} logs: {speed_frames()} frames",
             f"{frames_per_s} frames/s"]]


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


ACCURACY_HEADER = ["fused RMSE on the golden logs (3 robots, ideal camera, exact poses)",
                   "frames", *COLUMNS.values()]
SPEED_HEADER = ["speed", "work", "median of 3 runs"]
GOLDEN_HEADER = ["log", "method-fusion", "frames", "fused steps scored", "fused RMSE"]


def _commit() -> str:
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, check=True,
                             capture_output=True, text=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        out = "unknown"
    return out


def headline(frames_per_s: str, when: str) -> str:
    """The README's table: accuracy from the goldens, speed as measured, and the stamp."""
    return (_table(ACCURACY_HEADER, accuracy_rows()) + "\n"
            + _table(SPEED_HEADER, speed_rows(frames_per_s))
            + f"\nWritten by `python scripts/make_tables.py` {when}. The paper prints "
            "0.383 m for its four scenes (Table 1).\n")


_FPS, _WHEN = "\x00fps\x00", "\x00when\x00"


def headline_pattern() -> re.Pattern[str]:
    """The README's table as this script writes it, whatever the speed and the date."""
    text = re.escape(headline(_FPS, _WHEN))
    text = text.replace(re.escape(_FPS), r"[0-9]+").replace(
        re.escape(_WHEN), r"on [0-9]{4}-[0-9]{2}-[0-9]{2} at commit [0-9a-f]+, [0-9]+ cores, "
        r"load average [0-9]+\.[0-9] at the start")
    return re.compile(text)


def golden_table() -> str:
    return (_table(GOLDEN_HEADER, golden_rows())
            + "\nWritten by `python scripts/make_tables.py` from `logs/golden/`.\n")


def readme_block(text: str) -> str:
    """What the README holds between its table markers."""
    try:
        start = text.index(BEGIN) + len(BEGIN)
        end = text.index(END, start)
    except ValueError as err:
        raise SystemExit(f"{README.name}: no {BEGIN} ... {END} block") from err
    return text[start:end].strip("\n") + "\n"


def problems() -> list[str]:
    """Where a committed table is not what this script writes (empty: none)."""
    found = []
    block = readme_block(README.read_text(encoding="utf-8"))
    if not headline_pattern().fullmatch(block):
        found.append(f"{README.name}: the headline table is not this script's (run it)")
    site = GENERATED / "headline.md"
    if not site.is_file() or site.read_text(encoding="utf-8") != block:
        found.append(f"{site.relative_to(ROOT)}: differs from the README's table (run it)")
    golden = GENERATED / "golden.md"
    if not golden.is_file() or golden.read_text(encoding="utf-8") != golden_table():
        found.append(f"{golden.relative_to(ROOT)}: not the goldens' figures (run it)")
    return found


def _write(path: Path, text: str) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(path)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="make_tables.py", allow_abbrev=False,
                                     description=__doc__.split("\n")[0])
    parser.add_argument("--check", action="store_true",
                        help="check the tables' form and accuracy figures; write nothing")
    args = parser.parse_args(argv)
    readme = README.read_text(encoding="utf-8")
    if args.check:
        found = problems()
        for problem in found:
            print(f"make_tables.py: {problem}", file=sys.stderr)
        return 1 if found else 0
    load = os.getloadavg()[0]  # other work on the machine slows the speed row: say how much
    speed = measure_speed()
    when = (f"on {dt.datetime.now(dt.timezone.utc):%Y-%m-%d} at commit {_commit()}, "
            f"{os.cpu_count()} cores, load average {load:.1f} at the start")
    block = headline(speed, when)
    start = readme.index(BEGIN) + len(BEGIN) if BEGIN in readme else None
    if start is None:
        raise SystemExit(f"{README.name}: no {BEGIN} ... {END} block")
    end = readme.index(END, start)
    _write(README, readme[:start] + "\n" + block + readme[end:])
    GENERATED.mkdir(exist_ok=True)
    _write(GENERATED / "headline.md", block)
    _write(GENERATED / "golden.md", golden_table())
    print(f"wrote {README.name}, docs/generated/headline.md and golden.md")
    return 0


def _main() -> int:
    try:
        return main()
    except (OSError, ValueError, KeyError, TypeError) as err:
        # a golden file missing or not the results form: one line, nothing written
        where = getattr(err, "filename", None) or "logs/golden"
        print(f"make_tables.py: error: {where}: {err}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(_main())
