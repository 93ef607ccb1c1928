"""Text from a log made safe for a terminal.

Robot names come from topic names, and topics, frame ids and metadata strings are whatever the
log's writer put there: an escape sequence in one could clear the screen, retitle the
terminal or hide a line. :func:`printable` escapes every control and format character
(C0, DEL, C1 — so ESC and every ANSI/OSC sequence —, bidirectional overrides, zero-width
marks, lone surrogates) as ``\\xNN`` / ``\\uNNNN``, and with ``lines=False`` newlines too, so
a name stays on its line. Everything the commands print goes through it (errors in
:func:`dsp.cli.run_main`, summaries in :func:`dsp.cli.echo`).
"""

from __future__ import annotations

import unicodedata

__all__ = ["format_bytes", "printable"]

_UNSAFE_CATEGORIES = frozenset({"Cc", "Cf", "Cs", "Co", "Cn", "Zl", "Zp"})


def _escape(ch: str) -> str:
    code = ord(ch)
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}" if code < 0x10000 \
        else f"\\U{code:08x}"


def printable(text: object, *, lines: bool = False, limit: int | None = None) -> str:
    """``str(text)`` with control and format characters escaped (``"\\x1b[2J"`` ->
    ``"\\\\x1b[2J"``); tabs are kept, newlines are kept only when ``lines``. With ``limit``,
    what is longer is cut to ``limit`` characters and ``...`` (a name from a log in a line)."""
    s = _escaped(str(text), lines)
    return s if limit is None or len(s) <= limit else s[:limit] + "..."


def _escaped(s: str, lines: bool) -> str:
    if s.isprintable():  # the common case: nothing to escape
        return s
    out = []
    for ch in s:
        if ch == "\t" or (ch == "\n" and lines):
            out.append(ch)
        elif ch.isprintable() or unicodedata.category(ch) not in _UNSAFE_CATEGORIES:
            out.append(ch)
        else:
            out.append(_escape(ch))
    return "".join(out)


def format_bytes(n: int) -> str:
    """A size as every command prints it: binary units (B, KiB, MiB, GiB), one decimal."""
    size = float(n)
    for unit in ("B", "KiB", "MiB"):
        if size < 1024:
            return f"{n} B" if unit == "B" else f"{size:.1f} {unit}"
        size /= 1024
    return f"{size:.1f} GiB"
