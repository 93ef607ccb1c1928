"""A camera file's ``field`` key: the field the robots play on, by name or by its dimensions.

A log that names no field (a team's own bag) gets its poses corrected from the field lines
when its camera file names one (:mod:`dsp.camera_file`); ``dsp-calibrate --field`` writes the
key. A bad value is a :class:`FieldDescriptionError`: one line naming the file (or the option)
and the key, exit 2 (a field is the user's statement about the replay, as an option's value
is), where a bad camera entry exits 1.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

from dsp.cameras import FIELD_KEY, MAX_FIELD_SIDE_M, CameraDescriptionError
from dsp.errors import EXIT_USAGE
from dsp.field import FIELD_ALIASES, FIELDS, FieldSpec

__all__ = ["FieldDescriptionError", "field_from_json"]


class FieldDescriptionError(CameraDescriptionError):
    """A camera file's (or ``--field``'s) field that is no field: unknown name, impossible
    dimensions. Exit 2."""

    exit_code = EXIT_USAGE


def _fail(where: str, key: str, text: str) -> FieldDescriptionError:
    return FieldDescriptionError(f"{where}.{key} {text}")


_FIELD_REQUIRED = ("length_m", "width_m", "goal_area_depth_m", "goal_area_half_width_m",
                   "penalty_area_depth_m", "penalty_area_half_width_m")
"""The keys a field given by its dimensions needs (those :class:`~dsp.field.FieldSpec`
has no default for); the others take FieldSpec's defaults (the MSL rules')."""
_FIELD_KEYS = tuple(f.name for f in dataclasses.fields(FieldSpec) if f.name != "name")


def _field_size(where: str, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _fail(where, key, f"= {value!r} is not a number (metres)")
    if not math.isfinite(value):
        raise _fail(where, key, f"= {value!r} is not a finite number")
    if key == "border_m" and value < 0.0:
        raise _fail(where, key, f"= {value:g} must be >= 0")
    if key != "border_m" and not value > 0.0:
        raise _fail(where, key, f"= {value:g} must be > 0")
    if value > MAX_FIELD_SIDE_M:
        raise _fail(where, key, f"= {value:g} is out of range: a field's sizes are at most "
                    f"{MAX_FIELD_SIDE_M:g} m (an MSL field is 22 m long)")
    return float(value)


def _field_names() -> str:
    return ", ".join([*FIELDS, *(f"{a} (= {n})" for a, n in FIELD_ALIASES.items())])


def field_from_json(value: Any, source: str) -> FieldSpec:
    """A camera file's ``field``: a name of :data:`dsp.field.FIELDS` (or an alias,
    :data:`dsp.field.FIELD_ALIASES`), or an object of dimensions (the keys of
    :class:`~dsp.field.FieldSpec`: :data:`_FIELD_REQUIRED` required, the others FieldSpec's
    defaults). Raises :class:`FieldDescriptionError` naming ``source`` and the key."""
    if isinstance(value, str):
        name = FIELD_ALIASES.get(value.strip().lower(), value.strip().lower())
        if name not in FIELDS:
            raise FieldDescriptionError(
                f"{source}: {FIELD_KEY} = {value!r} is not a field's name (known: "
                f"{_field_names()}); or give its dimensions: {{{', '.join(_FIELD_REQUIRED)}}}")
        return FIELDS[name]
    where = f"{source}: {FIELD_KEY}"
    if value is None:
        raise FieldDescriptionError(f"{where} is empty: name the field ({_field_names()}) "
                                     "or give its dimensions")
    if not isinstance(value, Mapping):
        raise FieldDescriptionError(
            f"{where} = {value!r} is neither a field's name ({_field_names()}) nor an object "
            "of its dimensions")
    unknown = [k for k in value if k not in _FIELD_KEYS]
    if unknown:
        raise _fail(where, str(unknown[0]), f"is not a key of a field (keys: "
                    f"{', '.join(_FIELD_KEYS)})")
    m = {k: _field_size(where, k, v) for k, v in value.items()}
    missing = [k for k in _FIELD_REQUIRED if k not in m]
    if missing:
        raise _fail(where, missing[0], f"is missing: a field given by its dimensions needs "
                    f"{', '.join(_FIELD_REQUIRED)} (or give its name: {_field_names()})")
    half_length, half_width = m["length_m"] / 2.0, m["width_m"] / 2.0
    within = (  # (key, its largest value, said as): the markings inside the field
        ("width_m", m["length_m"], f"length_m ({m['length_m']:g}): the length runs from "
         "goal to goal"),
        ("penalty_area_depth_m", half_length, f"half the length ({half_length:g})"),
        ("penalty_area_half_width_m", half_width, f"half the width ({half_width:g})"),
        ("goal_area_depth_m", m["penalty_area_depth_m"],
         f"penalty_area_depth_m ({m['penalty_area_depth_m']:g}): the goal area lies in the "
         "penalty area"),
        ("goal_area_half_width_m", m["penalty_area_half_width_m"],
         f"penalty_area_half_width_m ({m['penalty_area_half_width_m']:g}): the goal area "
         "lies in the penalty area"),
        ("centre_circle_radius_m", half_width, f"half the width ({half_width:g})"),
        ("penalty_mark_distance_m", half_length, f"half the length ({half_length:g})"),
        ("goal_half_width_m", half_width, f"half the width ({half_width:g})"),
        ("line_width_m", 1.0, "1 m"),
        ("spot_radius_m", 1.0, "1 m"),
    )
    for key, largest, what in within:
        if key in m and m[key] > largest:
            raise _fail(where, key, f"= {m[key]:g} must be at most {what}")
    size = f"{m['length_m']:g}x{m['width_m']:g}"
    named = FIELDS.get(size)
    spec = FieldSpec(name=size, **m)
    return named if named == spec else dataclasses.replace(spec, name=f"{size} (described)")
