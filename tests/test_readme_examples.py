"""The README's list of commands (its third ``bash`` block) runs as written, in order, in a
fresh folder holding a copy of logs/golden: each line exits 0. A line is left out only for
a reason given here (a display or a browser, files the reader brings, or minutes of
simulation); a new line in the README runs unless it is added below."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

SKIP = {
    "dsp-replay run.mcap --rerun": "opens the Rerun viewer (a display)",
    "dsp-replay run.mcap --serve": "serves a browser viewer until Ctrl-C",
    "dsp-record match.mcap": "a match recording: simulation time, not the README's words",
    "dsp-record yellow.mcap": "a match recording: simulation time (the golden match log stands "
                              "in as yellow.mcap)",
    "dsp-record lobs.mcap": "a lob recording: simulation time (the golden lob log stands in "
                            "as lobs.mcap)",
    "dsp-record m.mcap": "a match recording: simulation time",
    "dsp-replay m.mcap": "needs m.mcap, the match recording left out above",
    "dsp-eval --suite random --count 200": "200 simulated scenes: minutes",
    "dsp-eval  ": "Table 1: four scenarios simulated and replayed six ways",
    "dsp-info team.mcap": "team.mcap is the reader's own robot log",
    "dsp-calibrate --from-measurements": "points.csv is the reader's own measurements",
    "dsp-replay team.mcap": "team.mcap is the reader's own robot log",
    "dsp-calibrate --ball-from frames/": "frames/ are the reader's own labelled images",
    "dsp-eval --suite images": "frames/ are the reader's own labelled images",
    "dsp-record run.mcap": "a 6 s mirror-camera recording: over a minute of simulation (the "
                           "golden rolling log stands in as run.mcap)",
    "dsp-calibrate --camera mirror": "the simulated calibration procedure: over a minute",
    "dsp-replay run.mcap --calibration mirror.json": "needs mirror.json, the calibration left "
                                                     "out above",
}

STAND_INS = {"dsp-record run.mcap": ("logs/golden/rolling.mcap", "run.mcap"),
             "dsp-record yellow.mcap": ("logs/golden/match.mcap", "yellow.mcap"),
             "dsp-record lobs.mcap": ("logs/golden/lobs.mcap", "lobs.mcap")}
"""A left-out recording's file, made from a golden log so the lines after it run."""


def _commands() -> list[str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = re.findall(r"```bash\n(.*?)```", text, flags=re.S)[2]
    return [line.strip() for line in block.replace("\\\n", " ").splitlines() if line.strip()]


def _skipped(line: str) -> str | None:
    padded = line if "#" not in line else line[:line.index("#")] + "  "
    return next((why for start, why in SKIP.items() if padded.startswith(start)), None)


def test_every_left_out_line_is_in_the_readme() -> None:
    lines = _commands()
    for start in SKIP:
        assert any(_skipped(line) == SKIP[start] for line in lines), start


@pytest.mark.skipif(shutil.which("dsp-replay") is None, reason="the project is not installed")
def test_the_readme_command_list_runs_as_written(tmp_path: Path) -> None:
    shutil.copytree(ROOT / "logs" / "golden", tmp_path / "logs" / "golden")
    env = {**os.environ, "MPLBACKEND": "Agg", "PATH": os.pathsep.join(
        [str(Path(sys.executable).parent), os.environ.get("PATH", "")])}
    ran = []
    for line in _commands():
        if _skipped(line) is not None:
            for start, (source, target) in STAND_INS.items():
                if line.startswith(start):
                    shutil.copy(tmp_path / source, tmp_path / target)
            continue
        t0 = time.perf_counter()
        proc = subprocess.run(["bash", "-c", line], cwd=tmp_path, env=env, capture_output=True,
                              text=True, timeout=300)
        assert proc.returncode == 0, f"{line}\nexit {proc.returncode}\n{proc.stderr}"
        ran.append(f"{time.perf_counter() - t0:6.1f} s  {line}")
    print("\n".join(ran))
    assert len(ran) >= 7
    assert (tmp_path / "results" / "batch-summary.json").is_file()
