"""Strict JSON out: what the commands write parses in every JSON parser.

Python's :func:`json.dumps` writes ``NaN`` and ``Infinity`` by default, which JSON does not
have (strict parsers, ``jq``, browsers refuse the file). :func:`finite` turns every
non-finite float into ``null``; :func:`dumps` does that and then dumps with
``allow_nan=False``, so a stray one is an error here and never a bad file. :data:`Json` is the
type of what JSON holds, for the documents the commands write.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from typing import Any, TypeAlias

__all__ = ["Json", "dumps", "finite"]

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
