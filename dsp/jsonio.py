"""Strict JSON out, bounded JSON in.

:func:`loads` is how every JSON a user or a log supplies is parsed: nesting deeper than
:data:`MAX_DEPTH` (Python's parser recurses: a RecursionError, a traceback of thousands of
lines) and numbers longer than :data:`MAX_INT_DIGITS` digits (Python refuses to convert such
integers with a ValueError of its own, after a long time for the longest) are refused, as a
:class:`JsonLimitError` (a ``ValueError``, as :func:`json.loads`'s own errors are), before
or while parsing, each in a few words a one-line message can hold.


Python's :func:`json.dumps` writes ``NaN`` and ``Infinity`` by default, which JSON does not
have (strict parsers, ``jq``, browsers refuse the file). :func:`finite` turns every
non-finite float into ``null``; :func:`dumps` does that and then dumps with
``allow_nan=False``, so a stray one is an error here and never a bad file. :data:`Json` is the
type of what JSON holds, for the documents the commands write.
"""

from __future__ import annotations

import itertools
import json
import math
import operator
from collections.abc import Iterator, Mapping, Sequence
from typing import Any, TypeAlias

__all__ = ["MAX_DEPTH", "MAX_INT_DIGITS", "Json", "JsonLimitError", "check_limits", "dumps",
           "finite", "loads"]

MAX_DEPTH = 64
"""The deepest nesting of arrays and objects a JSON input may have (the project's files
nest 5 deep at most)."""
MAX_INT_DIGITS = 100
"""The longest run of digits a JSON number may hold (a 64-bit integer has 20, a float's
shortest form 17)."""

Json: TypeAlias = "bool | int | float | str | Sequence[Json] | Mapping[str, Json] | None"
"""A JSON value, as the documents the commands write hold them (any sequence is an array,
any mapping with string keys an object)."""


def finite(value: Any) -> Any:
    """``value`` with every non-finite float (also in dicts, lists, tuples, numpy scalars)
    replaced by None."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):  # numpy scalar
        return finite(value.item())
    return value


def dumps(value: Any, **kwargs: Any) -> str:
    """:func:`json.dumps` of :func:`finite` ``(value)`` with ``allow_nan=False``."""
    return json.dumps(finite(value), allow_nan=False, **kwargs)


class JsonLimitError(ValueError):
    """A JSON text nests too deep or holds too long a number."""


_ALL_BYTES = bytes(range(256))
_NOT_BRACKETS = _ALL_BYTES.translate(None, b"[]{}")
_BRACKET_STEPS = bytes.maketrans(b"[{]}", b"\x02\x02\x00\x00")
_DIGITS = bytes(ord("1") if chr(b) in "0123456789" else ord(" ") for b in range(256))


CHUNK_CHARS = 1 << 20
"""The checks walk the text in pieces of about this many characters, so what they hold
beside it stays small whatever its size."""


def _pieces(text: str) -> Iterator[str]:
    """``text`` in pieces of about :data:`CHUNK_CHARS`, never cut after a backslash (an
    escape stays whole) nor inside a run of digits."""
    start, n = 0, len(text)
    while start < n:
        end = min(start + CHUNK_CHARS, n)
        while end < n and (text[end - 1] == "\\"
                           or (text[end - 1].isdigit() and text[end].isdigit())):
            end += 1
        yield text[start:end]
        start = end


def check_limits(text: str, max_depth: int = MAX_DEPTH) -> None:
    """Refuse ``text`` when its arrays and objects nest deeper than ``max_depth`` or a
    number in it runs to more than :data:`MAX_INT_DIGITS` digits (what is inside strings
    does not count); linear, no recursion, piece by piece (:func:`_pieces`)."""
    in_string = False
    depth = deepest = 0
    run = b"1" * (MAX_INT_DIGITS + 1)
    for piece in _pieces(text):
        # escaped backslashes, then escaped quotes, dropped; the quotes left delimit strings
        parts = piece.replace("\\\\", "").replace('\\"', "").split('"')
        outside = "".join(parts[1::2] if in_string else parts[::2]).encode(
            "utf-8", "surrogatepass")
        if (len(parts) - 1) % 2:
            in_string = not in_string
        steps = outside.translate(_BRACKET_STEPS, _NOT_BRACKETS)  # "[" "{" -> 2, "]" "}" -> 0
        if steps:
            # the depth after the i-th bracket is the steps' sum so far, less i
            deepest = max(deepest, depth + max(map(operator.sub, itertools.accumulate(steps),
                                                   itertools.count(1))))
            depth += sum(steps) - len(steps)
        if deepest > max_depth:
            raise JsonLimitError(f"nested {deepest} levels deep (at most {max_depth})")
        if run in outside.translate(_DIGITS):
            raise JsonLimitError(f"a number of more than {MAX_INT_DIGITS} digits")


def loads(text: str | bytes, *, max_depth: int = MAX_DEPTH, **kwargs: Any) -> Any:
    """:func:`json.loads` with the limits above; ``kwargs`` go to it. Raises
    ``ValueError`` (:class:`json.JSONDecodeError` or :class:`JsonLimitError`) for text that
    is not JSON or is beyond the limits, and ``TypeError`` for what is not text."""
    if isinstance(text, (bytes, bytearray)):
        text = bytes(text).decode("utf-8")
    if not isinstance(text, str):
        raise TypeError(f"JSON text is a {type(text).__name__}, not text")
    check_limits(text, max_depth)
    try:
        return json.loads(text, **kwargs)
    except RecursionError as err:  # pragma: no cover - the depth check comes first
        raise JsonLimitError(f"nested too deep ({err})") from None
