"""Check a log's ROS 2 message definitions against the ones replay knows.

A schema is free text in the log; a damaged or swapped one decodes bytes as the wrong
fields (a float64 read as float32 gives plausible-looking garbage). For the message types in
:data:`dsp.contract.MESSAGE_DEFINITIONS`, every definition section the log and the contract
both name must declare the same fields (type and name, in order; comments, defaults and
constants aside, package prefixes ignored since ``.msg`` files may omit them).
"""

from __future__ import annotations

from dsp import contract

__all__ = ["definition_mismatch"]

_SEP = "=" * 80


def _short_type(t: str) -> str:
    array = ""
    if "[" in t:
        t, array = t[:t.index("[")], t[t.index("["):]
    return t.rsplit("/", 1)[-1] + array


def _fields(text: str) -> list[tuple[str, str]]:
    out = []
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        parts = line.split()
        if len(parts) < 2 or "=" in line:
            continue  # blank, or a constant
        out.append((_short_type(parts[0]), parts[1]))
    return out


def _sections(name: str, text: str) -> dict[str, list[tuple[str, str]]]:
    """Definition name (without "msg/") -> its fields."""
    out = {}
    chunks = text.split(_SEP)
    out[_key(name)] = _fields(chunks[0])
    for chunk in chunks[1:]:
        lines = chunk.strip("\n").splitlines()
        if lines and lines[0].startswith("MSG:"):
            out[_key(lines[0][4:].strip())] = _fields("\n".join(lines[1:]))
    return out


def _key(name: str) -> str:
    return name.replace("/msg/", "/")


def definition_mismatch(name: str, text: str) -> str | None:
    """Why the log's definition ``text`` of message type ``name`` disagrees with the known
    one; None when it agrees or the type is not one replay knows."""
    known = contract.MESSAGE_DEFINITIONS.get(name)
    if known is None:
        return None
    ours = _sections(name, known)
    theirs = _sections(name, text)
    for section, fields in ours.items():
        got = theirs.get(section)
        if got is not None and got != fields:
            want = ", ".join(f"{t} {n}" for t, n in fields)
            have = ", ".join(f"{t} {n}" for t, n in got)
            return f"{section} declares ({have[:120]}), the ROS 2 definition ({want[:120]})"
    return None
