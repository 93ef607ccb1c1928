"""Result records and the deterministic results-file writer.

The results file is JSON with sorted keys and floats rounded to :data:`DECIMALS` places; it
holds nothing machine-dependent (no wall-clock time, no absolute paths, no timings), so the
same log and options give the same bytes. Frames and fused steps are spooled to temporary
files while replaying, so memory stays flat however long the log.

Schema (``format`` = "dsp-replay-results", ``version`` = 1)::

    {"format", "version",
     "log": {"file": basename, "sha256", "robots": [...], "recovered": {...} | null},
     "options": {"method", "fusion", "calibration", "pose_tolerance_s", "window_s", ...},
     "frames": [{"frame", "robot", "stamp_ns", "t_s", "status",
                 "detection": {"cx_px", "cy_px", "r_px", "area_px", "bbox_px",
                               "circularity"} | null,
                 "pose": {"x_m", "y_m", "yaw_rad", "gap_s", "interpolated"} | null,
                 "estimate": {"x_m", "y_m", "range_m", "bearing_rad", "visibility"} | null,
                 "truth": {"x_m", "y_m"} | null, "error_m": float | null}, ...],
     "fused": [{"step", "stamp_ns", "t_s", "robots": [...], "x_m", "y_m",
                "covariance": [[xx, xy], [yx, yy]], "truth": {...} | null,
                "error_m": float | null,
                "velocity_m_s": [vx, vy], "velocity_covariance": [[..], [..]],
                "truth_velocity_m_s": [vx, vy], "velocity_error_m_s": float}, ...],
     "summary": {"frames", "steps", "fused_steps", "skipped": {reason: n},
                 "robots": {name: {"frames", "detections", "estimates", "rmse_m", "mean_error_m",
                                   "max_error_m", "errors"}},
                 "fused": {"estimates", "rmse_m", "mean_error_m", "max_error_m", "errors",
                           "velocity": {"errors", "rmse_m_s", "mean_error_m_s",
                                        "max_error_m_s"}},
                 "undecodable_messages"}}

``status`` is one of :data:`FRAME_STATUSES`. Errors are Euclidean distances [m] to the
ground truth interpolated at the frame's (step's) stamp; RMSE = sqrt(mean(error^2)).
The velocity keys are there only when the fusion estimates a velocity (``track``): the
velocity [m/s] and its covariance [m^2/s^2]; the truth's velocity and the error's norm
[m/s] only when the log holds the ball's true velocity (``/ground_truth/ball/odometry``),
and so the summary's ``fused.velocity``.
"""

from __future__ import annotations

import enum
import io
import json
import math
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any, Protocol

import numpy as np

from dsp.atomic import AtomicFile
from estimator.constants import PAPER_CENTRE_PX
from replay.sink import SinkBase

__all__ = [
    "DECIMALS",
    "FRAME_STATUSES",
    "FrameResult",
    "FrameStatus",
    "ResultsCollector",
    "ResultsHeader",
    "ResultsWriter",
    "RobotEstimate",
    "StepResult",
    "normalise",
]

DECIMALS = 6


class FrameStatus(str, enum.Enum):
    """How far an image got through the estimator (the results file's ``status``)."""

    OK = "ok"
    NO_DETECTION = "no_detection"
    NO_POSE = "no_pose"
    BAD_IMAGE = "bad_image"
    DETECT_ERROR = "detect_error"
    OUT_OF_RANGE = "out_of_range"

    @property
    def skipped(self) -> bool:
        """True when the frame counts as skipped (a frame without a ball is not)."""
        return self not in (FrameStatus.OK, FrameStatus.NO_DETECTION)


FRAME_STATUSES = tuple(s.value for s in FrameStatus)


@dataclass(frozen=True)
class RobotEstimate:
    """One robot's ball estimate in the field frame [m]; bearing in the robot frame [rad]."""

    robot: str
    x_m: float
    y_m: float
    range_m: float
    bearing_rad: float
    robot_x_m: float
    robot_y_m: float
    robot_yaw_rad: float
    visibility: float = 1.0
    """Detected blob area / a whole ball's expected area at this range (1: unknown)."""


@dataclass(frozen=True)
class FrameResult:
    """What replay made of one image."""

    frame: int
    robot: str
    stamp_ns: int
    status: FrameStatus
    detection: Any = None  # estimator.detection.Detection | None
    r_px: float | None = None
    centre_px: tuple[float, float] = PAPER_CENTRE_PX
    pose: Any = None  # estimator.geometry.RobotPose | None
    pose_gap_ns: int | None = None
    pose_interpolated: bool = False
    estimate: RobotEstimate | None = None
    truth: tuple[float, float] | None = None
    error_m: float | None = None
    estimator_s: float = 0.0
    """Wall time of detection + estimation [s]: for display only, never in results files."""


@dataclass(frozen=True)
class StepResult:
    """One fusion step: the robots' frames within the window and their fused estimate."""

    step: int
    stamp_ns: int
    frames: tuple[FrameResult, ...]
    fused: Any = None  # estimator.estimates.FusedEstimate | None
    truth: tuple[float, float] | None = None
    error_m: float | None = None
    velocity_m_s: tuple[float, float] | None = None
    """The fused velocity [m/s] (field frame), when the fusion estimates one (``track``)."""
    velocity_covariance: tuple[tuple[float, float], tuple[float, float]] | None = None
    """Its 2 x 2 covariance [m^2/s^2]."""
    truth_velocity_m_s: tuple[float, float] | None = None
    """The ball's true velocity at the step's stamp, when the log holds it."""

    @property
    def velocity_error_m_s(self) -> float | None:
        """|v - v_true| [m/s] when both are known."""
        if self.velocity_m_s is None or self.truth_velocity_m_s is None:
            return None
        return math.hypot(self.velocity_m_s[0] - self.truth_velocity_m_s[0],
                          self.velocity_m_s[1] - self.truth_velocity_m_s[1])


def normalise(value: Any) -> Any:
    """Round floats to DECIMALS places (-0.0 -> 0.0, non-finite -> None), recursively."""
    if isinstance(value, bool) or value is None or isinstance(value, (int, str)):
        return value
    if isinstance(value, float):
        if not math.isfinite(value):
            return None
        r = round(value, DECIMALS)
        return 0.0 if r == 0 else r
    if isinstance(value, dict):
        return {str(k): normalise(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [normalise(v) for v in value]
    if hasattr(value, "item"):  # numpy scalar
        return normalise(value.item())
    raise TypeError(f"cannot write {type(value).__name__} to a results file")


def _dumps(value: Any) -> str:
    return json.dumps(normalise(value), sort_keys=True, separators=(", ", ": "),
                      ensure_ascii=True, allow_nan=False)


def frame_to_dict(f: FrameResult) -> dict[str, Any]:
    det = f.detection
    est = f.estimate
    return {
        "frame": f.frame,
        "robot": f.robot,
        "stamp_ns": f.stamp_ns,
        "t_s": f.stamp_ns / 1e9,
        "status": f.status.value,
        "detection": None if det is None else {
            "cx_px": float(det.cx_px), "cy_px": float(det.cy_px), "r_px": f.r_px,
            "area_px": float(det.area_px), "bbox_px": [int(v) for v in det.bbox_px],
            "circularity": float(det.circularity),
        },
        "pose": None if f.pose is None else {
            "x_m": f.pose.x_m, "y_m": f.pose.y_m, "yaw_rad": f.pose.yaw_rad,
            "gap_s": (f.pose_gap_ns or 0) / 1e9, "interpolated": f.pose_interpolated,
        },
        "estimate": None if est is None else {
            "x_m": est.x_m, "y_m": est.y_m, "range_m": est.range_m,
            "bearing_rad": est.bearing_rad, "visibility": est.visibility,
        },
        "truth": None if f.truth is None else {"x_m": f.truth[0], "y_m": f.truth[1]},
        "error_m": f.error_m,
    }


def step_to_dict(s: StepResult) -> dict[str, Any]:
    fused = s.fused
    out: dict[str, Any] = {
        "step": s.step,
        "stamp_ns": s.stamp_ns,
        "t_s": s.stamp_ns / 1e9,
        "robots": sorted(f.robot for f in s.frames if f.estimate is not None),
        "fused_robots": None if fused is None else sorted(fused.robots),
        "x_m": None if fused is None else fused.x_m,
        "y_m": None if fused is None else fused.y_m,
        "covariance": None if fused is None else [list(row) for row in fused.covariance],
        "truth": None if s.truth is None else {"x_m": s.truth[0], "y_m": s.truth[1]},
        "error_m": s.error_m,
    }
    if not s.frames:  # a tick of --clock's clock: no image in it
        out["tick"] = True
    # velocity keys only where there is a velocity: window fusions' files stay as they were
    if s.velocity_m_s is not None:
        out["velocity_m_s"] = list(s.velocity_m_s)
        out["velocity_covariance"] = (None if s.velocity_covariance is None
                                      else [list(row) for row in s.velocity_covariance])
    if s.truth_velocity_m_s is not None:
        out["truth_velocity_m_s"] = list(s.truth_velocity_m_s)
    if s.velocity_error_m_s is not None:
        out["velocity_error_m_s"] = s.velocity_error_m_s
    return out


@dataclass(frozen=True)
class ResultsHeader:
    """What the results file says of the log and the options."""

    file: str
    """The log's base name."""
    sha256: str
    robots: tuple[str, ...]
    options: dict[str, Any]
    """:meth:`replay.options.ReplayOptions.results_view`."""


class ResultsCollector(SinkBase):
    """Sink keeping the results file's ``frames`` and ``fused`` lists in memory, exactly as
    the file would hold them (rounded): for callers that score a replay without writing it."""

    def __init__(self) -> None:
        self.frames: list[dict[str, Any]] = []
        self.fused: list[dict[str, Any]] = []

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        self.frames.append(normalise(frame_to_dict(result)))

    def step(self, result: StepResult) -> None:
        self.fused.append(normalise(step_to_dict(result)))


class SummarySource(Protocol):
    """What the results header needs from the replay's statistics."""

    recovered: dict[str, Any] | None

    def summary_dict(self) -> dict[str, Any]: ...


def _head(header: ResultsHeader, stats: SummarySource) -> dict[str, Any]:
    return {
        "format": "dsp-replay-results", "version": 1,
        "log": {"file": header.file, "sha256": header.sha256, "robots": list(header.robots),
                "recovered": stats.recovered},
        "options": header.options,
        "summary": stats.summary_dict(),
    }


class ResultsWriter(SinkBase):
    """Sink writing the results JSON to ``path`` (refuses an existing file unless ``force``);
    frames and steps are spooled to temporary files, so memory stays flat."""

    def __init__(self, path: Path, *, header: ResultsHeader, stats: SummarySource,
                 force: bool = False) -> None:
        self.header = header
        self.stats = stats
        self._out = AtomicFile(path, force=force)
        self._spools = {key: tempfile.TemporaryFile("w+", encoding="ascii")
                        for key in ("frames", "fused")}
        self._counts = dict.fromkeys(self._spools, 0)

    def _spool(self, key: str, item: dict[str, Any]) -> None:
        f = self._spools[key]
        f.write(("  " if self._counts[key] == 0 else ",\n  ") + _dumps(item))
        self._counts[key] += 1

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        self._spool("frames", frame_to_dict(result))

    def step(self, result: StepResult) -> None:
        self._spool("fused", step_to_dict(result))

    def close(self, ok: bool) -> None:
        """Assemble the file when the replay succeeded, else discard it."""
        try:
            if ok:
                with self._out.guard():  # a full disk: one line naming the results file
                    self._write(self._out.stream())
                self._out.commit()
        finally:
            for spool in self._spools.values():
                spool.close()
            self._out.discard()

    def _write(self, stream: IO[bytes]) -> None:
        doc: dict[str, Any] = {**_head(self.header, self.stats), "frames": None, "fused": None}
        with io.TextIOWrapper(stream, encoding="ascii", newline="\n") as out:
            out.write("{\n")
            keys = sorted(doc)
            for i, key in enumerate(keys):
                out.write(f"{json.dumps(key)}: ")
                if key in self._spools:
                    spool = self._spools[key]
                    spool.seek(0)
                    out.write("[\n")
                    while chunk := spool.read(1 << 16):
                        out.write(chunk)
                    out.write("\n]" if self._counts[key] else "]")
                else:
                    out.write(_dumps(doc[key]))
                out.write(",\n" if i < len(keys) - 1 else "\n")
            out.write("}\n")
