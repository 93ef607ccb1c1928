"""A real camera's description fitted to its samples: centre, mounting, range calibration.

For each robot (:func:`fit_camera`):

1. the image centre and the mounting rotation, when the samples are centroids seen in
   enough directions around the robot: the centre first from the lines of the balls'
   directions (:func:`estimator.calibration.fit_centre_and_mount`), then moved to where the
   radii fit the ranges best (:func:`~estimator.calibration.fit_centre_to_ranges`: far out a
   pixel is centimetres, sharper than a measured direction), the mounting about it
   (:func:`~estimator.calibration.fit_mount`); otherwise the mounting alone about the
   centre given;
2. each sample's pixel radius about that centre, and every calibration model fitted to
   (radius, range) and ranked on held-out samples (:func:`estimator.calibration.fit_all`:
   the same rule as the simulated procedure);
3. the camera file's entry (:mod:`dsp.cameras`): a ``lookup`` camera with the best model as
   its calibration (and its fit), the centre, the mounting, a usable radius just past the
   farthest sample (the calibration says nothing beyond it), and the poses' frame.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from dsp.errors import InputError
from estimator.calibration import (
    CentreFit,
    FitResult,
    fit_all,
    fit_centre_and_mount,
    fit_centre_to_ranges,
    fit_mount,
)
from estimator.errors import CalibrationError
from replay.calibrate.measurements import Sample

__all__ = ["MIN_SAMPLES", "USABLE_MARGIN", "CameraFit", "fit_camera"]

MIN_SAMPLES = 6
USABLE_MARGIN = 1.05
"""The usable radius: the farthest sample's radius times this."""


@dataclass(frozen=True)
class CameraFit:
    """One robot's fitted camera."""

    robot: str
    centre: CentreFit
    fits: tuple[FitResult, ...]
    """Every model, best (lowest held-out RMS) first."""
    r_px: tuple[float, ...]
    range_m: tuple[float, ...]
    width_px: int
    height_px: int
    usable_radius_px: float

    @property
    def best(self) -> FitResult:
        return self.fits[0]

    def entry(self, map_to_field: tuple[float, float, float] | None = None) -> dict[str, Any]:
        """The camera file's entry for this camera."""
        fit = self.best
        calibration: dict[str, Any] = {**fit.model.to_dict(), "fit": {
            "r2": round(fit.r2, 6), "rms_m": round(fit.rms_m, 6),
            "max_abs_m": round(fit.max_abs_m, 6), "n": fit.n,
            **({"holdout_rms_m": round(fit.holdout_rms_m, 6)}
               if fit.holdout_rms_m is not None else {})}}
        out: dict[str, Any] = {
            "model": "lookup", "width_px": self.width_px, "height_px": self.height_px,
            "cu_px": round(self.centre.cu_px, 3), "cv_px": round(self.centre.cv_px, 3),
            "usable_radius_px": round(self.usable_radius_px, 1),
            "mount_yaw_deg": round(math.degrees(self.centre.mount_yaw_rad), 4),
            "calibration": calibration,
        }
        if map_to_field is not None:
            x, y, yaw = map_to_field
            out["map_to_field"] = {"x_m": x, "y_m": y, "yaw_deg": yaw}
        return out


def _centre(robot: str, samples: Sequence[Sample], centroids: bool,
            centre_px: tuple[float, float] | None) -> CentreFit:
    theta = [s.theta_rad for s in samples]
    if not centroids:  # radii and image bearings about the given centre
        if centre_px is None:
            raise InputError(f"{robot}: radii and bearings were measured about a centre; give "
                             "it (--centre CU,CV)")
        u = [centre_px[0] - (s.r_px or 0.0) * math.sin(s.bearing_rad or 0.0) for s in samples]
        v = [centre_px[1] - (s.r_px or 0.0) * math.cos(s.bearing_rad or 0.0) for s in samples]
        return fit_mount(u, v, theta, centre_px)
    u = [s.u_px or 0.0 for s in samples]
    v = [s.v_px or 0.0 for s in samples]
    if centre_px is not None:
        return fit_mount(u, v, theta, centre_px)
    try:
        lines = fit_centre_and_mount(u, v, theta)
        cu, cv, _rms = fit_centre_to_ranges(u, v, [s.range_m for s in samples],
                                            (lines.cu_px, lines.cv_px))
    except CalibrationError as err:
        raise InputError(f"{robot}: {err} (--centre CU,CV)") from err
    return replace(fit_mount(u, v, theta, (cu, cv)), centre_fitted=True)


def fit_camera(robot: str, samples: Sequence[Sample], *, centroids: bool,
               image_size_px: tuple[int, int], centre_px: tuple[float, float] | None = None,
               usable_radius_px: float | None = None) -> CameraFit:
    """The camera of ``robot`` fitted to its samples (see the module docstring)."""
    if len(samples) < MIN_SAMPLES:
        raise InputError(f"{robot}: {len(samples)} samples; a calibration needs at least "
                         f"{MIN_SAMPLES} (more, at ranges from near to far, fit better)")
    centre = _centre(robot, samples, centroids, centre_px)
    if centroids:
        r = np.array([math.hypot((s.u_px or 0.0) - centre.cu_px, (s.v_px or 0.0) - centre.cv_px)
                      for s in samples])
    else:
        r = np.array([s.r_px or 0.0 for s in samples])
    d = np.array([s.range_m for s in samples])
    try:
        fits = fit_all(r, d)
    except CalibrationError as err:
        raise InputError(f"{robot}: {err}") from err
    width, height = image_size_px
    if not (-0.5 <= centre.cu_px <= width - 0.5 and -0.5 <= centre.cv_px <= height - 0.5):
        raise InputError(f"{robot}: the fitted centre ({centre.cu_px:.1f}, {centre.cv_px:.1f}) "
                         f"is outside the {width} x {height} image: are the angles measured "
                         "as the robot frame says (0 forward, 90 left)?")
    usable = usable_radius_px or float(np.max(r)) * USABLE_MARGIN
    return CameraFit(robot, centre, tuple(fits), tuple(r.tolist()), tuple(d.tolist()),
                     width, height, usable)
