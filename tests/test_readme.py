"""The README's first lines are the commands a new user runs; CI must run the same test command."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _readme_commands() -> list[str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```bash\n(.*?)```", text, flags=re.S)
    return [line for block in blocks[:2] for line in block.splitlines()
            if line.strip() and not line.startswith("#")]


def test_readme_opens_with_a_run_command_and_a_test_command() -> None:
    run, test = _readme_commands()
    assert "dsp-record" in run and "dsp-replay" in run
    assert "pytest" in test


def test_ci_runs_exactly_the_readme_test_command() -> None:
    _, test = _readme_commands()
    ci_lines = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert test in ci_lines


def test_the_readme_says_what_to_install_where_it_builds_the_docs() -> None:
    """The first setup installs no ``docs`` extra; a reader who runs only it and then the
    README's docs command gets ``sphinx-build: command not found``."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    prose = re.sub(r"```.*?```", "", text, flags=re.S)
    for paragraph in prose.split("\n\n"):
        if "sphinx-build docs" in paragraph:
            assert "pip install -e '.[docs]'" in paragraph, paragraph
