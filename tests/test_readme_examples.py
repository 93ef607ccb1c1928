"""Every shell block of the README and the tutorials runs as written, in order, each line
exiting 0: the README's in one fresh folder, the three tutorials one after the other in
another (the later ones use what the earlier made, as a reader would). A renamed option
breaks this test, not a user.

A line is left out only for a reason given in SKIP (a display, a browser, ROS 2 on the
robots, the suite itself, minutes of simulation); a recording left out is replaced by a
golden log (STAND_INS), and a recording that runs is made shorter (SHORTER). The files a
reader brings (a team's log, measured points, labelled frames) are made first from the
golden rolling log and the committed test images, by the project's own scripts (INPUTS).
Each folder holds a copy of logs/golden and links to scripts/ and tests/data/, as a clone
does."""

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
README = ROOT / "README.md"
TUTORIALS = [ROOT / "docs" / "tutorials" / f"{name}.md"
             for name in ("simulated-match", "team-log", "venue-ball")]

SKIP = {
    "python3 -m venv .venv": "makes a virtual environment and installs the project: the "
                             "suite runs in one already",
    "pip install -e": "installs the project: the suite runs installed",
    "ruff check .": "the README's test command runs it",
    "mypy": "the README's test command runs it",
    "sphinx-build": "the README's test command builds the site",
    "python -m pytest": "the suite itself",
    "python scripts/make_tables.py": "rewrites the committed tables; tests/test_tables.py "
                                     "checks them",
    "rerun ": "opens the Rerun viewer (a display)",
    "dsp-replay match.mcap --serve": "serves a browser viewer until Ctrl-C",
    "ros2 bag record": "needs ROS 2 and the robots",
    "dsp-record match.mcap --scenario match --duration 3 #": "a 3 s match: simulation time "
                                                             "(the golden match log stands in)",
    "dsp-record team-source.mcap": "a 4 s mirror-camera recording: over a minute of "
                                   "simulation (the golden rolling log stands in)",
    "dsp-record boxes.mcap": "a 3 s match with boxes of the ball's colour: simulation time "
                             "(the golden match log, which has two, stands in)",
}

STAND_INS = {
    "dsp-record match.mcap --scenario match --duration 3 #": ("logs/golden/match.mcap",
                                                              "match.mcap"),
    "dsp-record team-source.mcap": ("logs/golden/rolling.mcap", "team-source.mcap"),
    "dsp-record boxes.mcap": ("logs/golden/match.mcap", "boxes.mcap"),
}
"""A left-out recording's file, copied from a golden log so the lines after it run."""

SHORTER = {"dsp-record match.mcap --scenario match --duration 3 --seed 1":
           ("--duration 3", "--duration 0.5")}
"""A recording that runs, shortened: 0.5 s of match is 10 images per robot."""

INPUTS = [
    # a team's log and the camera the simulation knows, from the golden rolling log
    "python scripts/team_example.py convert logs/golden/rolling.mcap team.mcap --pad 1280x1024"
    " --centre 640,512 --mount-deg 90 --exact-cameras exact.yaml",
    # points measured around the same camera, with a tape's and a heading's error
    "python scripts/team_example.py measure logs/golden/rolling.mcap points.csv --pad 1280x1024"
    " --centre 640,512 --mount-deg 90 --points 12",
    # ten labelled frames and four more of a real venue (the committed test images)
    "mkdir -p frames && cp tests/data/msl-images/20220715/r7/* frames/",
]
"""What a README reader brings, made before the README's lines run."""


def shell_lines(page: Path) -> list[str]:
    """The page's ``bash`` blocks, a line each (continuations joined, comments dropped)."""
    text = page.read_text(encoding="utf-8")
    lines = []
    for block in re.findall(r"```bash\n(.*?)```", text, flags=re.S):
        for line in block.replace("\\\n", " ").splitlines():
            if line.strip() and not line.lstrip().startswith("#"):
                lines.append(re.sub(r" +", " ", line.strip()) + "  ")
    return lines


def _skipped(line: str) -> str | None:
    return next((why for start, why in SKIP.items() if line.startswith(start)), None)


def _folder(tmp_path: Path) -> Path:
    shutil.copytree(ROOT / "logs" / "golden", tmp_path / "logs" / "golden")
    (tmp_path / "scripts").symlink_to(ROOT / "scripts")
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "data").symlink_to(ROOT / "tests" / "data")
    return tmp_path


def _run_all(lines: list[str], cwd: Path) -> list[str]:
    env = {**os.environ, "MPLBACKEND": "Agg", "PATH": os.pathsep.join(
        [str(Path(sys.executable).parent), os.environ.get("PATH", "")])}
    ran = []
    for line in lines:
        if _skipped(line) is not None:
            for start, (source, target) in STAND_INS.items():
                if line.startswith(start):
                    shutil.copy(cwd / source, cwd / target)
            continue
        for start, (old, new) in SHORTER.items():
            if line.startswith(start):
                line = line.replace(old, new)
        t0 = time.perf_counter()
        proc = subprocess.run(["bash", "-c", line], cwd=cwd, env=env, capture_output=True,
                              text=True, timeout=300)
        assert proc.returncode == 0, f"{line}\nexit {proc.returncode}\n{proc.stderr}"
        ran.append(f"{time.perf_counter() - t0:6.1f} s  {line.strip()}")
    print("\n".join(ran))
    return ran


def test_every_skip_and_stand_in_names_a_line() -> None:
    lines = [line for page in (README, *TUTORIALS) for line in shell_lines(page)]
    for table in (SKIP, STAND_INS, SHORTER):
        for start in table:
            assert any(line.startswith(start) for line in lines), start


def test_the_tutorials_have_shell_blocks() -> None:
    for page in TUTORIALS:
        assert len([line for line in shell_lines(page) if _skipped(line) is None]) >= 3, page


OUTPUT = re.compile(r"(?:^| )(?:-o|--out(?:-[a-z]+)?|--save|--plot|--exact-cameras)[ =](\S+)")
"""An option that names a file a line writes."""


def test_no_line_writes_over_what_an_earlier_line_wrote() -> None:
    """A reader edits what a page has them write (a camera file's template); a later line
    that writes the same name (with ``--force``) would throw their edits away."""
    for pages in ([README], TUTORIALS):
        written: dict[str, str] = {}
        for line in [line for page in pages for line in shell_lines(page)]:
            for name in OUTPUT.findall(line):
                assert name not in written, f"{line.strip()}\nwrites over\n{written[name]}"
                written[name] = line.strip()


def test_a_tutorial_says_first_where_it_runs_and_what_it_needs() -> None:
    """A tutorial that runs the clone's files (``scripts/``, ``tests/data/``) says, before its
    first step, to run from the clone's root; one that uses files an earlier tutorial writes
    links that tutorial there."""
    for i, page in enumerate(TUTORIALS):
        text = page.read_text(encoding="utf-8")
        intro = text.split("\n## ")[0]
        lines = shell_lines(page)
        if any(re.search(r"(?:^| )(?:scripts|tests/data)/", line) for line in lines):
            assert "Before you start" in intro and "root of a clone" in intro, page.name
        own = {name for line in lines for name in OUTPUT.findall(line)}
        used = {name for line in lines
                for name in re.findall(r"[\w.-]+\.(?:mcap|yaml|json|csv)\b", line)} - own
        for earlier in TUTORIALS[:i]:
            theirs = " ".join(shell_lines(earlier))
            if any(re.search(rf"(?:^| ){re.escape(name)}(?: |$)", theirs) for name in used):
                assert f"]({earlier.name})" in intro, f"{page.name} needs {earlier.name}"


needs_install = pytest.mark.skipif(shutil.which("dsp-replay") is None,
                                   reason="the project is not installed")


@needs_install
def test_the_readme_runs_as_written(tmp_path: Path) -> None:
    cwd = _folder(tmp_path)
    _run_all(INPUTS, cwd)
    ran = _run_all(shell_lines(README), cwd)
    assert len(ran) >= 12
    assert (cwd / "cameras.yaml").is_file() and (cwd / "ball.json").is_file()
    assert (cwd / "side.rrd").is_file()


@needs_install
def test_the_tutorials_run_as_written(tmp_path: Path) -> None:
    cwd = _folder(tmp_path)
    ran = _run_all([line for page in TUTORIALS for line in shell_lines(page)], cwd)
    assert len(ran) >= 14
    assert (cwd / "team.json").is_file() and (cwd / "eval" / "images-summary.md").is_file()
