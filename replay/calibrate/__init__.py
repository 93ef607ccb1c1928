"""A real camera calibrated from the command line (``dsp-calibrate --from-measurements``,
``--from-log``): samples (:mod:`~replay.calibrate.measurements`, :mod:`~replay.calibrate.
from_log`), the fit (:mod:`~replay.calibrate.fit`: centre, mounting, every model ranked on
held-out samples), the camera file and the report (:mod:`~replay.calibrate.run`), the
residual figure (:mod:`~replay.calibrate.figure`); the command in :mod:`~replay.calibrate.cli`.
"""

from __future__ import annotations

from replay.calibrate.fit import CameraFit, fit_camera
from replay.calibrate.measurements import Measurements, Sample, read_measurements
from replay.calibrate.run import MeasuredRun, calibrate_measured, camera_file, format_measured

__all__ = [
    "CameraFit",
    "MeasuredRun",
    "Measurements",
    "Sample",
    "calibrate_measured",
    "camera_file",
    "fit_camera",
    "format_measured",
    "read_measurements",
]
