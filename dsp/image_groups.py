"""Groups of labelled-image folders: which folders are one day or one event.

Images of one day are near-duplicates of each other, and a collection often holds many
small folders (one robot on one day, a few images each). ``dsp-eval --suite images`` and
``train/train.py`` therefore fit, hold out and score by group, not by folder:

- ``folder``: every folder is its own group (the default: what the suite always did);
- ``day``: a folder's group is its first path part under its root (``DAY/ROBOT``);
- a grouping file: one group a line, ``NAME PATTERN [PATTERN ...]``, ``#`` starting a
  comment. A folder belongs to the group of the first line with a pattern that matches
  its path under its root or one of that path's leading parts (``fnmatch``: ``2025*``
  takes every folder of 2025, ``20240606`` every robot of that day, ``20230709/r8`` one
  folder). A folder no line takes is an error naming it, so a new folder is never scored
  in a group by accident. ``train/msl-events.txt`` is the grouping of the shared set.

Read bounded (a text file of at most ``MAX_GROUPS_BYTES``); a bad line is one
:class:`InputError` naming the file and the line.
"""

from __future__ import annotations

import fnmatch
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from dsp.errors import InputError
from dsp.textfile import read_text_file

__all__ = ["BY_DAY", "BY_FOLDER", "MAX_GROUPS_BYTES", "Grouping", "group_folders",
           "read_grouping"]

MAX_GROUPS_BYTES = 1 << 20
BY_FOLDER = "folder"
BY_DAY = "day"
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,63}")


@dataclass(frozen=True)
class Grouping:
    """How folders (by their path under their root, ``a/b``) are grouped."""

    kind: str
    """``folder``, ``day`` or ``file``."""
    source: str = ""
    """The grouping file's path (``file`` only), for messages."""
    lines: tuple[tuple[str, tuple[str, ...]], ...] = ()
    """(group name, patterns) of a grouping file, in its order."""

    @property
    def label(self) -> str:
        """What the summary records: ``folder``, ``day`` or the file's name."""
        return Path(self.source).name if self.kind == "file" else self.kind

    def group_of(self, rel: str) -> str:
        """The group of a folder at ``rel`` (its path under its root, ``.`` for the root)."""
        if self.kind == BY_FOLDER:
            return rel
        parts = [] if rel == "." else rel.split("/")
        if self.kind == BY_DAY:
            return parts[0] if parts else rel
        heads = ["/".join(parts[:k]) for k in range(len(parts), 0, -1)] or ["."]
        for name, patterns in self.lines:
            if any(fnmatch.fnmatchcase(head, p) for p in patterns for head in heads):
                return name
        raise InputError(f"{self.source}: no group takes the folder {rel!r}; add it to a "
                         "line (NAME PATTERN ...)")


def read_grouping(spec: str) -> Grouping:
    """``folder``, ``day`` or a grouping file's path."""
    if spec in (BY_FOLDER, BY_DAY):
        return Grouping(spec)
    path = Path(spec)
    text = read_text_file(path, MAX_GROUPS_BYTES, what="a grouping file")
    lines: list[tuple[str, tuple[str, ...]]] = []
    seen: set[str] = set()
    for number, raw in enumerate(text.splitlines(), 1):
        words = raw.split("#", 1)[0].split()
        if not words:
            continue
        name, patterns = words[0], tuple(words[1:])
        if not _NAME.fullmatch(name) or not patterns:
            raise InputError(f"{path}:{number}: not 'NAME PATTERN [PATTERN ...]' (a name of "
                             f"letters, digits, '.', '_' or '-'): {raw[:60]!r}")
        if name in seen:
            raise InputError(f"{path}:{number}: the group {name!r} is named twice")
        seen.add(name)
        lines.append((name, patterns))
    if not lines:
        raise InputError(f"{path}: no group in it (lines of NAME PATTERN [PATTERN ...])")
    return Grouping("file", str(path), tuple(lines))


def group_folders(grouping: Grouping, folders: Sequence[tuple[str, str, Path]]
                  ) -> dict[str, list[tuple[str, Path]]]:
    """(key, rel, path) of each folder -> {group: [(key, path), ...]}, groups in order of
    their first folder."""
    groups: dict[str, list[tuple[str, Path]]] = {}
    for key, rel, path in folders:
        name = key if grouping.kind == BY_FOLDER else grouping.group_of(rel)
        groups.setdefault(name, []).append((key, path))
    return groups
