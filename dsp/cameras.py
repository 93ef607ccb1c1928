"""The camera description: one schema for a log's ``dsp.cameras`` metadata and a camera file.

A simulated log and a real one are described alike. An *entry* describes one robot's
camera as a JSON object (in the metadata: the value under the robot's name; in a camera
file, :mod:`dsp.camera_file`: the same object, in YAML or JSON)::

    model: mirror          # ideal | fisheye | mirror (estimator.camera) | lookup
    width_px: 1280         # the image's size
    height_px: 1024
    cu_px: 640.0           # the image centre (the robot's centre) [px]
    cv_px: 512.0
    max_radius_px: 539.0   # the image circle's radius [px] (the model's; lookup: optional)
    height_m: 0.85         # the model's own parameters, as estimator.camera names them
    a_m: 1.2               # (ideal: k_m_per_px; fisheye: fov_deg; mirror: a_m,
    b_rad_per_px: 0.00286  #  b_rad_per_px, self_radius_px)
    self_radius_px: 30.0
    # optional:
    usable_radius_px: 500  # a ball seen farther from the centre is out of range
    mount_yaw_deg: 0.0     # the robot-frame direction image up shows (0 forward, 90 left)
    calibration: {model: mirror, a_m: 1.04, b_rad_per_px: 0.00286}   # replaces the model's
    ball: ball.json        # the ball model, see dsp-calibrate --ball-from (path or object)
    map_to_field: {x_m: 0.0, y_m: 0.0, yaw_deg: 0.0}   # the poses' frame in the field

``ideal``, ``fisheye`` and ``mirror`` are projection models: the range comes from the model
(the ball-height correction, :class:`~estimator.calibration.CameraCalibration`) unless
``calibration`` replaces it, and the model tells how large a whole ball looks. ``lookup``:
the range is looked up in ``calibration`` (required; linear, lookup table, mirror); with
``height_m`` it makes a projection model (:mod:`estimator.table_camera`). Every key a
model needs is required: nothing about a camera's geometry is ever guessed. The recorder
writes exactly the model's ``to_dict()``, so its logs are what they always were.

An entry named ``default`` applies to every robot without one; a robot's entry is the
default with the robot's own keys put over it. ``ball`` is reserved for the ball model (a
path, relative to the camera file, or an inline object): it is checked to be one of those
and passed on untouched. ``map_to_field`` turns a pose (x, y, yaw) in the poses' frame
(e.g. AMCL's ``map``) into the field frame: rotated by ``yaw_deg`` then moved by (x, y).

Everything is parsed once, here, into frozen records (:class:`CameraSpec`,
:class:`CameraSet`); a bad field raises :class:`CameraDescriptionError`, one line naming the
source and the field (``cameras.yaml: robot2.cu_px = 'x' is not a number``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from dataclasses import field as dc_field
from typing import Any

from dsp.errors import InputError
from dsp.field import FieldSpec
from estimator.calibration import (
    PAPER_CALIBRATION,
    Calibration,
    CameraCalibration,
    calibration_from_dict,
)
from estimator.camera import CameraModel, make_camera
from estimator.constants import PAPER_CENTRE_PX, PAPER_IMAGE_SIZE_PX
from estimator.errors import EstimatorError
from estimator.table_camera import table_camera

__all__ = [
    "CAMERA_KINDS",
    "DEFAULT_ENTRY",
    "FIELD_KEY",
    "MAX_FIELD_SIDE_M",
    "PAPER_CAMERA",
    "CameraDescriptionError",
    "CameraSet",
    "CameraSpec",
    "FieldTransform",
    "camera_set_from_json",
    "camera_spec_from_json",
]

CAMERA_KINDS = ("ideal", "fisheye", "mirror", "lookup")
DEFAULT_ENTRY = "default"
"""The entry that describes every robot without one of its own."""
FIELD_KEY = "field"
"""A camera file's top-level key naming the field (:func:`dsp.field_file.field_from_json`),
beside the robots' entries: like ``default``, never a robot's name."""
MAX_FIELD_SIDE_M = 40.0
"""The longest side a described field may have [m]: an MSL field is 22 m long, and the line
fit samples the field every 2 cm (a 1e6 m field would not fit in memory)."""
MAX_IMAGE_SIDE_PX = 100_000
MAX_MAGNITUDE = 1e6
"""The largest number a camera description holds, either sign (pixels, metres, degrees):
1e308 is finite, and overflows what it is multiplied by."""

_COMMON = ("model", "width_px", "height_px", "cu_px", "cv_px")
_MODEL_KEYS = {
    "ideal": ("max_radius_px", "height_m", "k_m_per_px"),
    "fisheye": ("max_radius_px", "height_m", "fov_deg"),
    "mirror": ("max_radius_px", "height_m", "a_m", "b_rad_per_px", "self_radius_px"),
    "lookup": ("calibration",),
}
"""Required keys besides :data:`_COMMON`, per model."""
_OPTIONAL = ("usable_radius_px", "mount_yaw_deg", "calibration", "ball", "map_to_field",
             "max_radius_px", "height_m")
_POSITIVE = ("max_radius_px", "height_m", "k_m_per_px", "fov_deg", "a_m", "b_rad_per_px",
             "usable_radius_px")


class CameraDescriptionError(InputError, ValueError):
    """A camera description that cannot be used: the message names the source and field."""


@dataclass(frozen=True)
class FieldTransform:
    """The poses' frame in the field frame: field = R(yaw) * pose + (x, y), yaw added."""

    x_m: float = 0.0
    y_m: float = 0.0
    yaw_rad: float = 0.0

    def apply(self, x_m: float, y_m: float, yaw_rad: float) -> tuple[float, float, float]:
        """A pose (x, y, yaw) in the poses' frame, in the field frame."""
        c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        return (self.x_m + c * x_m - s * y_m, self.y_m + s * x_m + c * y_m,
                math.remainder(yaw_rad + self.yaw_rad, math.tau))

    @property
    def identity(self) -> bool:
        return self.x_m == 0.0 and self.y_m == 0.0 and self.yaw_rad == 0.0


@dataclass(frozen=True)
class CameraSpec:
    """One robot's camera, validated (see the module docstring for the fields)."""

    model: str
    width_px: int
    height_px: int
    centre_px: tuple[float, float]
    camera: CameraModel | None = None
    """The projection model; None for a ``lookup`` without ``height_m``."""
    calibration: Calibration | None = None
    """The entry's ``calibration``, when it gives one (it replaces the model's)."""
    calibration_rms_m: float | None = None
    """The calibration's fit residual RMS [m], when its ``fit`` records one (``rms_m``)."""
    max_radius_px: float | None = None
    usable_radius_px: float | None = None
    mount_yaw_rad: float = 0.0
    ball: str | Mapping[str, Any] | None = None
    """The ball model (a path or an object), passed on unread: see dsp-calibrate
    --ball-from."""
    map_to_field: FieldTransform | None = None
    entry: Mapping[str, Any] = dc_field(default_factory=dict, compare=False, repr=False)
    """The entry as given (JSON values), for templates and ``dsp-info``."""

    @property
    def range_calibration(self) -> Calibration:
        """What turns a pixel radius into a range: the entry's calibration, else the model's."""
        if self.calibration is not None:
            return self.calibration
        assert self.camera is not None  # a lookup entry always has a calibration
        return CameraCalibration(self.camera)

    def describe(self) -> str:
        """One line for a terminal."""
        parts = [f"{self.model} {self.width_px}x{self.height_px}",
                 f"centre ({self.centre_px[0]:g}, {self.centre_px[1]:g})"]
        if self.usable_radius_px is not None:
            parts.append(f"usable radius {self.usable_radius_px:g} px")
        if self.model == "lookup" and self.camera is not None:
            parts.append(f"height {self.camera.height_m:g} m (a projection model)")
        if self.mount_yaw_rad:
            parts.append(f"mounted at {math.degrees(self.mount_yaw_rad):g} deg")
        parts.append(f"calibration {self.calibration.name}" if self.calibration is not None
                     else "calibration from the model")
        if self.ball is not None:
            parts.append("ball model " + (self.ball if isinstance(self.ball, str) else "inline"))
        if self.map_to_field is not None and not self.map_to_field.identity:
            t = self.map_to_field
            parts.append(f"map to field ({t.x_m:g}, {t.y_m:g}, {math.degrees(t.yaw_rad):g} deg)")
        return ", ".join(parts)


@dataclass(frozen=True)
class CameraSet:
    """The cameras a metadata record or a camera file describes: per robot, and a default."""

    robots: Mapping[str, CameraSpec]
    default: CameraSpec | None = None
    source: str = ""
    field: FieldSpec | None = None
    """The field a camera file names (its ``field`` key); None: it names none."""

    def for_robot(self, robot: str) -> CameraSpec | None:
        """The robot's camera: its own entry, else the default, else None."""
        return self.robots.get(robot, self.default)


def _fail(where: str, key: str, text: str) -> CameraDescriptionError:
    return CameraDescriptionError(f"{where}.{key} {text}" if key else f"{where} {text}")


def _number(where: str, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _fail(where, key, f"= {value!r} is not a number")
    if not math.isfinite(value):
        raise _fail(where, key, f"= {value!r} is not a finite number")
    if abs(value) > MAX_MAGNITUDE:
        raise _fail(where, key, f"= {value!r} is out of range (a camera's numbers are within "
                    f"{MAX_MAGNITUDE:g} either way)")
    return float(value)


def _size(where: str, key: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not (
            0 < value <= MAX_IMAGE_SIDE_PX):
        raise _fail(where, key, f"= {value!r} is not a whole number of pixels in "
                    f"[1, {MAX_IMAGE_SIDE_PX}]")
    return value


def _object(where: str, key: str, value: Any) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise _fail(where, key, f"= {value!r} is not an object (key: value pairs)")
    return value


def _transform(where: str, value: Any) -> FieldTransform:
    obj = _object(where, "map_to_field", value)
    unknown = sorted(set(obj) - {"x_m", "y_m", "yaw_deg"})
    if unknown:
        raise _fail(where, "map_to_field", f"has unknown key {unknown[0]!r} "
                    "(keys: x_m, y_m, yaw_deg)")
    get = {k: _number(where, f"map_to_field.{k}", obj.get(k, 0.0))
           for k in ("x_m", "y_m", "yaw_deg")}
    return FieldTransform(get["x_m"], get["y_m"], math.radians(get["yaw_deg"]))


def _ball(where: str, value: Any) -> str | Mapping[str, Any]:
    if isinstance(value, str) and value.strip():
        return value
    if isinstance(value, Mapping):
        return dict(value)
    raise _fail(where, "ball", f"= {value!r} is neither a path nor an object (the ball "
                "model, see dsp-calibrate --ball-from)")


def _calibration(where: str, value: Any) -> tuple[Calibration, float | None]:
    """The calibration and its fit's residual RMS [m] (None when it records none)."""
    obj = _object(where, "calibration", value)
    try:
        model = calibration_from_dict(obj)
    except (EstimatorError, TypeError) as err:
        raise _fail(where, "calibration", f"is unusable: {err}") from err
    fit = obj.get("fit")
    if fit is None or "rms_m" not in _object(where, "calibration.fit", fit):
        return model, None
    rms = _number(where, "calibration.fit.rms_m", fit["rms_m"])
    if rms < 0.0:
        raise _fail(where, "calibration.fit.rms_m", "must be >= 0")
    return model, rms


def _check_keys(where: str, entry: Mapping[str, Any], model: str) -> None:
    empty = [k for k, v in entry.items() if v is None]
    if empty:
        hint = (" (dsp-calibrate --from-measurements or --from-log writes a calibration)"
                if empty[0] == "calibration" else "")
        raise _fail(where, empty[0], f"is empty: fill it in{hint}")
    allowed = (*_COMMON, *_MODEL_KEYS[model], *_OPTIONAL)
    unknown = [k for k in entry if k not in allowed]
    if unknown:
        raise _fail(where, str(unknown[0]), f"is not a key of a {model} camera "
                    f"(keys: {', '.join(dict.fromkeys(allowed))})")
    missing = [k for k in (*_COMMON, *_MODEL_KEYS[model]) if k not in entry]
    if missing:
        raise _fail(where, missing[0], f"is missing: a {model} camera needs "
                    f"{', '.join(k for k in (*_COMMON, *_MODEL_KEYS[model]) if k != 'model')}")


def camera_spec_from_json(entry: Any, where: str) -> CameraSpec:
    """One entry (a JSON object) as a :class:`CameraSpec`; ``where`` names it in errors
    (``"cameras.yaml: robot1"``)."""
    entry = _object(where, "", entry)
    model = entry.get("model")
    if model not in CAMERA_KINDS:
        if model is None:
            raise _fail(where, "model", f"is missing: give one of {', '.join(CAMERA_KINDS)}")
        raise _fail(where, "model", f"= {model!r} is not one of {', '.join(CAMERA_KINDS)}")
    _check_keys(where, entry, model)
    width, height = (_size(where, k, entry[k]) for k in ("width_px", "height_px"))
    cu, cv = (_number(where, k, entry[k]) for k in ("cu_px", "cv_px"))
    if not (-0.5 <= cu <= width - 0.5 and -0.5 <= cv <= height - 0.5):
        raise _fail(where, "cu_px", f"/ cv_px = ({cu:g}, {cv:g}) is not inside the "
                    f"{width} x {height} image")
    numbers = {k: _number(where, k, entry[k]) for k in entry
               if k not in (*_COMMON, "calibration", "ball", "map_to_field")}
    for key in _POSITIVE:
        if key in numbers and not numbers[key] > 0.0:
            raise _fail(where, key, f"= {numbers[key]:g} must be > 0")
    if numbers.get("self_radius_px", 0.0) < 0.0:
        raise _fail(where, "self_radius_px", "must be >= 0")
    if abs(numbers.get("mount_yaw_deg", 0.0)) > 360.0:
        raise _fail(where, "mount_yaw_deg", "must be within [-360, 360] deg")
    camera: CameraModel | None = None
    if model != "lookup":
        params = {k: v for k, v in numbers.items()
                  if k not in ("usable_radius_px", "mount_yaw_deg")}
        try:
            camera = make_camera(model, width_px=width, height_px=height, cu_px=cu, cv_px=cv,
                                 **params)
        except (ValueError, TypeError) as err:
            raise _fail(where, "model", f"{model} cannot be made: {err}") from err
    calibration, rms = (None, None) if "calibration" not in entry else _calibration(
        where, entry["calibration"])
    if model == "lookup" and "height_m" in numbers and calibration is not None:
        rim = numbers.get("max_radius_px", numbers.get("usable_radius_px", max(width, height) / 2))
        try:  # the calibration and the camera's height make a projection model
            camera = table_camera(calibration, height_m=numbers["height_m"], width_px=width,
                                  height_px=height, centre_px=(cu, cv), max_radius_px=rim)
        except ValueError as err:
            raise _fail(where, "height_m", f"with its calibration makes no camera: {err}") from err
    return CameraSpec(
        model=model, width_px=width, height_px=height, centre_px=(cu, cv), camera=camera,
        calibration=calibration, calibration_rms_m=rms,
        max_radius_px=numbers.get("max_radius_px"),
        usable_radius_px=numbers.get("usable_radius_px"),
        mount_yaw_rad=math.radians(numbers.get("mount_yaw_deg", 0.0)),
        ball=None if "ball" not in entry else _ball(where, entry["ball"]),
        map_to_field=None if "map_to_field" not in entry else _transform(
            where, entry["map_to_field"]),
        entry=dict(entry),
    )


def camera_set_from_json(doc: Any, source: str, *, field: FieldSpec | None = None
                         ) -> CameraSet:
    """Every entry of a description (robot name or ``default`` -> entry); ``source`` names it
    in errors (a file's path, or ``"LOG: metadata dsp.cameras"``). ``field``: the field the
    description names (a camera file's ``field`` key, read by
    :func:`dsp.field_file.field_from_json`); a description that names one may describe no
    camera (the log's metadata describes them)."""
    doc = _object(source, "", doc)
    default_entry = doc.get(DEFAULT_ENTRY)
    if default_entry is not None:
        default_entry = _object(f"{source}: {DEFAULT_ENTRY}", "", default_entry)
    robots: dict[str, CameraSpec] = {}
    for name, entry in doc.items():
        if name == DEFAULT_ENTRY:
            continue
        if not isinstance(name, str) or not name:
            raise CameraDescriptionError(f"{source}: {name!r} is not a robot name")
        merged = {**(default_entry or {}), **_object(f"{source}: {name}", "", entry)}
        robots[name] = camera_spec_from_json(merged, f"{source}: {name}")
    default = None if default_entry is None else camera_spec_from_json(
        default_entry, f"{source}: {DEFAULT_ENTRY}")
    if not robots and default is None and field is None:
        raise CameraDescriptionError(f"{source}: describes no camera (give a {DEFAULT_ENTRY!r} "
                                     "entry or one per robot)")
    return CameraSet(robots, default, source, field)


PAPER_CAMERA = camera_spec_from_json({
    "model": "lookup", "width_px": PAPER_IMAGE_SIZE_PX, "height_px": PAPER_IMAGE_SIZE_PX,
    "cu_px": PAPER_CENTRE_PX[0], "cv_px": PAPER_CENTRE_PX[1],
    "calibration": PAPER_CALIBRATION.to_dict(),
}, "the paper's camera")
"""The paper's camera, asked for by name (``--cameras paper``): a 1080 x 1080 image centred
at (539, 539), image up = robot forward, eq. 4's linear calibration."""
