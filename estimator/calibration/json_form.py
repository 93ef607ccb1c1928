"""The JSON form of a calibration model, written and read back.

The form is ``{"format": "dsp-calibration", "version": 1, "model": <name>, ...params,
"fit": {...}?}`` with sorted keys; it is parsed with :func:`json.loads` only.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

from estimator.calibration.fit import FitResult
from estimator.calibration.models import (
    CALIBRATION_MODELS,
    Calibration,
    CameraCalibration,
    LinearCalibration,
    LookupCalibration,
    MirrorCalibration,
)
from estimator.errors import CalibrationFormatError

__all__ = [
    "CALIBRATION_FORMAT",
    "CALIBRATION_FORMAT_VERSION",
    "calibration_from_dict",
    "calibration_from_json",
    "calibration_to_json",
]

CALIBRATION_FORMAT = "dsp-calibration"
CALIBRATION_FORMAT_VERSION = 1


def calibration_to_json(model: Calibration, fit: FitResult | None = None) -> str:
    """The model (and optionally its fit statistics) as a small JSON string."""
    doc: dict[str, Any] = {
        "format": CALIBRATION_FORMAT,
        "version": CALIBRATION_FORMAT_VERSION,
        **model.to_dict(),
    }
    if fit is not None:
        doc["fit"] = {"r2": fit.r2, "rms_m": fit.rms_m, "max_abs_m": fit.max_abs_m, "n": fit.n}
    return json.dumps(doc, sort_keys=True, indent=2)


def calibration_from_json(text: str) -> Calibration:
    """The model in a JSON string written by :func:`calibration_to_json`."""
    try:
        doc = json.loads(text)
    except (json.JSONDecodeError, TypeError) as err:
        raise CalibrationFormatError(
            f"calibration is not valid JSON ({err}); pass the text calibration_to_json wrote"
        ) from err
    if not isinstance(doc, dict):
        raise CalibrationFormatError(
            f"calibration JSON is a {type(doc).__name__}, not an object with a 'model' key"
        )
    return calibration_from_dict(doc)


def _number(doc: Mapping[str, Any], key: str) -> float:
    if key not in doc:
        raise CalibrationFormatError(
            f"calibration model {doc.get('model')!r} lacks the key {key!r}; add it"
        )
    value = doc[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise CalibrationFormatError(
            f"calibration key {key!r} = {value!r} is not a number; write a number"
        )
    return float(value)


def _numbers(doc: Mapping[str, Any], key: str) -> tuple[float, ...]:
    value = doc.get(key)
    if not isinstance(value, list):
        raise CalibrationFormatError(
            f"calibration key {key!r} = {value!r} is not a list of numbers; write one"
        )
    return tuple(_number({key: v, "model": doc.get("model")}, key) for v in value)


def calibration_from_dict(d: Mapping[str, Any]) -> Calibration:
    """The model described by a dict with a ``"model"`` key (the ``to_dict()`` form,
    optionally with ``"format"``, ``"version"`` and ``"fit"`` keys, which are checked or
    ignored)."""
    version = d.get("version", CALIBRATION_FORMAT_VERSION)
    if version != CALIBRATION_FORMAT_VERSION:
        raise CalibrationFormatError(
            f"calibration format version {version!r} is not supported; this estimator "
            f"reads version {CALIBRATION_FORMAT_VERSION} (re-save it with this version)"
        )
    fmt = d.get("format", CALIBRATION_FORMAT)
    if fmt != CALIBRATION_FORMAT:
        raise CalibrationFormatError(
            f"format {fmt!r} is not {CALIBRATION_FORMAT!r}; this is not a calibration file"
        )
    model = d.get("model")
    if model == "linear":
        return LinearCalibration(_number(d, "a_m_per_px"), _number(d, "b_m"))
    if model == "lookup":
        return LookupCalibration(_numbers(d, "r_px"), _numbers(d, "d_m"))
    if model == "mirror":
        return MirrorCalibration(_number(d, "a_m"), _number(d, "b_rad_per_px"))
    if model == "camera":
        camera_doc = d.get("camera")
        if not isinstance(camera_doc, dict):
            raise CalibrationFormatError(
                f"camera calibration key 'camera' = {camera_doc!r} is not an object; "
                "write the camera's to_dict()"
            )
        from estimator.camera import camera_from_dict  # lazy: camera models are optional

        try:
            camera = camera_from_dict(camera_doc)
        except (KeyError, TypeError, ValueError) as err:
            raise CalibrationFormatError(
                f"camera {camera_doc!r} cannot be rebuilt ({err}); write a camera's to_dict()"
            ) from err
        return CameraCalibration(camera, _number(d, "ball_radius_m"))
    raise CalibrationFormatError(
        f"calibration model {model!r} is unknown; use one of {', '.join(CALIBRATION_MODELS)}"
    )
