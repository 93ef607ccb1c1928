"""The README and docs/ stand on their own in a clone and stay a newcomer's: every relative
link, image and anchor exists and nothing points outside the repository; the README is
short and reaches its four tasks from its first screen; no user page is long or holds
seed-by-seed history (that lives in docs/notes/, outside the navigation); the command
reference covers every command; a changelog exists. The site's own build (sphinx-build
-W in the README's test command) checks the links between its pages again."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = [ROOT / "README.md", ROOT / "CHANGELOG.md", *sorted(DOCS.rglob("*.md"))]
NOTES = DOCS / "notes"
USER_PAGES = [p for p in sorted(DOCS.rglob("*.md"))
              if NOTES not in p.parents and p.parent.name != "generated"]

README_MAX_LINES = 200
USER_PAGE_MAX_LINES = 300
FIRST_SCREEN_LINES = 40
TASKS = ("record", "own", "ball", "compare")
"""Words the README's four task links carry (record + replay + view; your own log; your
venue's ball; compare two runs)."""

HISTORY = [re.compile(p) for p in (r"\bseeds \d+[-,]", r"\bseed \d+\b(?! *[`'\"])",
                                   r"change by change", r"\bbefore \(at [0-9a-f]{7}",
                                   r"in an earlier run", r"made after seeing")]
"""What marks a lab notebook: figures seed by seed, change by change, before and after."""


def slug(heading: str) -> str:
    """GitHub's (and MyST's) anchor for a Markdown heading."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors(page: Path) -> set[str]:
    text = re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)
    return {slug(h) for h in re.findall(r"^#{1,6} +(.+?) *$", text, flags=re.M)}


def links(page: Path) -> list[str]:
    text = re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)
    return re.findall(r"\]\(([^)\s]+)\)", text)


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_links_images_and_anchors_exist_within_the_repository(page: Path) -> None:
    text = page.read_text(encoding="utf-8")
    assert "../shared" not in text
    for target in links(page):
        if re.match(r"^[a-z]+://", target):
            continue
        file, _, anchor = target.partition("#")
        path = (page.parent / file).resolve() if file else page
        assert path.is_relative_to(ROOT), f"{page.name}: {target} leaves the repository"
        assert path.exists(), f"{page.name}: {target} does not exist"
        if anchor:
            assert path.suffix == ".md", f"{page.name}: {target}: an anchor in a non-page"
            assert anchor in anchors(path), f"{page.name}: {target}: no such heading"


def test_readme_is_short_and_reaches_the_four_tasks_from_its_first_screen() -> None:
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES
    first = "\n".join(lines[:FIRST_SCREEN_LINES])
    targets = re.findall(r"\[([^\]]+)\]\(#([^)]+)\)", first)
    for word in TASKS:
        assert any(word in label.lower() for label, _ in targets), word
    headings = anchors(ROOT / "README.md")
    for _, anchor in targets:
        assert anchor in headings, anchor


@pytest.mark.parametrize("page", USER_PAGES, ids=lambda p: str(p.relative_to(DOCS)))
def test_user_pages_are_short_and_hold_no_history(page: Path) -> None:
    text = page.read_text(encoding="utf-8")
    assert len(text.splitlines()) <= USER_PAGE_MAX_LINES, f"{page.name}: over 300 lines"
    prose = re.sub(r"```.*?```", "", text, flags=re.S)
    for pattern in HISTORY:
        found = pattern.search(prose)
        assert found is None, f"{page.name}: {found.group(0)!r}: history belongs in notes/"


def test_the_history_checks_catch_a_notebook() -> None:
    notebook = (NOTES / "hops.md").read_text(encoding="utf-8")
    assert any(p.search(notebook) for p in HISTORY)


def test_notes_stay_out_of_the_navigation_and_are_all_listed() -> None:
    listed = set(links(NOTES / "index.md"))
    for page in sorted(NOTES.glob("*.md")):
        assert page.read_text(encoding="utf-8").startswith("---\norphan: true\n---"), page.name
        if page.name != "index.md":
            assert page.name in listed, f"notes/index.md does not list {page.name}"
    for page in USER_PAGES:
        for block in re.findall(r"```\{toctree\}(.*?)```", page.read_text(encoding="utf-8"),
                                flags=re.S):
            assert "notes/" not in block, f"{page.name}: notes in the navigation"


def test_every_user_page_is_in_the_navigation() -> None:
    entries = set()
    for page in USER_PAGES:
        for block in re.findall(r"```\{toctree\}(.*?)```", page.read_text(encoding="utf-8"),
                                flags=re.S):
            for line in block.splitlines():
                if line.strip() and not line.startswith(":"):
                    entries.add((page.parent / line.strip()).with_suffix(".md").resolve())
    for page in USER_PAGES:
        if page != DOCS / "index.md":
            assert page.resolve() in entries, f"{page.relative_to(DOCS)} is in no toctree"


def test_the_cli_reference_covers_every_command() -> None:
    import sys

    sys.path.insert(0, str(DOCS))
    import cli_parsers

    # [project.scripts] read by pattern: tomllib is Python 3.11's, the project runs on 3.10
    section = (ROOT / "pyproject.toml").read_text(encoding="utf-8").split("[project.scripts]")[1]
    section = section.split("\n[")[0]
    scripts = dict(re.findall(r'^(dsp-[a-z]+) = "([^"]+)"', section, flags=re.M))
    launch = (ROOT / "dsp" / "launch.py").read_text(encoding="utf-8")
    assert set(scripts) == set(cli_parsers.COMMANDS)
    for name, entry in scripts.items():
        function = entry.split(":")[1]
        assert f'_launch("{name}", "{cli_parsers.COMMANDS[name]}")' in launch, name
        page = (DOCS / "reference" / "cli" / f"{name}.md").read_text(encoding="utf-8")
        assert f":ref: cli_parsers.{function}\n" in page, name


def test_the_cli_reference_escapes_help_but_keeps_it() -> None:
    import sys

    sys.path.insert(0, str(DOCS))
    import cli_parsers

    parser = cli_parsers.replay()
    helps = [a.help for a in parser._actions if a.help]
    assert any(r"\*.mcap" in h for h in helps)
    assert len(helps) > 30



def test_the_cli_reference_shows_defaults_as_a_user_types_them() -> None:
    """``Default: 0.05,1.0``, not a Python tuple; no ``Default: True`` under a flag."""
    import sys

    sys.path.insert(0, str(DOCS))
    import cli_parsers
    from sphinxarg.parser import parse_parser

    shown = {name: option["default"]
             for group in parse_parser(cli_parsers.replay())["action_groups"]
             for option in group["options"] for name in option["name"]}
    assert shown["--pose-sigma"] is None  # learnt from the log unless given
    pair = argparse.ArgumentParser().add_argument("--pair", default=(0.05, 1.0))
    assert str(cli_parsers._typed(pair)) == "0.05,1.0"
    assert str(shown["--image-topic"]) == "/{robot}/omni/image/compressed"
    for flag in ("--no-progress", "--progress", "--quiet", "--force", "--strict"):
        assert shown[flag] is None or str(shown[flag]).strip("'") == "==SUPPRESS==", flag
    assert str(shown["--pose-tolerance"]) == "0.1"
    help_all = parse_parser(cli_parsers.evaluate())["action_groups"]
    only = next(o for g in help_all for o in g["options"] if "--only" in o["name"])
    assert str(only["default"]).strip("'") == "==SUPPRESS=="  # an empty list: nothing to show


def test_a_changelog_in_keep_a_changelog_form() -> None:
    text = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert text.startswith("# Changelog")
    assert "keepachangelog.com" in text
    assert "## [Unreleased]" in text


def test_readme_images_are_small() -> None:
    for image in (DOCS / "images").glob("*.png"):
        assert image.stat().st_size < 400_000, f"{image.name} is large for a README"


def test_every_page_that_opens_rerun_says_how_without_a_display() -> None:
    """``rerun FILE`` stops at once without a display (Rerun's own winit error); a page that
    gives it also gives ``rerun --web-viewer FILE``."""
    for page in (ROOT / "README.md", *USER_PAGES):
        text = page.read_text(encoding="utf-8")
        opens = re.findall(r"^rerun [\w./-]+\.(?:rrd|mcap)|`rerun [\w./-]+\.(?:rrd|mcap)`",
                           text, flags=re.M)
        if opens:
            assert "rerun --web-viewer " in text, f"{page.name}: {opens[0]} without a display"
