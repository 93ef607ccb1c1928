"""Sink logging a replay to Rerun (rerun-sdk 0.41: ``rr.Scalars``, ``set_time``).

Uses its own :class:`rerun.RecordingStream` (never the global one) whose recording id is
derived from the log's SHA-256 and the options, so the same replay is the same recording.
The entity paths and timelines are listed in ``docs/viewer.md`` (:data:`ENTITY_PATHS`,
checked against a saved .rrd by the tests); the layout is :mod:`replay.sinks.rerun.blueprint`,
the colours and sizes :mod:`replay.sinks.style`; live viewing is :mod:`replay.sinks.rerun.live`.

A series in a plot is broken where there is no value (a frame without an estimate or
without ground truth): the sink logs a :class:`rerun.Clear` there, which Rerun draws as a
gap instead of a straight line across.
"""

from __future__ import annotations

import contextlib
import math
import sys
from collections import deque
from collections.abc import Mapping
from pathlib import Path
from typing import Literal

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
import rerun_bindings as rr_bindings

from dsp.atomic import AtomicFile
from dsp.errors import UsageError
from dsp.field import DEFAULT_FIELD, FIELDS, FieldSpec, polylines
from estimator.constants import NS_PER_S
from estimator.geometry import RobotPose
from replay.beliefs import learnt_markdown
from replay.log import LogInfo
from replay.options import ReplayOptions, RerunTarget
from replay.records import FrameResult, StepResult
from replay.sink import SinkBase
from replay.sinks.rerun import shapes, streams
from replay.sinks.rerun.blueprint import blueprint, scenario_kind
from replay.sinks.rerun.live import (
    Liveness,
    ViewerUnavailableError,
    check_display,
    check_reachable,
    grpc_address,
    reachable,
)
from replay.sinks.results import SummarySource
from replay.sinks.style import (
    BALL_COLOUR,
    BALL_RADIUS_M,
    CANDIDATE_COLOUR,
    FIELD_LINE_COLOUR,
    FUSED_COLOUR,
    LANDING_COLOUR,
    LINE_POINT_COLOUR,
    OUTLINE_COLOUR,
    RADIUS_COLOUR,
    ROBOT_FOOTPRINT_M,
    TRACK_COLOUR,
    TRUTH_COLOUR,
    Rgb,
    robot_colour,
)

__all__ = ["APPLICATION_ID", "ENTITY_PATHS", "LOCALISED_PATHS", "TIMELINES", "RerunSink"]

APPLICATION_ID = "dual_sight_replay"
TIMELINES = ("sim_time", "frame", "step")
"""``sim_time`` (duration from the log's stamps) on everything; ``frame`` (the frame index)
on per-frame data; ``step`` (the fusion step index) on fused data."""
ENTITY_PATHS = (
    "/field", "/field/lines",
    "/field/robots/{robot}", "/field/robots/{robot}/heading", "/field/robots/{robot}/name",
    "/field/robots/{robot}/estimate", "/field/robots/{robot}/ray",
    "/field/robots/{robot}/corrected", "/field/robots/{robot}/corrected/heading",
    "/field/fused", "/field/fused/covariance", "/field/fused/height",
    "/field/ground_truth/ball",
    "/field/track", "/field/track/trail", "/field/track/velocity", "/field/track/landing",
    "/robots/{robot}/camera/image", "/robots/{robot}/camera/centre",
    "/robots/{robot}/camera/detection",
    "/robots/{robot}/camera/detection/centroid", "/robots/{robot}/camera/detection/outline",
    "/robots/{robot}/camera/detection/radius", "/robots/{robot}/camera/detection/label",
    "/robots/{robot}/camera/candidates", "/robots/{robot}/camera/lines",
    "/plots/error/{robot}", "/plots/error/fused", "/plots/speed/track", "/plots/speed/truth",
    "/plots/height/fused", "/plots/height/truth",
    "/plots/blob_area/{robot}", "/plots/pose_sigma/{robot}", "/plots/estimator_ms/{robot}",
    "/summary/learnt",
)
"""Every entity the sink logs (``{robot}`` per robot; the track's only with a tracker, its
landing only with ``ballistic``, the corrected pose and the line points only with
``--localise``, the heights only with a 3-D fusion, pose_sigma with a pose uncertainty, the
summary once the replay has ended)."""
LOCALISED_PATHS = ("/field/robots/{robot}/corrected", "/field/robots/{robot}/corrected/heading",
                   "/robots/{robot}/camera/lines")  # only --localise logs them
TRAIL_S = 3.0  # how much of the track's past the trail shows [s]
_BALL_Z = BALL_RADIUS_M


class RerunSink(SinkBase):
    """Logs frames and steps to a Rerun recording stream (see the module docstring)."""

    def __init__(self, target: RerunTarget, *, info: LogInfo, digest: str,
                 options: ReplayOptions, centres: Mapping[str, tuple[float, float]],
                 field: FieldSpec | None = None,
                 summary: SummarySource | None = None) -> None:
        self.target = target
        self.summary = summary  # what the replay learnt, logged at its end
        self._save: AtomicFile | None = None
        self._liveness: Liveness | None = None
        self.lost: str | None = None  # why the viewer is no longer logged to
        self.broken = False  # the .rrd's writer failed: its recording is left, not closed
        self.info = info
        self.centres = centres
        # the replay's field (the log's or the camera file's), else the log's, else the paper's
        self.field = field or (info.scenario.field if info.scenario else FIELDS[DEFAULT_FIELD])
        opts = options.as_dict()
        for key in ("rerun", "out", "out_mcap", "out_csv", "plot", "force", "progress"):
            opts.pop(key, None)
        self.recording_id = streams.recording_id(digest, opts)
        self.rec = rr.RecordingStream(APPLICATION_ID, recording_id=self.recording_id)
        self.rec.set_log_time_enabled(False)  # sim time only: no wall clock in the recording
        self.colours = {r: robot_colour(i) for i, r in enumerate(info.robots)}
        name = info.scenario.name if info.scenario is not None else None
        self.kind = scenario_kind(name, tracked=options.fusion_method in ("track", "ballistic"))
        self.heights = options.fusion_method in ("triangulate", "ballistic")
        self.candidates = options.detector_name == "real"
        self._trail: deque[tuple[int, float, float, float]] = deque()
        self.names = shapes.NamePlacer()  # the robots' names, clear of robots and the ball
        try:
            self._open(force=options.force)
        except BaseException:
            self._end()
            raise

    def blueprint(self) -> rrb.Blueprint:
        return blueprint(self.info.robots, self.field, self.kind, heights=self.heights)

    def _open(self, *, force: bool) -> None:
        mode, target = self.target.mode, self.target.target
        bp = self.blueprint()
        if mode == "save":
            self._save = AtomicFile(Path(str(target)), force=force)
            streams.check_room(self._save.path)  # a nearly full disk can block Rerun's writer
            try:
                with streams.blueprint_storage(APPLICATION_ID, bp) as storage:
                    rr_bindings.save(path=str(self._save.tmp), default_blueprint=storage,
                                     recording=self.rec.to_native(), write_footer=True)
            except RuntimeError as err:
                self.broken = True
                raise streams.write_failure(self._save.path, err, self.rec) from err
        elif mode == "spawn":
            check_display()
            self.rec.spawn(default_blueprint=bp)
            self._watch("127.0.0.1", 9876, "--rerun: the Rerun viewer did not start (use "
                        "--serve to watch in a browser, or --save FILE.rrd)")
        elif mode in ("connect", "serve"):
            if target is None:
                raise UsageError(f"Rerun mode {mode} needs the viewer's gRPC URL")
            check_reachable(target)
            self.rec.connect_grpc(target, default_blueprint=bp)
            self._watch(*grpc_address(target), f"--{mode}: the Rerun viewer at {target} "
                        "stopped answering")
        else:  # pragma: no cover - RerunTarget allows only the four
            raise ValueError(f"unknown Rerun mode {mode!r}")
        self._static()

    def _watch(self, host: str, port: int, failure: str) -> None:
        if not reachable(host, port, 5.0):
            raise ViewerUnavailableError(failure)
        self._liveness = Liveness(lambda: reachable(host, port, 0.5))

    def _alive(self) -> bool:
        """False once the viewer has gone away (said once, in one line on stderr)."""
        if self.lost is not None:
            return False
        if self._liveness is not None and self._liveness.gone():
            self.lost = ("the Rerun viewer went away; the replay goes on without it and "
                         "still writes its results")
            print(f"warning: {self.lost}", file=sys.stderr, flush=True)
            return False
        return True

    def _static(self) -> None:
        rec = self.rec
        rec.log("/field", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        strips = [[(x, y, 0.0) for x, y in s] for s in polylines(self.field)]  # the markings
        rec.log("/field/lines", rr.LineStrips3D(strips, colors=[FIELD_LINE_COLOUR], radii=0.04),
                static=True)
        for robot in self.info.robots:
            cx, cy = self.centres.get(robot, (539.0, 539.0))
            rec.log(f"/robots/{robot}/camera/centre",
                    rr.Points2D([(cx, cy)], colors=[RADIUS_COLOUR], radii=4.0), static=True)
        for name in (*self.info.robots, "fused"):
            colour = FUSED_COLOUR if name == "fused" else self.colours[name]
            width = 3.0 if name == "fused" else 1.5
            rec.log(f"/plots/error/{name}",
                    rr.SeriesLines(colors=[colour], names=[name], widths=[width]), static=True)
        series = [("speed/track", TRACK_COLOUR), ("speed/truth", TRUTH_COLOUR)]
        if self.heights:  # the plot's own colours, not the viewer's defaults
            series += [("height/fused", FUSED_COLOUR), ("height/truth", TRUTH_COLOUR)]
        for path, colour in series:
            rec.log(f"/plots/{path}", rr.SeriesLines(colors=[colour],
                                                     names=[path.split("/")[1]]), static=True)
        for robot in self.info.robots:
            for plot in ("blob_area", "pose_sigma", "estimator_ms"):
                rec.log(f"/plots/{plot}/{robot}",
                        rr.SeriesLines(colors=[self.colours[robot]], names=[robot]), static=True)

    def _time(self, stamp_ns: int, timeline: str, index: int) -> None:
        self.rec.reset_time()
        self.rec.set_time("sim_time", duration=np.timedelta64(int(stamp_ns), "ns"))
        self.rec.set_time(timeline, sequence=int(index))

    def _scalar(self, path: str, value: float | None) -> None:
        """A point of a plot, or a gap where there is no value."""
        if value is None or not math.isfinite(value):
            self.rec.log(path, rr.Clear(recursive=False))
        else:
            self.rec.log(path, rr.Scalars(float(value)))

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        if not self._alive():
            return
        self._time(result.stamp_ns, "frame", result.frame)
        self._camera(result, image_bgr)
        self._robot(result)

    def _camera(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        rec, robot = self.rec, result.robot
        cam = f"/robots/{robot}/camera"
        if image_bgr is not None:
            rec.log(f"{cam}/image", rr.Image(image_bgr, color_model="BGR").compress(85))
        det = result.detection
        if det is None:
            rec.log(f"{cam}/detection", rr.Clear(recursive=True))
            self._scalar(f"/plots/blob_area/{robot}", None)
        else:
            cx, cy = float(det.cx_px), float(det.cy_px)  # labels on hover, /label beside
            rec.log(f"{cam}/detection/centroid",
                    rr.Points2D([(cx, cy)], labels=[f"({cx:.1f}, {cy:.1f})"],
                                colors=[BALL_COLOUR], radii=5.0, show_labels=False))
            outline = det.outline_px
            if len(outline) >= 3:
                pts = np.asarray(outline, dtype=np.float32).reshape(-1, 2)
                rec.log(f"{cam}/detection/outline",
                        rr.LineStrips2D([np.vstack([pts, pts[:1]])], colors=[OUTLINE_COLOUR],
                                        radii=1.5))
            else:
                x, y, w, h = (float(v) for v in det.bbox_px)
                rec.log(f"{cam}/detection/outline",
                        rr.Boxes2D(mins=[(x, y)], sizes=[(w, h)], colors=[OUTLINE_COLOUR]))
            r_label = None if result.r_px is None else [f"r = {result.r_px:.1f} px"]
            rec.log(f"{cam}/detection/radius",
                    rr.LineStrips2D([[result.centre_px, (cx, cy)]], colors=[RADIUS_COLOUR],
                                    radii=2.0, labels=r_label, show_labels=False))
            at, text = shapes.detection_label(result, image_bgr)
            rec.log(f"{cam}/detection/label", rr.Points2D(
                [at], labels=[text], colors=[BALL_COLOUR], radii=0.0, show_labels=True))
            self._scalar(f"/plots/blob_area/{robot}", float(det.area_px))
        rec.log(f"/plots/estimator_ms/{robot}", rr.Scalars(1e3 * result.estimator_s))
        self._candidates(result)

    def _candidates(self, result: FrameResult) -> None:
        """The real detector's candidates: a box each, labelled with the check's P(ball),
        the one that won (reported as the ball) in the ball's colour (nothing from the
        paper's chain, whose logs keep their entities)."""
        if not self.candidates:
            return
        path = f"/robots/{result.robot}/camera/candidates"
        if not result.candidates:
            self.rec.log(path, rr.Clear(recursive=True))
            return
        won = result.detection is not None
        boxes = [c.detection.bbox_px for c in result.candidates]
        colours = [BALL_COLOUR if i == 0 and won else CANDIDATE_COLOUR
                   for i in range(len(boxes))]
        labels = [f"{'ball ' if i == 0 and won else ''}P {c.check_score:.2f}"
                  for i, c in enumerate(result.candidates)]
        self.rec.log(path, rr.Boxes2D(mins=[(b[0], b[1]) for b in boxes],
                                      sizes=[(b[2], b[3]) for b in boxes], colors=colours,
                                      labels=labels, show_labels=False))

    def _robot(self, result: FrameResult) -> None:
        rec, robot = self.rec, result.robot
        colour = self.colours[robot]
        if result.pose is not None:  # the correction in its label, on hover; the name beside
            self._pose(f"/field/robots/{robot}", result.pose, colour, "solid",
                       shapes.pose_label(result))
            rec.log(f"/field/robots/{robot}/name", rr.Points3D(
                [self.names.place(robot, result.pose)], labels=[robot], colors=[colour],
                radii=0.0, show_labels=True))
        self._corrected(result)
        est = result.estimate
        if est is None:
            rec.log(f"/field/robots/{robot}/estimate", rr.Clear(recursive=False))
            rec.log(f"/field/robots/{robot}/ray", rr.Clear(recursive=False))
        else:
            rec.log(f"/field/robots/{robot}/estimate",
                    rr.Points3D([(est.x_m, est.y_m, _BALL_Z)], colors=[colour],
                                radii=0.5 * BALL_RADIUS_M))
            rec.log(f"/field/robots/{robot}/ray",
                    rr.LineStrips3D([[(est.robot_x_m, est.robot_y_m, 0.05),
                                      (est.x_m, est.y_m, 0.05)]], colors=[colour], radii=0.025))
        self._scalar(f"/plots/error/{robot}", result.error_m)
        self._scalar(f"/plots/pose_sigma/{robot}", shapes.pose_share_cm(result))

    def _pose(self, path: str, pose: RobotPose, colour: Rgb,
              fill: Literal["solid", "majorwireframe"], label: str) -> None:
        """A robot's footprint at ``pose``, its label shown on hovering (an always-shown one
        would cover it), and its heading arrow (``path``/heading)."""
        c, s, h = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad), ROBOT_FOOTPRINT_M / 2
        self.rec.log(path, rr.Boxes3D(
            centers=[(pose.x_m, pose.y_m, 0.02)], half_sizes=[(h, h, 0.02)],
            quaternions=[rr.Quaternion(xyzw=[0.0, 0.0, math.sin(pose.yaw_rad / 2),
                                             math.cos(pose.yaw_rad / 2)])],
            colors=[colour], fill_mode=fill, labels=[label], show_labels=False))
        self.rec.log(f"{path}/heading", rr.Arrows3D(
            origins=[(pose.x_m, pose.y_m, 0.05)],
            vectors=[(0.9 * ROBOT_FOOTPRINT_M * c, 0.9 * ROBOT_FOOTPRINT_M * s, 0.0)],
            colors=[FIELD_LINE_COLOUR if fill == "solid" else colour], radii=0.035))

    def _corrected(self, result: FrameResult) -> None:
        """With ``--localise``: the corrected pose, a wireframe beside the believed (solid)
        one whose label gives the correction, and the line points the fit used."""
        loc = result.localisation
        if loc is None:
            return
        robot = result.robot  # (its label, the same as the believed one's, on hovering)
        self._pose(f"/field/robots/{robot}/corrected", loc.pose, self.colours[robot],
                   "majorwireframe", shapes.pose_label(result))
        if loc.pixels is None or not len(loc.pixels):
            self.rec.log(f"/robots/{robot}/camera/lines", rr.Clear(recursive=False))
        else:
            self.rec.log(f"/robots/{robot}/camera/lines",
                         rr.Points2D(loc.pixels, colors=[LINE_POINT_COLOUR], radii=1.5))

    def step(self, result: StepResult) -> None:
        if not self._alive():
            return
        rec = self.rec
        self._time(result.stamp_ns, "step", result.step)
        fused = result.fused
        if fused is None:
            rec.log("/field/fused", rr.Clear(recursive=True))
            self.names.ball_label = None
        else:
            z = _BALL_Z if fused.z_m is None else fused.z_m
            label = self.names.ball(fused.x_m, fused.y_m, shapes.fused_label(result))
            rec.log("/field/fused", rr.Points3D([(fused.x_m, fused.y_m, z)], colors=[FUSED_COLOUR],
                                                radii=BALL_RADIUS_M, labels=[label],
                                                show_labels=True))
            self._height(result, z)
            rec.log("/field/fused/covariance",
                    rr.LineStrips3D([shapes.ellipse(fused.x_m, fused.y_m, fused.covariance)],
                                    colors=[FUSED_COLOUR], radii=0.025))
        if result.truth is None:
            rec.log("/field/ground_truth/ball", rr.Clear(recursive=False))
        else:
            z_true = BALL_RADIUS_M if result.truth_z_m is None else result.truth_z_m
            strips = shapes.truth_mark(result.truth[0], result.truth[1], z_true)
            rec.log("/field/ground_truth/ball", rr.LineStrips3D(
                strips, colors=[TRUTH_COLOUR], radii=[0.03, 0.01][:len(strips)]))
        self._scalar("/plots/error/fused", result.error_m)
        self._track(result)
        rec.reset_time()

    def _height(self, result: StepResult, z: float) -> None:
        """A 3-D fusion's ball: a line down to its shadow on the ground, its height plotted
        beside the truth's."""
        fused = result.fused
        if fused is None or fused.z_m is None:
            return
        self.rec.log("/field/fused/height",
                     rr.LineStrips3D([[(fused.x_m, fused.y_m, 0.0), (fused.x_m, fused.y_m, z)]],
                                     colors=[FUSED_COLOUR], radii=0.01))
        self._scalar("/plots/height/fused", fused.z_m)
        self._scalar("/plots/height/truth", result.truth_z_m)

    def _track(self, result: StepResult) -> None:
        """The tracker's trail, velocity arrow and speed, when the step carries a velocity."""
        velocity, truth_velocity = result.velocity_m_s, result.truth_velocity_m_s
        if truth_velocity is not None:
            self._scalar("/plots/speed/truth", math.hypot(*truth_velocity))
        fused = result.fused
        if velocity is None or fused is None:
            if velocity is None and result.velocity_covariance is None:
                return
            self.rec.log("/field/track", rr.Clear(recursive=True))
            self._scalar("/plots/speed/track", None)
            return
        z, vz = _BALL_Z if fused.z_m is None else fused.z_m, result.vz_m_s or 0.0
        ground = 0.03 if fused.z_m is None else z  # a 3-D fusion's trail is the flight's arc
        self._trail.append((result.stamp_ns, fused.x_m, fused.y_m, ground))
        while self._trail and result.stamp_ns - self._trail[0][0] > TRAIL_S * NS_PER_S:
            self._trail.popleft()
        self.rec.log("/field/track/trail",
                     rr.LineStrips3D([[(x, y, h) for _, x, y, h in self._trail]],
                                     colors=[TRACK_COLOUR], radii=0.03))
        vx, vy = velocity
        self.rec.log("/field/track/velocity",
                     rr.Arrows3D(origins=[(fused.x_m, fused.y_m, z)],
                                 vectors=[(vx, vy, vz)], colors=[TRACK_COLOUR], radii=0.04))
        self._scalar("/plots/speed/track", math.hypot(vx, vy))
        if result.vz_m_s is None:  # a level tracker predicts no landing
            return
        if result.landing is None:
            self.rec.log("/field/track/landing", rr.Clear(recursive=False))
            return
        strips, label = shapes.landing_mark(result)
        self.rec.log("/field/track/landing", rr.LineStrips3D(
            strips, colors=[LANDING_COLOUR], radii=0.02, labels=[label], show_labels=True))

    def close(self, ok: bool) -> None:
        """Flush and disconnect; a saved .rrd is renamed into place only when ``ok``. A
        viewer that went away is not waited for."""
        try:
            if self.lost is None:
                if ok and self.summary is not None:
                    self.log_learnt(self.summary.summary_dict().get("learnt"))
                try:
                    streams.flush(self.rec, None if self._save is None else self._save.tmp)
                except RuntimeError as err:  # a full disk, or the gRPC connection broke
                    if self._save is not None:
                        self.broken = True
                        raise streams.write_failure(self._save.path, err, self.rec) from err
                    print(f"warning: the Rerun viewer went away ({err})", file=sys.stderr)
                    self.lost = str(err)
            if ok and self._save is not None:
                streams.commit(self.rec, self._save)  # when whole (a writer may stop mid-way)
        finally:
            self._end()

    def log_learnt(self, learnt: object) -> None:
        """``/summary/learnt``: what the replay came to believe of each robot's pose (the
        results' ``summary.learnt``; None or empty: nothing)."""
        text = learnt_markdown(self.info.robots, learnt if isinstance(learnt, dict) else None)
        self.rec.log("/summary/learnt", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN),
                     static=True)

    def _end(self) -> None:
        """Close the recording (its threads end; a viewer that went away is not waited for)
        and remove an uncommitted .rrd."""
        if self.lost is None and not self.broken:  # a broken file writer blocks a disconnect
            with contextlib.suppress(RuntimeError):
                streams.release(self.rec)
        if self._save is not None:
            self._save.discard()
