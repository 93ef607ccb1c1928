"""A real camera's calibration samples: where the ball was seen, and where it truly was.

One :class:`Sample` per sighting: the ball's centroid in the image (or its pixel radius and
image bearing, measured about a known centre), and its true range and direction from the
robot (robot frame: 0 deg forward, 90 deg left). They come from a measurements file
(:func:`read_measurements`) or from a log with the ball at a known place
(:mod:`replay.calibrate.from_log`).

The measurements file is CSV with a header row; ``#`` lines are comments::

    robot,u_px,v_px,range_m,angle_deg       (the centroid: centre and mounting are fitted)
    robot1,612.4,301.9,2.50,30.0
    ...
    robot,r_px,bearing_deg,range_m,angle_deg   (radius and image bearing about --centre)

``robot`` is optional (all rows then describe one camera, the file's ``default``). The file
is bounded (:data:`MAX_MEASUREMENT_BYTES`, :data:`MAX_ROWS`); a bad cell is one line naming
the file, the line and the column.
"""

from __future__ import annotations

import csv
import io
import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

from dsp.cameras import DEFAULT_ENTRY
from dsp.errors import InputError
from dsp.textfile import read_text_file

__all__ = ["MAX_MEASUREMENT_BYTES", "MAX_ROWS", "Measurements", "Sample", "read_measurements"]

MAX_MEASUREMENT_BYTES = 16 << 20
MAX_ROWS = 100_000
MAX_RANGE_M = 100.0

T = TypeVar("T")

_CENTROID = ("u_px", "v_px")
_RADIUS = ("r_px", "bearing_deg")
_TRUTH = ("range_m", "angle_deg")


@dataclass(frozen=True)
class Sample:
    """One sighting: the centroid (or radius and image bearing) and the ball's true range
    [m] and robot-frame direction [rad] (0 forward, +pi/2 left)."""

    range_m: float
    theta_rad: float
    u_px: float | None = None
    v_px: float | None = None
    r_px: float | None = None
    bearing_rad: float | None = None
    """The image bearing atan2(-du, -dv) about the centre the radius was measured from."""


@dataclass(frozen=True)
class Measurements:
    """Samples per robot (``default`` when the source names no robot) and their form."""

    samples: dict[str, list[Sample]]
    centroids: bool
    """True: centroids (u, v); False: radii and image bearings about a known centre."""
    source: str


class MeasurementError(InputError):
    """A measurements file that cannot be read: the message names the file and the line."""


def _number(where: str, column: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise MeasurementError(f"{where}: {column} = {text[:40]!r} is not a number") from None
    if not math.isfinite(value):
        raise MeasurementError(f"{where}: {column} = {text[:40]!r} is not a finite number")
    return value


def _row(where: str, row: dict[str, str], centroids: bool) -> Sample:
    d = _number(where, "range_m", row["range_m"])
    if not 0.0 < d <= MAX_RANGE_M:
        raise MeasurementError(f"{where}: range_m = {d:g} is not in (0, {MAX_RANGE_M:g}] m")
    theta = math.radians(_number(where, "angle_deg", row["angle_deg"]))
    if centroids:
        return Sample(d, theta, u_px=_number(where, "u_px", row["u_px"]),
                      v_px=_number(where, "v_px", row["v_px"]))
    r = _number(where, "r_px", row["r_px"])
    if r < 0.0:
        raise MeasurementError(f"{where}: r_px = {r:g} is negative")
    return Sample(d, theta, r_px=r, bearing_rad=math.radians(
        _number(where, "bearing_deg", row["bearing_deg"])))


def _csv_step(path: Path, where: str, step: Callable[[], T]) -> T:
    """``step()``, a read of the CSV reader, with its error (a cell over the csv module's
    field limit, 128 KiB; a NUL byte) as one line naming the file and the row."""
    try:
        return step()
    except csv.Error as err:
        raise MeasurementError(f"{path}: {where}: not CSV measurements ({err}; a cell holds "
                               "one number)") from None


def read_measurements(path: Path | str) -> Measurements:
    """The samples of a measurements file (see the module docstring)."""
    path = Path(path)
    text = read_text_file(path, MAX_MEASUREMENT_BYTES, what="a measurements file",
                          error=MeasurementError)
    lines = [line for line in text.splitlines()
             if line.strip() and not line.lstrip().startswith("#")]
    reader = csv.DictReader(io.StringIO("\n".join(lines)), skipinitialspace=True)
    columns = [c.strip() for c in _csv_step(path, "the header", lambda: reader.fieldnames) or []]
    reader.fieldnames = columns
    centroids = all(c in columns for c in _CENTROID)
    needed = (*(_CENTROID if centroids else _RADIUS), *_TRUTH)
    missing = [c for c in needed if c not in columns]
    if missing or len(set(columns)) != len(columns):
        raise MeasurementError(
            f"{path}: the header {','.join(columns) or '(none)'} lacks "
            f"{', '.join(missing) or 'nothing but repeats a column'}; give robot (optional), "
            "u_px, v_px (or r_px, bearing_deg), range_m, angle_deg")
    samples: dict[str, list[Sample]] = {}
    rows = iter(reader)
    for i in itertools.count(1):
        where = f"{path}: row {i}"
        row = _csv_step(path, f"row {i}", lambda: next(rows, None))
        if row is None:
            break
        if i > MAX_ROWS:
            raise MeasurementError(f"{path}: more than {MAX_ROWS} rows")
        if None in row or any(row.get(c) is None for c in needed):
            raise MeasurementError(f"{where}: {len([v for v in row.values() if v])} cells, "
                                   f"the header has {len(columns)}")
        robot = (row.get("robot") or "").strip() or DEFAULT_ENTRY
        samples.setdefault(robot, []).append(_row(where, row, centroids))
    if not samples:
        raise MeasurementError(f"{path}: no measurement rows under the header")
    return Measurements(samples, centroids, str(path))
