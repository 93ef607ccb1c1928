"""Each robot's camera as a replay uses it: centre, mounting, model, calibration, poses' frame.

Where a robot's camera description (:class:`dsp.cameras.CameraSpec`) comes from, first
found first:

1. ``--cameras FILE`` (:mod:`dsp.camera_file`): the robot's entry, or the file's default;
   ``--cameras paper``: the paper's camera (:data:`dsp.cameras.PAPER_CAMERA`);
2. the log's ``dsp.cameras`` metadata (the robot's entry, or its default);
3. ``--calibration paper``: the paper's camera too (its centre with its calibration).

A robot described by none of them is an error that says what to give
(:class:`~replay.errors.NoCameraError`): a replay never guesses a camera. ``--calibration
FILE`` (or ``paper``), or a model from outside (``--calibration-model``,
:mod:`replay.plugins`), then replaces every robot's calibration, keeping the rest of its
description. The files a replay reads besides the log are read here. A camera file may
name the field too (its ``field`` key): :attr:`Cameras.field`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dsp import jsonio
from dsp.camera_file import read_camera_file
from dsp.cameras import PAPER_CAMERA, CameraSet, CameraSpec, FieldTransform
from dsp.errors import CalibrationError
from dsp.field import FieldSpec
from dsp.textfile import read_text_file
from estimator.calibration import PAPER_CALIBRATION, Calibration, calibration_from_json
from estimator.camera import CameraModel, ball_image_area_px
from estimator.constants import PAPER_CENTRE_PX
from estimator.corrected import ball_visibility
from estimator.detection import Detection
from estimator.errors import EstimatorError
from replay.errors import NoCameraError

__all__ = ["DEFAULT_CENTRE_PX", "MAX_CALIBRATION_BYTES", "PAPER", "Cameras", "cameras_for",
           "check_ranges", "read_calibration"]

DEFAULT_CENTRE_PX = PAPER_CENTRE_PX
"""The centre a sink draws for a robot it knows no camera of (none replays without one)."""
PAPER = "paper"
"""``--cameras paper`` / ``--calibration paper``: the paper's constants, asked for by name."""
MAX_CALIBRATION_BYTES = 1 << 20
"""1 MiB: a calibration file is a model and its fit (a lookup table of 1000 points, 30 KiB)."""


@dataclass(frozen=True)
class Cameras:
    """Per robot: its camera description and the calibration the replay uses."""

    specs: Mapping[str, CameraSpec]
    calibrations: Mapping[str, Calibration]
    fit_rms_m: float = 0.0
    """The calibrations' fit residual RMS [m] when their files record one (0: a model)."""
    sources: Mapping[str, str] | None = None
    """Robot -> where its description came from ("metadata", the camera file, "paper")."""
    calibration_source: str | None = None
    """What replaced every robot's calibration (``--calibration FILE``,
    ``--calibration-model SPEC``); None: each robot's description gives its own."""
    field: FieldSpec | None = None
    """The field the camera file names (its ``field`` key); None: it names none."""
    field_source: str | None = None
    """The camera file that names :attr:`field`."""

    @property
    def centres(self) -> Mapping[str, tuple[float, float]]:
        return {r: s.centre_px for r, s in self.specs.items()}

    @property
    def models(self) -> Mapping[str, CameraModel]:
        return {r: s.camera for r, s in self.specs.items() if s.camera is not None}

    def mount_yaw_rad(self, robot: str) -> float:
        return self.specs[robot].mount_yaw_rad

    def usable_radius_px(self, robot: str) -> float | None:
        return self.specs[robot].usable_radius_px

    def map_to_field(self, robot: str) -> FieldTransform | None:
        transform = self.specs[robot].map_to_field
        return None if transform is None or transform.identity else transform

    def ball_models(self) -> Mapping[str, str | Mapping[str, Any]]:
        """Robot -> its ``ball`` entry (the ball model, read by the ball detector)."""
        return {r: s.ball for r, s in self.specs.items() if s.ball is not None}

    def visibility(self, robot: str, det: Detection, range_m: float) -> float:
        """How much of the ball the blob shows, when the camera's model is known."""
        model = self.specs[robot].camera
        if model is None:
            return 1.0
        expected = ball_image_area_px(model, range_m)
        return ball_visibility(float(det.area_px), expected)


def _missing(log: str, robots: Sequence[str], metadata: CameraSet | None,
             cameras: Path | str | None) -> NoCameraError:
    where = (" (the log has no dsp.cameras metadata)" if metadata is None
             else " (the log's dsp.cameras metadata does not name them)")
    if cameras is not None:
        where = f" (neither {cameras} nor the log's metadata names them)"
    return NoCameraError(
        log, f"no camera description for {', '.join(robots)}{where}: give --cameras FILE "
        f"(dsp-info --cameras-template {log} -o cameras.yaml writes one to start from), or "
        "--cameras paper for the paper's 1080 x 1080 camera centred at (539, 539)")


def cameras_for(robots: Sequence[str], *, log: str, metadata: CameraSet | None,
                cameras: Path | str | None = None,
                calibration: Path | str | None = None,
                calibration_model: Calibration | None = None) -> Cameras:
    """Each robot's camera (see the module docstring for the order); raises
    :class:`~replay.errors.NoCameraError` for a robot nothing describes."""
    given: CameraSet | None = None
    if cameras is not None and cameras != PAPER:
        given = read_camera_file(Path(cameras))
    specs: dict[str, CameraSpec] = {}
    sources: dict[str, str] = {}
    for robot in robots:
        found: list[tuple[CameraSpec | None, str]] = [
            (PAPER_CAMERA if cameras == PAPER else None, PAPER),
            (None if given is None else given.for_robot(robot), str(cameras)),
            (None if metadata is None else metadata.for_robot(robot), "metadata"),
            (PAPER_CAMERA if calibration == PAPER else None, PAPER),
        ]
        spec, source = next(((s, w) for s, w in found if s is not None), (None, ""))
        if spec is not None:
            specs[robot], sources[robot] = spec, source
    missing = [r for r in robots if r not in specs]
    if missing:
        raise _missing(log, missing, metadata, cameras)
    calibrations = {r: s.range_calibration for r, s in specs.items()}
    rms = max((s.calibration_rms_m or 0.0 for s in specs.values()), default=0.0)
    replaced = None
    if calibration == PAPER:
        calibrations, rms = dict.fromkeys(robots, PAPER_CALIBRATION), 0.0
        replaced = "--calibration paper"
    elif calibration is not None:
        model, rms = read_calibration(Path(calibration))
        calibrations, replaced = dict.fromkeys(robots, model), f"--calibration {calibration}"
    elif calibration_model is not None:  # a model from outside: no fit residual to add
        calibrations, rms = dict.fromkeys(robots, calibration_model), 0.0
        replaced = "--calibration-model"
    for robot, model in calibrations.items():
        where = replaced or (f"{log}: metadata" if sources[robot] == "metadata"
                             else sources[robot])
        check_ranges(model, _radius_px(specs[robot]), f"{where} ({robot})")
    return Cameras(specs, calibrations, rms, sources, replaced,
                   field=None if given is None else given.field,
                   field_source=None if given is None or given.field is None else str(cameras))


RANGE_SAMPLES = 64
"""The radii :func:`check_ranges` evaluates a calibration at."""
INNER_SHARE = 0.1
"""The inner share of the radius (under the robot's own body) where a range may be
negative (a fit's offset below zero)."""


NEAR_MAX_M = 100.0
"""The farthest range [m] a calibration may give within the inner half of the radius: an
MSL field's diagonal is under 30 m, and every camera sees its far field near the rim."""
MIN_SPAN_M = 0.5
"""The least growth [m] of the ranges from the image centre to the rim: an omni camera
sees from under half a metre to metres away."""


def _radius_px(spec: CameraSpec) -> float:
    """The radius over which a robot's ranges are read: its usable radius, else the image's
    inscribed circle's."""
    if spec.usable_radius_px is not None:
        return float(spec.usable_radius_px)
    return 0.5 * min(spec.width_px, spec.height_px)


def check_ranges(model: Calibration, radius_px: float, source: str) -> None:
    """Refuse a calibration whose ranges over the image (0 to ``radius_px``, up to where it
    gives none: a mirror's horizon) are not finite, fall as the radius grows, are negative
    beyond the inner :data:`INNER_SHARE` of the radius, exceed :data:`NEAR_MAX_M` within the
    inner half, or grow by less than :data:`MIN_SPAN_M` over the whole: such a model places
    every ball wrongly (a linear one with a negative slope put balls at -15.7 m, one with
    slope 0 every ball on the robot), in one line naming ``source``."""
    first: tuple[float, float] | None = None
    last: tuple[float, float] | None = None
    for i in range(RANGE_SAMPLES + 1):
        r_px = radius_px * i / RANGE_SAMPLES
        try:
            got: float | None = model.range_m(r_px)  # a model from outside may give None
        except (EstimatorError, ArithmeticError, ValueError):
            break  # beyond where the model gives ranges
        if got is None:
            break
        value = float(got)
        if not math.isfinite(value):
            raise CalibrationError(source, f"its range at {r_px:.0f} px is {value}")
        if value < 0 and r_px > INNER_SHARE * radius_px:
            raise CalibrationError(source, f"its range at {r_px:.0f} px is {value:.3g} m, "
                                   "negative; a range grows from the image centre outwards")
        if value > NEAR_MAX_M and r_px <= 0.5 * radius_px:
            raise CalibrationError(source, f"its range at {r_px:.0f} px, within the inner "
                                   f"half of the image, is {value:.3g} m; no camera sees that "
                                   "far so near its centre")
        if last is not None and value < last[1] - 1e-9 * max(1.0, abs(last[1])):
            raise CalibrationError(source, f"its range falls from {last[1]:.3g} m at "
                                   f"{last[0]:.0f} px to {value:.3g} m at {r_px:.0f} px; a "
                                   "range grows from the image centre outwards")
        first = first or (r_px, value)
        last = (r_px, value)
    if first is not None and last is not None and last[1] - first[1] < MIN_SPAN_M:
        raise CalibrationError(source, f"its range only grows from {first[1]:.3g} m at "
                               f"{first[0]:.0f} px to {last[1]:.3g} m at {last[0]:.0f} px; "
                               "a ball further out in the image is further away")


def read_calibration(path: Path) -> tuple[Calibration, float]:
    """The calibration in ``path`` and its fit's residual RMS [m] (0 when not recorded)."""
    def unusable(message: str) -> CalibrationError:  # "PATH: why" -> "PATH: unusable ...: why"
        return CalibrationError(path, message.removeprefix(f"{path}: "))

    text = read_text_file(path, MAX_CALIBRATION_BYTES, what="a calibration JSON file",
                          error=unusable)
    try:
        jsonio.check_limits(text)  # within a JSON input's limits before the model parses it
        model = calibration_from_json(text)
        fit = json.loads(text).get("fit") or {}
        rms = float(fit.get("rms_m", 0.0)) if isinstance(fit, dict) else 0.0
    except (ValueError, TypeError, KeyError, EstimatorError) as err:
        raise CalibrationError(path, str(err)) from err
    if not (math.isfinite(rms) and rms >= 0.0):
        raise CalibrationError(path, f"fit rms_m = {rms} must be a finite number >= 0")
    return model, rms
