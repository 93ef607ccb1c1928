"""Pixel radius -> ground range calibration models, behind the :class:`Calibration` protocol.

A calibration maps the pixel radius r [px] of the ball's centroid (its distance from the
image centre) to the horizontal range d [m] from the robot's centre to the ball's centre:

- :class:`LinearCalibration` ``d = a r + b``, the paper's eq. 4 (:data:`PAPER_CALIBRATION`);
- :class:`LookupCalibration`, a monotone piecewise-linear table;
- :class:`MirrorCalibration` ``d = a tan(b r)``, NuBot's catadioptric mirror;
- :class:`CameraCalibration`, from a camera model with the ball-height correction.

Fitting them to samples is :mod:`estimator.calibration.fit`, their JSON form
:mod:`estimator.calibration.json_form`; :mod:`estimator.calibration` gathers all three.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from estimator.constants import BALL_RADIUS_M, PAPER_B_M, PAPER_K_M_PER_PX
from estimator.errors import CalibrationError, OutOfRangeError

__all__ = [
    "CALIBRATION_MODELS",
    "MAX_RADIUS_PX",
    "MAX_RANGE_M",
    "PAPER_CALIBRATION",
    "Calibration",
    "CameraCalibration",
    "CameraLike",
    "LinearCalibration",
    "LookupCalibration",
    "MirrorCalibration",
    "ranges_m",
]

MAX_RANGE_M = 1e4
"""The largest number of metres a calibration's parameter or table entry may hold: ten
kilometres is beyond any camera's view of a ball (and keeps every product in range)."""
MAX_RADIUS_PX = 1e5
"""The largest pixel radius a lookup table may list: beyond any camera's image."""

CALIBRATION_MODELS = ("linear", "lookup", "mirror", "camera")
"""The models' names: the ``"model"`` key of their dict form."""


@runtime_checkable
class Calibration(Protocol):
    """Pixel radius [px] -> ground range of the ball's centre [m]."""

    @property
    def name(self) -> str:
        """The model's name, the ``"model"`` key of its dict form."""
        ...

    def range_m(self, r_px: float) -> float:
        """Horizontal range [m] from the robot's centre to the ball's centre."""
        ...

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict with a ``"model"`` key, read back by calibration_from_dict."""
        ...


def _check_finite(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise CalibrationError(f"{name} = {value} is not finite; pass a finite number")
    return value


def _check_within(name: str, value: float, low: float, high: float) -> float:
    value = _check_finite(name, value)
    if not low <= value <= high:
        raise CalibrationError(f"{name} = {value:g} is outside [{low:g}, {high:g}]; no camera's "
                               "calibration holds such a number")
    return value


@dataclass(frozen=True)
class LinearCalibration:
    """``d = a r + b``, the paper's eq. 4 (its own fit is :data:`PAPER_CALIBRATION`)."""

    a_m_per_px: float
    b_m: float

    def __post_init__(self) -> None:
        _check_within("a_m_per_px", self.a_m_per_px, -MAX_RANGE_M, MAX_RANGE_M)
        _check_within("b_m", self.b_m, -MAX_RANGE_M, MAX_RANGE_M)

    @property
    def name(self) -> str:
        return "linear"

    def range_m(self, r_px: float) -> float:
        return self.a_m_per_px * r_px + self.b_m  # eq. 4

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.name, "a_m_per_px": self.a_m_per_px, "b_m": self.b_m}


PAPER_CALIBRATION = LinearCalibration(a_m_per_px=PAPER_K_M_PER_PX, b_m=PAPER_B_M)
"""The paper's eq. 4: d = 0.0163 r + 0.2786 (R^2 = 0.9932)."""


@dataclass(frozen=True)
class LookupCalibration:
    """A monotone piecewise-linear table r_px -> d_m.

    ``r_px`` must be strictly increasing and ``d_m`` non-decreasing (a ball further out in
    the image is never nearer), at least two points. Between points the range is linearly
    interpolated; outside the table it is linearly EXTRAPOLATED along the first or last
    segment (so a ball slightly beyond the calibrated span still gets a sensible range).
    """

    r_px: tuple[float, ...]
    d_m: tuple[float, ...]

    def __post_init__(self) -> None:
        r = tuple(_check_within("r_px", v, 0.0, MAX_RADIUS_PX) for v in self.r_px)
        d = tuple(_check_within("d_m", v, -MAX_RANGE_M, MAX_RANGE_M) for v in self.d_m)
        if len(r) != len(d) or len(r) < 2:
            raise CalibrationError(
                f"lookup table has {len(r)} radii and {len(d)} ranges; "
                "pass two equally long sequences of at least 2 points"
            )
        for i in range(1, len(r)):
            if not r[i] > r[i - 1]:
                raise CalibrationError(
                    f"lookup r_px is not strictly increasing at index {i} "
                    f"({r[i - 1]} then {r[i]}); sort the table and pool duplicates "
                    "(fit_lookup does both)"
                )
            if d[i] < d[i - 1]:
                raise CalibrationError(
                    f"lookup d_m decreases at index {i} ({d[i - 1]} then {d[i]}); "
                    "the range must be non-decreasing in r (fit_lookup enforces it)"
                )
        object.__setattr__(self, "r_px", r)
        object.__setattr__(self, "d_m", d)

    @property
    def name(self) -> str:
        return "lookup"

    @functools.cached_property
    def _arrays(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """The table as arrays, made once: np.interp converting the tuples on every call
        made a fit's n calls on its n-point table O(n^2)."""
        return np.asarray(self.r_px, dtype=np.float64), np.asarray(self.d_m, dtype=np.float64)

    def range_m(self, r_px: float) -> float:
        r, d = self.r_px, self.d_m
        if r_px <= r[0]:  # linear extrapolation along the first segment
            return d[0] + (r_px - r[0]) * (d[1] - d[0]) / (r[1] - r[0])
        if r_px >= r[-1]:  # linear extrapolation along the last segment
            return d[-1] + (r_px - r[-1]) * (d[-1] - d[-2]) / (r[-1] - r[-2])
        return float(np.interp(r_px, *self._arrays))

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.name, "r_px": list(self.r_px), "d_m": list(self.d_m)}


@dataclass(frozen=True)
class MirrorCalibration:
    """``d = a tan(b r)``: NuBot's catadioptric mirror (e.g. a = 1.569 m, b = 0.007088).

    Defined for 0 <= b r < pi/2 (the horizon); beyond it :meth:`range_m` raises
    :class:`OutOfRangeError`.
    """

    a_m: float
    b_rad_per_px: float

    def __post_init__(self) -> None:
        _check_within("a_m", self.a_m, -MAX_RANGE_M, MAX_RANGE_M)
        if _check_within("b_rad_per_px", self.b_rad_per_px, -math.pi, math.pi) <= 0.0:
            raise CalibrationError(
                f"b_rad_per_px = {self.b_rad_per_px} must be > 0 (d = a tan(b r))"
            )

    @property
    def name(self) -> str:
        return "mirror"

    def range_m(self, r_px: float) -> float:
        angle = self.b_rad_per_px * r_px
        if not abs(angle) < math.pi / 2.0:
            raise OutOfRangeError(
                f"r_px = {r_px} is at or beyond the mirror's horizon "
                f"r = pi / (2 b) = {math.pi / (2.0 * self.b_rad_per_px):.1f} px; "
                "reject detections that far out or refit the calibration"
            )
        return self.a_m * math.tan(angle)

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.name, "a_m": self.a_m, "b_rad_per_px": self.b_rad_per_px}


class CameraLike(Protocol):
    """The two members of ``estimator.camera.CameraModel`` a CameraCalibration needs."""

    @property
    def height_m(self) -> float:
        """Optical centre above the ground [m]."""
        ...

    def nadir_angle_rad(self, r_px: float) -> npt.ArrayLike:
        """Angle between the pixel's ray and straight down [rad] (a float or 0-d array;
        NaN where the pixel sees no ground)."""
        ...


@dataclass(frozen=True)
class CameraCalibration:
    """Range of the ball's CENTRE from a camera model: the ball-height correction.

    The ray through the ball's centroid meets the plane z = ball_radius_m (the height of
    the ball's centre), not the ground, so with h the camera height and phi the ray's
    nadir angle::

        d = (h - ball_radius_m) * tan(phi(r))

    (NuBot's ``range * (h - r_ball) / h`` correction, written for a ray.) Raises
    :class:`OutOfRangeError` at or above the horizon (phi >= pi/2).
    """

    camera: CameraLike
    ball_radius_m: float = BALL_RADIUS_M

    def __post_init__(self) -> None:
        radius = _check_finite("ball_radius_m", self.ball_radius_m)
        height = float(self.camera.height_m)
        if not radius < height:
            raise CalibrationError(
                f"ball_radius_m = {radius} is not below the camera height {height} m; "
                "the camera must look down on the ball's centre"
            )

    @property
    def name(self) -> str:
        return "camera"

    def range_m(self, r_px: float) -> float:
        phi = float(np.asarray(self.camera.nadir_angle_rad(r_px), dtype=np.float64))
        if not phi < math.pi / 2.0:  # NaN (no ground) fails this test too
            raise OutOfRangeError(
                f"r_px = {r_px} looks {math.degrees(phi):.1f} deg from nadir (NaN: outside the "
                "camera's image), at or above the horizon; reject detections that far out"
            )
        return (self.camera.height_m - self.ball_radius_m) * math.tan(phi)

    def to_dict(self) -> dict[str, Any]:
        to_dict: Callable[[], dict[str, Any]] | None = getattr(self.camera, "to_dict", None)
        if to_dict is None:
            raise CalibrationError(
                f"camera {self.camera!r} has no to_dict(); use an estimator.camera model "
                "to serialise a CameraCalibration"
            )
        return {"model": self.name, "camera": to_dict(), "ball_radius_m": self.ball_radius_m}


def ranges_m(model: Calibration, r_px: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """``model.range_m`` of each radius, NaN where the model has no range (beyond a horizon):
    a curve to draw or residuals to take."""
    radii = np.asarray(r_px, dtype=np.float64)
    out = np.full(radii.shape, np.nan)
    for i, ri in np.ndenumerate(radii):
        try:
            out[i] = float(model.range_m(float(ri)))
        except CalibrationError:
            pass
    return out
