"""A real camera calibrated: samples in, a camera file and its residual figure out.

:func:`calibrate_measured` fits every robot's camera (:mod:`replay.calibrate.fit`) from a
measurements file or a log (:mod:`replay.calibrate.measurements`, :mod:`~replay.calibrate.
from_log`); :func:`camera_file` writes the cameras as the file ``dsp-replay --cameras``
reads (the schema of ``dsp.cameras``, :mod:`dsp.cameras`), and :func:`format_measured` the
report: per robot the centre and mounting found, and each model's fit and held-out RMS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from dsp.camera_file import camera_file_text
from dsp.cameras import DEFAULT_ENTRY
from dsp.errors import InputError
from replay.calibrate.fit import CameraFit, fit_camera
from replay.calibrate.measurements import Measurements

__all__ = ["MeasuredRun", "calibrate_measured", "camera_file", "format_measured"]


@dataclass(frozen=True)
class MeasuredRun:
    cameras: tuple[CameraFit, ...]
    source: str
    map_to_field: tuple[float, float, float] | None = None
    height_m: float | None = None
    """The camera's height, written to every entry (``--camera-height``)."""
    field: str | None = None
    """The field's name, written to the file (``--field``)."""


def calibrate_measured(measurements: Measurements, *,
                       image_sizes: dict[str, tuple[int, int]],
                       centre_px: tuple[float, float] | None = None,
                       usable_radius_px: float | None = None,
                       map_to_field: tuple[float, float, float] | None = None) -> MeasuredRun:
    """Every robot's camera fitted to its samples; ``image_sizes`` per robot (or under
    ``default`` for all)."""
    cameras = []
    for robot, samples in sorted(measurements.samples.items()):
        size = image_sizes.get(robot) or image_sizes.get(DEFAULT_ENTRY)
        if size is None:
            raise InputError(f"{measurements.source}: the image size of {robot} is unknown; "
                             "give --image-size WxH")
        cameras.append(fit_camera(robot, samples, centroids=measurements.centroids,
                                  image_size_px=size, centre_px=centre_px,
                                  usable_radius_px=usable_radius_px))
    return MeasuredRun(tuple(cameras), measurements.source, map_to_field)


def camera_file(run: MeasuredRun, suffix: str) -> str:
    """The camera file of the run (YAML with a header saying how it was made, or JSON)."""
    entries = {c.robot: c.entry(run.map_to_field) for c in run.cameras}
    if run.height_m is not None:
        entries = {robot: {**entry, "height_m": run.height_m} for robot, entry in entries.items()}
    lines = [f"Cameras calibrated by dsp-calibrate from {Path(run.source).name}:"]
    for c in run.cameras:
        lines.append(f"  {c.robot}: {len(c.r_px)} samples, {_centre_text(c)}, best "
                     f"{c.best.model.name} (held-out RMS {_held(c)})")
    lines.append("Give it to dsp-replay --cameras; the keys: docs/cameras.md.")
    return camera_file_text(entries, suffix, header="\n".join(lines), field=run.field)


def _held(c: CameraFit) -> str:
    h = c.best.holdout_rms_m
    return "not computed: too few ranges" if h is None else f"{h:.4f} m"


def _centre_text(c: CameraFit) -> str:
    how = "fitted" if c.centre.centre_fitted else "given"
    return (f"centre ({c.centre.cu_px:.2f}, {c.centre.cv_px:.2f}) {how}, mounted at "
            f"{math.degrees(c.centre.mount_yaw_rad):.2f} deg, "
            f"{c.centre.rms_px:.2f} px off the bearing lines")


def format_measured(run: MeasuredRun) -> str:
    lines = [f"calibrated from {run.source}:"]
    for c in run.cameras:
        lines += ["", f"{c.robot}: {len(c.r_px)} samples, ranges {min(c.range_m):.2f} to "
                  f"{max(c.range_m):.2f} m; {_centre_text(c)}",
                  f"  {'model':8} {'R^2':>8} {'RMS [m]':>8} {'max [m]':>8} {'held-out RMS':>13}"]
        for fit in c.fits:
            held = "-" if fit.holdout_rms_m is None else f"{fit.holdout_rms_m:.4f}"
            lines.append(f"  {fit.model.name:8} {fit.r2:>8.5f} {fit.rms_m:>8.4f} "
                         f"{fit.max_abs_m:>8.4f} {held:>13}")
        ranked = ("ranked on held-out samples" if c.best.holdout_rms_m is not None
                  else "ranked on the fitted samples: too few distinct ranges to hold any out")
        lines.append(f"  best: {c.best.model.name} ({ranked}); usable radius "
                     f"{c.usable_radius_px:.0f} px")
    return "\n".join(lines)
