"""The log's metadata records, typed: frozen, validated, to and from MCAP metadata.

MCAP metadata is name -> {str: str}; the names are :data:`dsp.contract.SCENARIO_METADATA`,
:data:`~dsp.contract.CAMERAS_METADATA` and :data:`~dsp.contract.RECORDER_METADATA`. The recorder
writes these records with ``to_metadata()``; the replay reader parses them once with
``from_metadata()``, and nothing downstream looks a key up in a dict. A record that cannot
be read raises :class:`MetadataError`, never a silent fallback.
"""

from __future__ import annotations

import dataclasses
import json
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from dataclasses import field as dc_field
from typing import Any, ClassVar

from dsp import jsonio
from dsp.cameras import (
    CameraDescriptionError,
    CameraSet,
    CameraSpec,
    camera_set_from_json,
    camera_spec_from_json,
)
from dsp.contract import CAMERAS_METADATA, RECORDER_METADATA, SCENARIO_METADATA
from dsp.errors import InputError
from dsp.field import DEFAULT_FIELD, FIELDS, FieldSpec

__all__ = ["CameraMetadata", "CamerasMetadata", "MetadataError", "RecorderMetadata",
           "RecordingMetadata", "ScenarioMetadata", "json_text"]


class MetadataError(InputError, ValueError):
    """A log's metadata record cannot be read: the message names the record, key and value."""


def json_text(obj: Any) -> str:
    """Canonical JSON (sorted keys, no spaces) so metadata bytes never vary."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"))


def _get(record: str, data: Mapping[str, Any], key: str) -> Any:
    if key not in data:
        raise MetadataError(f"{record}: no {key!r} (has {', '.join(map(repr, data)) or 'none'})")
    return data[key]


def _int(record: str, key: str, value: Any) -> int:
    if isinstance(value, int) and not isinstance(value, bool):
        return value
    if isinstance(value, str) and re.fullmatch(r"-?\d+", value.strip()):
        return int(value)
    raise MetadataError(f"{record}: {key} = {value!r} is not an integer")


def _float(record: str, key: str, value: Any) -> float:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value)
    raise MetadataError(f"{record}: {key} = {value!r} is not a number")


def _str(record: str, key: str, value: Any) -> str:
    if isinstance(value, str) and value:
        return value
    raise MetadataError(f"{record}: {key} = {value!r} is not a non-empty string")


def _bool(record: str, key: str, value: Any) -> bool:
    if isinstance(value, bool):
        return value
    raise MetadataError(f"{record}: {key} = {value!r} is not true or false")


def _int_map(record: str, key: str, value: Any) -> dict[str, int]:
    if isinstance(value, Mapping):
        return {str(k): _int(record, f"{key}.{k}", v) for k, v in value.items()}
    raise MetadataError(f"{record}: {key} = {value!r} is not a JSON object of integers")


def _json_object(record: str, key: str, text: Any) -> dict[str, Any]:
    try:
        value = jsonio.loads(text)
    except (TypeError, ValueError) as err:
        raise MetadataError(f"{record}: {key} is not JSON ({err}): {str(text)[:80]!r}") from err
    if not isinstance(value, dict):
        raise MetadataError(f"{record}: {key} is not a JSON object: {str(text)[:80]!r}")
    return value


@dataclass(frozen=True)
class RecordingMetadata:
    """How the recorder sampled a scenario (``params["recording"]`` of ``dsp.scenario``)."""

    rate_hz: float
    """Camera frames per second."""
    pose_rate_hz: float
    """Poses, /tf and ground truth per second (twice the camera rate)."""
    frames: int
    camera: str
    """The camera model's name (estimator.camera.CAMERA_MODELS)."""
    image_format: str
    pose_noise_m: float
    """Standard deviation of the believed position's noise."""
    yaw_noise_deg: float
    """Standard deviation of the believed yaw's noise."""
    face_px: int
    physics_hz: int
    # --- written by recordings that use them (match play; older logs have none) ---------
    camera_phase: str | None = None
    """"sync" (every camera fires at the same stamps) or "random" (each its own phase)."""
    camera_offsets_ns: Mapping[str, int] | None = None
    """Robot -> the stamp of its first image [ns]."""
    pose_bias_m: float | None = None
    """Stationary std of the believed position's drifting bias (an OU process)."""
    yaw_bias_deg: float | None = None
    """Stationary std of the believed yaw's drifting bias."""
    pose_bias_tau_s: float | None = None
    """Time constant of the drifting bias."""
    exposure_ms: float | None = None
    """Exposure time (the blur's length); the stamp marks the exposure's end."""
    image_noise: float | None = None
    """Std of the Gaussian pixel noise [grey levels]."""
    gain_jitter: float | None = None
    """Stationary std of the log gain (an OU process, time constant 1 s)."""
    ball_odometry: bool | None = None
    """True when the log has the ball's true velocity on /ground_truth/ball/odometry."""
    # --- the venue's trouble and lobs: written only when not the default (older logs and
    # recordings without them read as the defaults) -------------------------------------
    ball_colour: str = "orange"
    """The ball's colour: "orange", "yellow" or "white"."""
    ball_pattern: str = "plain"
    """"plain" (one colour), "panels" (a football's pentagons and hexagons) or "bands"."""
    people: int = 0
    """Figures in shirts of the ball's colour beside the field (``scene["scenery"]``)."""
    covers: int = 0
    """Robots dressed in a skirt of the ball's colour."""
    light_pools: int = 0
    """Lamps lighting the field unevenly (0: the even light)."""
    lob_fraction: float = 0.0
    """Share of the kicks that are lobs (1 for the lobs scenario; ``scene["flight"]`` then
    holds the ball's physics in the air)."""

    _FIELDS: ClassVar[dict[str, Callable[[str, str, Any], Any]]] = {
        "rate_hz": _float, "pose_rate_hz": _float, "pose_noise_m": _float,
        "yaw_noise_deg": _float, "frames": _int, "face_px": _int, "physics_hz": _int,
        "camera": _str, "image_format": _str,
    }
    _OPTIONAL: ClassVar[dict[str, Callable[[str, str, Any], Any]]] = {
        "camera_phase": _str, "camera_offsets_ns": _int_map, "pose_bias_m": _float,
        "yaw_bias_deg": _float, "pose_bias_tau_s": _float, "exposure_ms": _float,
        "image_noise": _float, "gain_jitter": _float, "ball_odometry": _bool,
    }
    _DEFAULTED: ClassVar[dict[str, Callable[[str, str, Any], Any]]] = {
        "ball_colour": _str, "ball_pattern": _str, "people": _int, "covers": _int,
        "light_pools": _int, "lob_fraction": _float,
    }

    def to_json(self) -> dict[str, Any]:
        """The JSON object written as ``params["recording"]`` (optional keys only when set)."""
        out = {k: parse("", k, getattr(self, k)) for k, parse in self._FIELDS.items()}
        out.update({k: parse("", k, v) for k, parse in self._OPTIONAL.items()
                    if (v := getattr(self, k)) is not None})
        defaults = {f.name: f.default for f in dataclasses.fields(self)}
        out.update({k: parse("", k, v) for k, parse in self._DEFAULTED.items()
                    if (v := getattr(self, k)) != defaults[k]})
        return out

    @classmethod
    def from_json(cls, obj: Mapping[str, Any], record: str = "recording") -> RecordingMetadata:
        """Parse ``params["recording"]``; raises :class:`MetadataError` naming what is wrong."""
        values = {k: parse(record, k, _get(record, obj, k)) for k, parse in cls._FIELDS.items()}
        values.update({k: parse(record, k, obj[k])
                       for k, parse in (*cls._OPTIONAL.items(), *cls._DEFAULTED.items())
                       if k in obj})
        return cls(**values)


@dataclass(frozen=True)
class ScenarioMetadata:
    """The ``dsp.scenario`` record: ``{"name", "seed", "params": JSON object}``.

    ``params`` holds the scenario's own parameters (``scene``: robots, ball, ...), the field's
    name (``field``) and how it was recorded (``recording``).
    """

    name: str
    seed: int
    field_name: str | None = None
    """A name in :data:`dsp.field.FIELDS`; None when the log names no field."""
    recording: RecordingMetadata | None = None
    scene: Mapping[str, Any] = dc_field(default_factory=dict)
    """The scenario's other parameters as JSON values (read-only by convention)."""

    def __post_init__(self) -> None:
        if self.field_name is not None and self.field_name not in FIELDS:
            raise MetadataError(f"{SCENARIO_METADATA}: unknown field {self.field_name!r}; "
                                f"known fields: {', '.join(FIELDS)}")
        clash = {"field", "recording"} & set(self.scene)
        if clash:
            raise MetadataError(f"{SCENARIO_METADATA}: scene repeats {sorted(clash)}")
        # JSON values only (tuples become lists): a record equals its own round trip
        object.__setattr__(self, "scene", json.loads(json_text(self.scene)))

    @property
    def field(self) -> FieldSpec:
        """The field the scene was played on (the paper's 18x12 when the log names none)."""
        return FIELDS[self.field_name or DEFAULT_FIELD]

    @property
    def pose_rate_hz(self) -> float | None:
        return None if self.recording is None else self.recording.pose_rate_hz

    def params(self) -> dict[str, Any]:
        """The ``params`` JSON object."""
        out = dict(self.scene)
        if self.field_name is not None:
            out["field"] = self.field_name
        if self.recording is not None:
            out["recording"] = self.recording.to_json()
        return out

    def to_metadata(self) -> dict[str, str]:
        return {"name": self.name, "seed": str(self.seed), "params": json_text(self.params())}

    @classmethod
    def from_metadata(cls, data: Mapping[str, str]) -> ScenarioMetadata:
        rec = SCENARIO_METADATA
        params = _json_object(rec, "params", _get(rec, data, "params"))
        field_name = params.pop("field", None)
        if field_name is not None:
            field_name = _str(rec, "params.field", field_name)
        recording = params.pop("recording", None)
        if recording is not None:
            if not isinstance(recording, dict):
                raise MetadataError(f"{rec}: params.recording is not a JSON object")
            recording = RecordingMetadata.from_json(recording, f"{rec} params.recording")
        return cls(name=_str(rec, "name", _get(rec, data, "name")),
                   seed=_int(rec, "seed", _get(rec, data, "seed")),
                   field_name=field_name, recording=recording, scene=params)


@dataclass(frozen=True)
class CameraMetadata:
    """One robot's camera: the entry of :mod:`dsp.cameras` (the ``estimator.camera`` model
    dict the recorder writes, with the optional keys a camera file may add), parsed."""

    robot: str
    model: Mapping[str, Any]
    """The entry as written (JSON values)."""
    spec: CameraSpec = dc_field(init=False, compare=False, repr=False)
    """The entry validated (:func:`dsp.cameras.camera_spec_from_json`)."""

    def __post_init__(self) -> None:
        _str(CAMERAS_METADATA, f"{self.robot}.model", self.model.get("model"))
        try:
            spec = camera_spec_from_json(dict(self.model), f"{CAMERAS_METADATA}: {self.robot}")
        except CameraDescriptionError as err:
            raise MetadataError(str(err)) from err
        object.__setattr__(self, "spec", spec)


@dataclass(frozen=True)
class CamerasMetadata:
    """The ``dsp.cameras`` record: ``{robot name: JSON object of its camera}`` (a ``default``
    entry too, as in a camera file; :mod:`dsp.cameras`)."""

    cameras: tuple[CameraMetadata, ...] = ()

    def by_robot(self) -> dict[str, Mapping[str, Any]]:
        """Robot name -> camera entry as written."""
        return {c.robot: c.model for c in self.cameras}

    def camera_set(self, source: str = CAMERAS_METADATA) -> CameraSet | None:
        """The cameras as a :class:`~dsp.cameras.CameraSet` (None: the record names none);
        a robot's entry goes over the ``default`` one, as in a camera file."""
        if not self.cameras:
            return None
        try:
            return camera_set_from_json(self.by_robot(), source)
        except CameraDescriptionError as err:
            raise MetadataError(str(err)) from err

    def to_metadata(self) -> dict[str, str]:
        return {c.robot: json_text(dict(c.model)) for c in self.cameras}

    @classmethod
    def from_metadata(cls, data: Mapping[str, str]) -> CamerasMetadata:
        return cls(tuple(
            CameraMetadata(robot, _json_object(CAMERAS_METADATA, robot, text))
            for robot, text in data.items()
        ))


@dataclass(frozen=True)
class RecorderMetadata:
    """The ``dsp.recorder`` record: renderer, physics and image settings, package versions."""

    renderer: str
    """"egl" or "tiny"."""
    physics_hz: int
    face_px: int
    versions: Mapping[str, str] = dc_field(default_factory=dict)
    """Distribution (dual_sight, pybullet, numpy, opencv, mcap, mcap_ros2, python) -> version."""

    _KEYS = ("renderer", "physics_hz", "face_px")

    def __post_init__(self) -> None:
        clash = set(self._KEYS) & set(self.versions)
        if clash:
            raise MetadataError(f"{RECORDER_METADATA}: versions repeat {sorted(clash)}")

    def to_metadata(self) -> dict[str, str]:
        return {"renderer": self.renderer, "physics_hz": str(self.physics_hz),
                "face_px": str(self.face_px), **self.versions}

    @classmethod
    def from_metadata(cls, data: Mapping[str, str]) -> RecorderMetadata:
        rec = RECORDER_METADATA
        return cls(renderer=_str(rec, "renderer", _get(rec, data, "renderer")),
                   physics_hz=_int(rec, "physics_hz", _get(rec, data, "physics_hz")),
                   face_px=_int(rec, "face_px", _get(rec, data, "face_px")),
                   versions={k: str(v) for k, v in data.items() if k not in cls._KEYS})
