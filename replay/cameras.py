"""Each robot's camera as a replay uses it: image centre, camera model, calibration.

From the log's camera metadata (``dsp.cameras``: a camera model per robot, whose
calibration is the model's own) or, for a robot it does not name, the paper's image centre
and calibration; a ``--calibration`` file replaces every robot's calibration. The one file
a replay reads besides the log is read here (:func:`read_calibration`).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from dsp import contract
from dsp.errors import CalibrationError
from estimator.calibration import (
    PAPER_CALIBRATION,
    Calibration,
    CameraCalibration,
    calibration_from_json,
)
from estimator.camera import CameraModel, ball_image_area_px, camera_from_dict
from estimator.constants import PAPER_CENTRE_PX
from estimator.corrected import ball_visibility
from estimator.detection import Detection
from estimator.errors import EstimatorError

__all__ = ["DEFAULT_CENTRE_PX", "Cameras", "cameras_for", "read_calibration"]

DEFAULT_CENTRE_PX = PAPER_CENTRE_PX
"""The image centre of a robot whose log names no camera: the paper's."""


@dataclass(frozen=True)
class Cameras:
    """Per robot: image centre, camera model (when the log names one) and calibration."""

    centres: Mapping[str, tuple[float, float]]
    models: Mapping[str, CameraModel]
    calibrations: Mapping[str, Calibration]
    fit_rms_m: float = 0.0
    """The calibration file's fit residual RMS [m] when it records one (0: a camera model)."""

    def visibility(self, robot: str, det: Detection, range_m: float) -> float:
        """How much of the ball the blob shows, when the log names the camera model."""
        model = self.models.get(robot)
        if model is None:
            return 1.0
        expected = ball_image_area_px(model, range_m)
        return ball_visibility(float(det.area_px), expected)


def cameras_for(robots: Sequence[str], metadata: Mapping[str, Mapping[str, object]], source: str,
                calibration_file: Path | None) -> Cameras:
    """Each robot's camera from the log's metadata (the paper's when it names none), and the
    calibration file, when given, for every robot."""
    centres: dict[str, tuple[float, float]] = {}
    models: dict[str, CameraModel] = {}
    calibrations: dict[str, Calibration] = {}
    for robot in robots:
        centres[robot] = DEFAULT_CENTRE_PX
        calibrations[robot] = PAPER_CALIBRATION
        if robot in metadata:
            try:
                model = camera_from_dict(dict(metadata[robot]))
            except (ValueError, TypeError, EstimatorError) as err:
                raise CalibrationError(
                    f"{source} metadata {contract.CAMERAS_METADATA}[{robot}]", str(err)
                ) from err
            centres[robot] = (float(model.centre_px[0]), float(model.centre_px[1]))
            calibrations[robot] = CameraCalibration(model)
            models[robot] = model
    fit_rms_m = 0.0
    if calibration_file is not None:
        model_from_file, fit_rms_m = read_calibration(Path(calibration_file))
        calibrations = dict.fromkeys(robots, model_from_file)
    return Cameras(centres, models, calibrations, fit_rms_m)


def read_calibration(path: Path) -> tuple[Calibration, float]:
    """The calibration in ``path`` and its fit's residual RMS [m] (0 when not recorded)."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as err:
        raise CalibrationError(path, f"cannot read: {err.strerror or err}") from err
    try:
        model = calibration_from_json(text)
        fit = json.loads(text).get("fit") or {}
        rms = float(fit.get("rms_m", 0.0)) if isinstance(fit, dict) else 0.0
    except (ValueError, TypeError, KeyError, EstimatorError) as err:
        raise CalibrationError(path, str(err)) from err
    if not (math.isfinite(rms) and rms >= 0.0):
        raise CalibrationError(path, f"fit rms_m = {rms} must be a finite number >= 0")
    return model, rms
