"""Camera files (``--cameras cameras.yaml`` or ``.json``): read safely, written plainly.

The file holds the entries of :mod:`dsp.cameras` (the schema of a log's ``dsp.cameras``
metadata) under robot names, or one ``default`` entry for every robot::

    default:
      model: lookup
      width_px: 1280
      height_px: 1024
      cu_px: 640.0
      cv_px: 512.0
      calibration: {model: mirror, a_m: 1.04, b_rad_per_px: 0.002856}
    robot2:
      mount_yaw_deg: 90.0      # robot2's camera is turned; the rest as the default
    field: 18x12               # optional: the field played on (its name, or dimensions)

Reading is bounded and safe: the path must be a regular file of at most
:data:`MAX_CAMERA_FILE_BYTES`, UTF-8. JSON is parsed strictly (no NaN, no repeated key).
YAML goes through PyYAML's safe loader only (plain data, no Python objects), narrowed
further: no anchors or aliases (no "billion laughs"), no repeated key, string keys, at most
:data:`MAX_DEPTH` levels, and only JSON's values (a date or a ``!!binary`` is refused).
So a YAML file and a JSON file with the same content read the same. A ``ball`` given as a
relative path is resolved against the camera file's folder.

The top-level ``field`` key is not a robot: it names the field the robots play on
(:func:`dsp.field_file.field_from_json`: a name of :data:`dsp.field.FIELDS`, ``msl`` for the
current MSL field, or the dimensions), so that a log that names none (a team's own bag) gets
its poses corrected from the field lines. A file that names the field may describe no camera
(the log's metadata describes them).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from dsp import jsonio
from dsp.cameras import (
    DEFAULT_ENTRY,
    FIELD_KEY,
    CameraDescriptionError,
    CameraSet,
    camera_set_from_json,
)
from dsp.field_file import field_from_json
from dsp.jsonio import dumps as strict_json
from dsp.textfile import read_text_file

__all__ = ["CAMERA_FILE_SUFFIXES", "MAX_CAMERA_FILE_BYTES", "MAX_DEPTH", "camera_file_text",
           "load_camera_document", "read_camera_file"]

CAMERA_FILE_SUFFIXES = (".yaml", ".yml", ".json")
MAX_CAMERA_FILE_BYTES = 1 << 20
"""1 MiB: a camera file describes a few cameras (a lookup table of 1000 points is 30 KiB)."""
MAX_DEPTH = 16


class _Loader(yaml.SafeLoader):
    """PyYAML's safe loader without aliases and repeated keys."""

    _depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.AliasEvent):
            raise yaml.YAMLError("an alias (*name); write the value out instead")
        if self._depth > MAX_DEPTH:  # before the composer's recursion goes any deeper
            raise yaml.YAMLError(f"nested deeper than {MAX_DEPTH} levels")
        self._depth += 1
        try:
            node = super().compose_node(parent, index)
        finally:
            self._depth -= 1
        if self.anchors:
            line = "" if node is None else f"line {node.start_mark.line + 1}: "
            raise yaml.YAMLError(f"{line}an anchor (&name); write values out instead")
        return node

    def construct_mapping(self, node: Any, deep: bool = False) -> Any:
        seen: set[Any] = set()
        for key_node, _value in node.value:
            key = self.construct_object(key_node, deep=deep)
            if key in seen:
                raise yaml.YAMLError(f"line {key_node.start_mark.line + 1}: the key {key!r} "
                                     "is given twice")
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


# YAML 1.2 floats too: PyYAML (YAML 1.1) would read 1e-3 as text
_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."))


def _plain(value: Any, where: str, depth: int = 0) -> Any:
    """``value`` if it holds JSON values only (string keys), else an error naming where."""
    if depth > MAX_DEPTH:
        raise CameraDescriptionError(f"{where}: nested deeper than {MAX_DEPTH} levels")
    if isinstance(value, dict):
        for key, item in value.items():
            if not isinstance(key, str):
                raise CameraDescriptionError(f"{where}: the key {key!r} is not a string")
            _plain(item, f"{where}.{key}" if depth else f"{where}: {key}", depth + 1)
        return value
    if isinstance(value, list):
        for i, item in enumerate(value):
            _plain(item, f"{where}[{i}]", depth + 1)
        return value
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    raise CameraDescriptionError(f"{where}: {type(value).__name__} value {str(value)[:40]!r} "
                                 "is not a number, string, list or object")


def _json_pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise ValueError(f"the key {key!r} is given twice")
        out[key] = value
    return out


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a JSON number")


def load_camera_document(text: str, suffix: str, source: str) -> Any:
    """The document in ``text`` (YAML or JSON by ``suffix``) as JSON values."""
    try:
        if suffix == ".json":
            doc = jsonio.loads(text, object_pairs_hook=_json_pairs,
                               parse_constant=_no_constant)
        else:
            doc = yaml.load(text, Loader=_Loader)  # the safe loader, narrowed (above)
    except (ValueError, yaml.YAMLError, RecursionError) as err:
        detail = " ".join(str(err).split())[:200]
        raise CameraDescriptionError(f"{source}: not valid {suffix.lstrip('.').upper()}: "
                                     f"{detail}") from err
    return _plain(doc, source)


def read_camera_file(path: Path | str) -> CameraSet:
    """The cameras a camera file describes. Raises :class:`CameraDescriptionError` (one line
    naming the file, and the field where one is wrong)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in CAMERA_FILE_SUFFIXES:
        raise CameraDescriptionError(f"{path}: a camera file ends in "
                                     f"{', '.join(CAMERA_FILE_SUFFIXES)}")
    text = read_text_file(path, MAX_CAMERA_FILE_BYTES, what="a camera file",
                          error=CameraDescriptionError)
    doc = load_camera_document(text, suffix, str(path))
    field = None
    if isinstance(doc, dict):
        if FIELD_KEY in doc:
            field = field_from_json(doc[FIELD_KEY], str(path))
        doc = {name: _resolve_ball(entry, path.parent) for name, entry in doc.items()
               if name != FIELD_KEY}
    return camera_set_from_json(doc, str(path), field=field)


def _resolve_ball(entry: Any, folder: Path) -> Any:
    """The entry with a relative ``ball`` path made relative to the camera file's folder."""
    if isinstance(entry, dict) and isinstance(entry.get("ball"), str) and entry["ball"].strip():
        ball = Path(entry["ball"])
        if not ball.is_absolute():
            return {**entry, "ball": str(folder / ball)}
    return entry


def _yaml_scalar(value: Any) -> str:
    """A JSON value as YAML flow text (JSON is YAML; floats keep their repr)."""
    if isinstance(value, float) and math.isfinite(value):
        return repr(value)
    return strict_json(value, sort_keys=False)


def _yaml_name(name: str) -> str:
    """A name as YAML: bare (``18x12``) where YAML reads it back as that text, else quoted."""
    try:
        if re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9_.-]*", name) and yaml.load(
                name, Loader=_Loader) == name:
            return name
    except yaml.YAMLError:
        pass
    return _yaml_scalar(name)


def camera_file_text(entries: Mapping[str, Mapping[str, Any]], suffix: str,
                     comments: Mapping[str, str] | None = None, header: str = "", *,
                     field: str | Mapping[str, float] | None = None,
                     field_comment: str = "") -> str:
    """A camera file of ``entries`` (name -> entry) as YAML (block style, ``comments`` after
    the keys they name, ``header`` lines first) or JSON (sorted keys, no comments). ``field``:
    the file's ``field`` key (a name or dimensions), first; YAML only: ``field_comment`` after
    it, or, with no ``field``, as a comment line of its own."""
    if suffix == ".json":
        doc: dict[str, Any] = dict(entries)
        if field is not None:
            doc[FIELD_KEY] = field
        return strict_json(doc, sort_keys=True, indent=2) + "\n"
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    if field is not None:
        value = _yaml_name(field) if isinstance(field, str) else _yaml_scalar(dict(field))
        line = f"{FIELD_KEY}: {value}"
        lines.append(f"{line}  # {field_comment}" if field_comment else line)
    elif field_comment:
        lines.append(f"# {field_comment}")
    comments = comments or {}
    order = sorted(entries, key=lambda n: (n != DEFAULT_ENTRY, n))
    for name in order:
        lines.append(f"{name}:")
        for key, value in entries[name].items():
            note = comments.get(key)
            line = f"  {key}: {_yaml_scalar(value)}"
            lines.append(f"{line}  # {note}" if note else line)
    return "\n".join(lines) + "\n"
