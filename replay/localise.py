"""``--localise lines``: each frame's pose corrected from its own image before the ball is
located (:mod:`estimator.localisation`).

A robot believes a pose (its ``/robotN/pose``), which a real robot's localisation gets wrong
by centimetres and a degree or so; the same omni image that sees the ball sees the field's
white lines. :class:`Localiser` is built once per replay from the field the log's scenario
metadata or the camera file names (:func:`field_for`, :mod:`dsp.field`) and each robot's
camera model, and splits the work three
ways, so that the part that needs the image alone runs in the look-ahead's threads
(:mod:`replay.ahead`), the fit (many small numpy calls, which hold the GIL) on the replay's
own thread, and the results are the same bytes whatever the thread count:

1. :meth:`Localiser.points`: the image's line points (needs the image alone; pure);
2. :meth:`Localiser.fit`: the pose that fits them, around the believed pose at the image's
   stamp with the covariance ``--pose-sigma`` states, else the one the robot's own fits
   showed so far (:meth:`Localiser.prior`, :mod:`estimator.localisation.spread`) (pure);
3. :meth:`Localiser.settle`: in frame order, on the replay's own thread: a failed fit takes
   the robot's last correction while it is recent (:class:`~estimator.localisation.
   CorrectionHold`), else the believed pose stays; the frame's :class:`~replay.records.
   Localisation` says which.

A robot whose log names no camera model is not corrected (status ``no_camera``).
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from dsp.errors import UsageError
from dsp.field import DEFAULT_FIELD, Circle, FieldSpec, Rect, Segment, markings
from dsp.jsonio import Json
from estimator.camera import CameraModel
from estimator.errors import LocalisationError
from estimator.geometry import RobotPose
from estimator.localisation import (
    CorrectionHold,
    CorrectionSpread,
    DistanceGrid,
    FieldLines,
    GroundGrid,
    LinePoints,
    PoseCorrection,
    correct_pose,
    detect_line_points,
)
from replay.records import Localisation

__all__ = [
    "NO_CAMERA",
    "LocalisedPoints",
    "Localiser",
    "check_field",
    "field_for",
    "field_lines_for",
    "prior_covariance",
]

WARM_AGE_NS = 500_000_000
"""A robot's correction at most this old starts the next fit (:meth:`Localiser.start`)."""

NO_CAMERA = "no_camera"
"""The status of a robot the log names no camera model for (not corrected)."""


def field_lines_for(spec: FieldSpec) -> FieldLines:
    """The field's markings (:func:`dsp.field.markings`) as the pose fit measures them."""
    rects: list[tuple[float, float, float, float]] = []
    segments: list[tuple[float, float, float, float]] = []
    circles: list[tuple[float, float, float]] = []
    marks: list[tuple[float, float, float]] = []
    for m in markings(spec):
        if isinstance(m, Rect):
            rects.append((m.x0, m.y0, m.x1, m.y1))
        elif isinstance(m, Segment):
            segments.append((m.x0, m.y0, m.x1, m.y1))
        elif isinstance(m, Circle):
            (marks if m.filled else circles).append((m.x, m.y, m.radius_m))
    return FieldLines.from_shapes(half_length_m=spec.half_length_m,
                                  half_width_m=spec.half_width_m, rects=rects,
                                  segments=segments, circles=circles, marks=marks,
                                  line_width_m=spec.line_width_m)


@dataclass(frozen=True, eq=False)
class LocalisedPoints:
    """An image's line points (robot frame) and where they are in the image [px]."""

    points: LinePoints
    camera: CameraModel
    camera_xy_m: np.ndarray
    """(N, 2): the points in the camera's frame (before its mount yaw is turned back)."""

    @functools.cached_property
    def pixels(self) -> np.ndarray:
        """(N, 2) float32: (u, v) of each point, for the viewer (worked out when asked)."""
        if not len(self.camera_xy_m):
            return np.zeros((0, 2), np.float32)
        rays = np.column_stack([self.camera_xy_m, np.full(len(self.camera_xy_m),
                                                          -self.camera.height_m)])
        return np.asarray(self.camera.ray_to_pixel(rays), np.float32).reshape(-1, 2)


def prior_covariance(sigma_m: float, sigma_deg: float) -> np.ndarray:
    """The believed pose's covariance over (x, y, yaw) from its standard deviations."""
    s_yaw = math.radians(sigma_deg)
    return np.diag([sigma_m**2, sigma_m**2, s_yaw**2])


class Localiser:
    """The field-line correction of every robot's pose in one replay (module docstring)."""

    def __init__(self, field: FieldSpec, cameras: Mapping[str, CameraModel], *,
                 sigma_m: float, sigma_deg: float,
                 mount_yaw_rad: Mapping[str, float] | None = None,
                 learn: bool = False) -> None:
        self.field = field
        self.lines = field_lines_for(field)
        self.distance = DistanceGrid.build(self.lines)
        self.cameras = dict(cameras)
        self.mount_yaw_rad = dict(mount_yaw_rad or {})
        """Robot -> how far its camera is turned on it [rad]: the points are turned back."""
        by_model: dict[str, GroundGrid] = {}
        self.grids: dict[str, GroundGrid] = {}
        for robot, camera in sorted(self.cameras.items()):  # one grid per distinct model
            key = json.dumps(camera.to_dict(), sort_keys=True)
            if key not in by_model:
                by_model[key] = GroundGrid.build(camera)
            self.grids[robot] = by_model[key]
        self.prior_covariance = prior_covariance(sigma_m, sigma_deg)
        """The fits' prior covariance when it is not learnt (``learn`` False), else only that
        of a fit asked for without one."""
        self.spread = CorrectionSpread() if learn else None
        """Each robot's pose spread as its fits show it: its next fit's prior."""
        self.hold = CorrectionHold()

    def points(self, robot: str, image: np.ndarray | None) -> LocalisedPoints | None:
        """The image's line points (None: no image, or no camera model for the robot).
        Pure and thread-safe."""
        grid = self.grids.get(robot)
        if image is None or grid is None:
            return None
        try:
            pts = detect_line_points(image, grid)
        except LocalisationError:  # an image of another size than the camera's
            return None
        camera_xy = pts.xy_m
        yaw = self.mount_yaw_rad.get(robot, 0.0)
        if yaw:  # the camera's frame turned into the robot's
            c, s = math.cos(yaw), math.sin(yaw)
            xy = pts.xy_m @ np.array([[c, s], [-s, c]])
            pts = LinePoints(xy, pts.sigma_m, pts.contrast)
        return LocalisedPoints(pts, self.cameras[robot], camera_xy)

    def beliefs(self, learnt: dict[str, dict[str, Json]]) -> dict[str, dict[str, Json]]:
        """``learnt`` (``summary.learnt``) with, per robot its fits learnt from, how far its
        belief was off (``line_sigma_m``, ``line_sigma_deg``: the spread its next fit would
        search with) and from how many fits (``line_fits``)."""
        for robot in sorted(self.grids):
            if self.spread is not None and self.spread.count(robot):
                cov = self.spread.covariance(robot)
                learnt.setdefault(robot, {}).update(
                    line_sigma_m=round(math.sqrt(cov[0, 0]), 6),
                    line_sigma_deg=round(math.degrees(math.sqrt(cov[2, 2])), 6),
                    line_fits=self.spread.count(robot))
        return learnt

    def start(self, robot: str, stamp_ns: int, believed: RobotPose) -> RobotPose | None:
        """Where the fit of the robot's frame at ``stamp_ns`` starts: its last settled
        correction carried to ``believed`` while at most :data:`WARM_AGE_NS` old (the
        error drifts over seconds), else None (from the belief, every stage). Called in
        frame order, on the replay's own thread."""
        return self.hold.carried(robot, stamp_ns, believed, WARM_AGE_NS)

    def prior(self, robot: str) -> np.ndarray:
        """The covariance the robot's next fit searches with: learnt from its fits so far, or
        the one given. Called in frame order, on the replay's own thread."""
        return self.prior_covariance if self.spread is None else self.spread.covariance(robot)

    def fit(self, points: LocalisedPoints | None, believed: RobotPose,
            start: RobotPose | None = None,
            prior: np.ndarray | None = None) -> PoseCorrection | None:
        """The pose the points give around ``believed`` (covariance ``prior``, else the one
        given), searched from ``start`` when given (None: no points to fit). Pure and
        thread-safe."""
        if points is None:
            return None
        return correct_pose(believed, self.prior_covariance if prior is None else prior,
                            points.points, self.distance, self.lines, start=start)

    def settle(self, robot: str, stamp_ns: int, believed: RobotPose,
               correction: PoseCorrection | None,
               points: LocalisedPoints | None, prior: np.ndarray | None = None) -> Localisation:
        """The frame's pose, in frame order: the fit, a held earlier one or the belief
        (``prior``: the covariance the fit searched with)."""
        prior = self.prior_covariance if prior is None else prior
        if correction is not None and self.spread is not None:
            self.spread.observe(robot, stamp_ns, believed, correction)
        if correction is None:
            cov = prior
            status = NO_CAMERA if robot not in self.grids else "too_few_points"
            return Localisation(believed, _rows3(cov), status, "prior", 0, 0,
                                points)
        held = self.hold.update(robot, stamp_ns, believed, prior, correction)
        return Localisation(held.pose, _rows3(held.covariance), correction.status.value,
                            held.source, correction.points, correction.inliers,
                            points)


def _rows3(m: np.ndarray) -> tuple[tuple[float, float, float], ...]:
    a = np.asarray(m, dtype=np.float64)
    return tuple((float(r[0]), float(r[1]), float(r[2])) for r in a)


def field_for(scenario_field: FieldSpec | None, file_field: FieldSpec | None,
              file: str | None) -> tuple[FieldSpec | None, str | None]:
    """The field the replay localises on, and a note when the camera file overrides the
    log: the log's scenario metadata names it, else the camera file (``file``) does. Where
    both name one and they differ, the camera file wins: it is the user's own statement
    about this replay (a log recorded on one field and replayed as played on another, or
    metadata that is wrong), and the note says so."""
    if file_field is None:
        return scenario_field, None
    if scenario_field is None or dataclasses.replace(file_field, name="") == \
            dataclasses.replace(scenario_field, name=""):
        return (scenario_field or file_field), None
    return file_field, (f"field {file_field.name} from {file} (the log's dsp.scenario names "
                        f"{scenario_field.name})")


def check_field(field: FieldSpec | None, log: str) -> FieldSpec:
    """The field to localise on (:func:`field_for`), or the error that says how to name it."""
    if field is None:
        raise UsageError(f"--localise lines: {log} has no dsp.scenario metadata naming the "
                         f"field and the camera file names none; the lines' geometry is "
                         f"unknown: name it in the camera file (field: {DEFAULT_FIELD}), or "
                         "use --localise none")
    return field
