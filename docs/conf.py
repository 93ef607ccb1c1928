"""The documentation site: ``sphinx-build -W --keep-going -q docs build/docs``.

Sphinx with MyST (the pages stay Markdown that reads on its own in a clone), the furo theme,
sphinx-argparse (the command reference is built from each command's ``build_parser()``, so
it cannot drift from ``--help``) and autodoc (the Python API from its docstrings). Warnings
are errors (``-W``): a broken link between pages, a missing anchor or a page left out of the
navigation fails the build.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "docs")]  # the packages and cli_parsers.py, installed or not
os.environ.setdefault("RUST_LOG", "off")  # importing rerun prints nothing

project = "dual-sight"
author = "the dual-sight developers"
copyright = "the dual-sight developers, MIT licence"

extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinxarg.ext"]
source_suffix = {".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "generated"]  # generated/: tables included into pages

# [text](page.md#a-heading) links are checked against headings down to level 3 (MyST warns
# on a missing page or anchor; GitHub-style slugs, as the pages read on GitHub)
myst_heading_anchors = 3
myst_enable_extensions = ["colon_fence"]

autodoc_default_options = {"members": True, "show-inheritance": False}
autodoc_member_order = "bysource"
autodoc_typehints = "signature"

highlight_language = "text"  # the commands' usage blocks; shell blocks say bash
html_theme = "furo"
html_title = "dual-sight"
html_static_path: list[str] = []
html_show_sourcelink = False
smartquotes = False  # "--out" stays two hyphens, as a user types it
