"""A camera model from a range calibration and the camera's height: what a ``lookup`` camera
becomes when its height is known.

A team's camera file gives a ``lookup`` camera: a calibration that turns a ball's pixel
radius into its range (a table, a line, a mirror law; :mod:`estimator.calibration`). That is
a projection model in all but name: the ball's centre, ``BALL_RADIUS_M`` above the floor,
seen at range d from an optical centre ``height_m`` up, lies on the ray of nadir angle

    n(r) = atan2(d(r), height_m - BALL_RADIUS_M)

so, the camera's height given, every pixel radius has a ray (the camera is radially
symmetric about its centre pixel, as every model here). :class:`TableCamera` samples n(r)
once, every ``step_px`` from the calibration's first radius to the image circle's, and
interpolates it both ways (pixel -> ray, ray -> pixel): it is a
:class:`~estimator.camera.CameraModel`, so the field-line fit, the crossed rays of the 3-D
track and the ball's expected size work with it as with the parametric models. Outside the
sampled radii it has no ray (NaN), never an extrapolation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from estimator.calibration import Calibration
from estimator.camera import FloatArray, _RadialCamera
from estimator.constants import BALL_RADIUS_M
from estimator.errors import OutOfRangeError

__all__ = ["TableCamera", "table_camera"]

STEP_PX = 0.5
"""Pixel-radius step of the sampled law: well inside a pixel, and a few thousand samples."""


@dataclass(frozen=True)
class TableCamera(_RadialCamera):
    """A radially symmetric camera given by samples of its law: nadir angle at pixel radius."""

    r_px: tuple[float, ...] = ()
    """Increasing pixel radii."""
    nadir_rad: tuple[float, ...] = ()
    """The nadir angle at each radius, increasing."""
    name: str = "lookup"

    def __post_init__(self) -> None:
        r, n = np.asarray(self.r_px, np.float64), np.asarray(self.nadir_rad, np.float64)
        if len(r) < 2 or len(r) != len(n) or not (np.all(np.diff(r) > 0)
                                                   and np.all(np.diff(n) > 0)):
            raise ValueError("a table camera needs at least two radii and nadir angles, "
                             "both increasing")
        if not (n[0] >= 0.0 and n[-1] < math.pi / 2):
            raise ValueError(f"nadir angles {n[0]:.3f}..{n[-1]:.3f} rad: a camera looking "
                             "down sees between 0 and pi/2")

    def nadir_angle_rad(self, r_px: ArrayLike) -> FloatArray:
        r = np.asarray(r_px, dtype=np.float64)
        table_r, table_n = np.asarray(self.r_px), np.asarray(self.nadir_rad)
        out = np.interp(r, table_r, table_n)
        return np.where((r >= table_r[0]) & (r <= table_r[-1]), out, np.nan)

    def radius_px(self, nadir_angle_rad: ArrayLike) -> FloatArray:
        n = np.asarray(nadir_angle_rad, dtype=np.float64)
        table_r, table_n = np.asarray(self.r_px), np.asarray(self.nadir_rad)
        out = np.interp(n, table_n, table_r)
        return np.where((n >= table_n[0]) & (n <= table_n[-1]), out, np.nan)

    def to_dict(self) -> dict[str, Any]:
        d = super().to_dict()
        d.update(r_px=list(self.r_px), nadir_rad=list(self.nadir_rad))
        return d


def _range(calibration: Calibration, r: float) -> float:
    try:
        return calibration.range_m(r)
    except OutOfRangeError:
        return math.nan


def table_camera(calibration: Calibration, *, height_m: float, width_px: int, height_px: int,
                 centre_px: tuple[float, float], max_radius_px: float,
                 step_px: float = STEP_PX) -> TableCamera:
    """The camera whose ball ranges are ``calibration``'s, its optical centre ``height_m``
    above the floor (module docstring). Radii from the calibration's first (a table's first
    entry, else 0) to ``max_radius_px``, from the first with a range to the next without
    one (a mirror's horizon); samples where the range stays level are left out. Raises
    ValueError when the camera is too low to see a ball (``height_m`` <= the ball's radius)
    or the law gives under two rising samples."""
    if not height_m > BALL_RADIUS_M:
        raise ValueError(f"height_m = {height_m:g} m: the camera must be above the ball's "
                         f"centre ({BALL_RADIUS_M:g} m)")
    first = float(getattr(calibration, "r_px", (0.0,))[0])
    radii = np.arange(first, max_radius_px + step_px / 2, step_px)
    nadir = np.array([math.atan2(_range(calibration, float(r)), height_m - BALL_RADIUS_M)
                      for r in radii])
    ok = np.isfinite(nadir) & (nadir >= 0.0)
    if not ok.any():
        raise ValueError("the calibration gives no range over the image's radii")
    start = int(np.argmax(ok))  # the first radius with a ray
    gaps = np.flatnonzero(~ok[start:])
    end = start + int(gaps[0]) if len(gaps) else len(radii)  # up to the first without one
    r, n = radii[start:end], nadir[start:end]
    # a range that stays level (a table's flat stretch) gives no new ray: keep the samples
    # that rise above every one before them, so the law is strictly increasing both ways
    before = np.maximum.accumulate(np.concatenate([[-np.inf], n[:-1]]))
    r, n = r[n > before], n[n > before]
    if len(r) < 2:
        raise ValueError("the calibration gives no rising range over the image's radii")
    return TableCamera(width_px=width_px, height_px=height_px, cu_px=centre_px[0],
                       cv_px=centre_px[1], max_radius_px=float(r[-1]), height_m=height_m,
                       r_px=tuple(float(v) for v in r), nadir_rad=tuple(float(v) for v in n))
