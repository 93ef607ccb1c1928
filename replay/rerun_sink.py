"""Sink logging a replay to Rerun (rerun-sdk >= 0.24 API: ``rr.Scalars``, ``set_time``).

Uses its own :class:`rerun.RecordingStream` (never the global one) whose recording id is
derived from the log's SHA-256 and the options, so the same replay is the same recording.

Entity paths::

    /robots/{robot}/camera/image                 the omni image (EncodedImage or Image)
    /robots/{robot}/camera/detection/centroid    Points2D + label "(cx, cy)"
    /robots/{robot}/camera/detection/outline     LineStrips2D (blob outline) or Boxes2D
    /robots/{robot}/camera/detection/radius      LineStrips2D image centre -> centroid (Fig. 8)
    /field/lines                                 static field markings (LineStrips3D, z = 0)
    /field/robots/{robot}                        Points3D robot position + Arrows3D heading
    /field/robots/{robot}/estimate               Points3D the robot's ball estimate
    /field/robots/{robot}/ray                    LineStrips3D bearing ray robot -> estimate
    /field/fused                                 Points3D the fused estimate
    /field/fused/covariance                      LineStrips3D 2-sigma covariance ellipse
    /field/ground_truth/ball                     Points3D the true ball
    /plots/error/{robot}, /plots/error/fused     Scalars: error vs ground truth [m]
    /plots/blob_area/{robot}                     Scalars: blob area [px]
    /plots/estimator_ms/{robot}                  Scalars: detection + estimation time [ms]

Timelines: ``sim_time`` (duration, ns from the log) and ``frame`` (frame index; the step
index for fused data).
"""

from __future__ import annotations

import hashlib
import json
import math
import uuid
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from dsp.atomic import AtomicFile
from dsp.field import DEFAULT_FIELD, FIELDS, FieldSpec, polylines
from replay.options import ReplayOptions, RerunTarget
from replay.reader import LogInfo
from replay.results import FrameResult, StepResult
from replay.sink import SinkBase

__all__ = ["APPLICATION_ID", "RerunSink", "field_lines", "recording_id"]

APPLICATION_ID = "dual_sight_replay"
ROBOT_COLOURS = [(66, 133, 244), (219, 68, 55), (244, 180, 0), (15, 157, 88), (171, 71, 188)]
BALL_COLOUR = (255, 140, 0)
FUSED_COLOUR = (255, 255, 255)
TRUTH_COLOUR = (0, 255, 0)


def recording_id(digest: str, options: dict[str, Any]) -> str:
    """A UUID derived from the log's hash and the options (same input -> same recording)."""
    text = json.dumps({"sha256": digest, "options": options}, sort_keys=True, default=str)
    return str(uuid.UUID(bytes=hashlib.sha256(text.encode()).digest()[:16], version=4))


def field_lines(spec: FieldSpec) -> list[list[tuple[float, float]]]:
    """The field's markings (:mod:`dsp.field`) as polylines for ``/field/lines``."""
    return polylines(spec)


def _ellipse(x: float, y: float, cov: Any, k: float = 2.0, n: int = 48) -> np.ndarray:
    c = np.asarray(cov, dtype=np.float64)
    vals, vecs = np.linalg.eigh(0.5 * (c + c.T))
    vals = np.sqrt(np.clip(vals, 0.0, None)) * k
    a = np.linspace(0.0, 2 * math.pi, n + 1)
    circle = np.stack([np.cos(a) * vals[0], np.sin(a) * vals[1]])
    pts = (vecs @ circle).T + np.array([x, y])
    return np.column_stack([pts, np.zeros(len(pts))])


class RerunSink(SinkBase):
    """Logs frames and steps to a Rerun recording stream (see the module docstring)."""

    def __init__(self, target: RerunTarget, *, info: LogInfo, digest: str,
                 options: ReplayOptions, centres: Mapping[str, tuple[float, float]]) -> None:
        self.target = target
        self._save: AtomicFile | None = None
        self.info = info
        self.centres = centres
        self.field = info.scenario.field if info.scenario is not None else FIELDS[DEFAULT_FIELD]
        opts = options.as_dict()
        for key in ("rerun", "out", "out_mcap", "out_csv", "plot", "force", "progress"):
            opts.pop(key, None)
        self.recording_id = recording_id(digest, opts)
        self.rec = rr.RecordingStream(APPLICATION_ID, recording_id=self.recording_id)
        self.colours = {r: ROBOT_COLOURS[i % len(ROBOT_COLOURS)]
                        for i, r in enumerate(info.robots)}
        self._open(force=options.force)

    def blueprint(self) -> rrb.Blueprint:
        cams = [rrb.Spatial2DView(origin=f"/robots/{r}/camera", name=f"{r} camera")
                for r in self.info.robots]
        # straight down from high enough that the whole field and its 1.5 m border fit the
        # (narrow, tall) field panel
        eye_height_m = 1.35 * (self.field.length_m + 2 * self.field.border_m)
        field_view = rrb.Spatial3DView(
            origin="/field", name="field (top-down)",
            eye_controls=rrb.EyeControls3D(position=(0.0, -0.5, eye_height_m),
                                           look_target=(0.0, 0.0, 0.0), eye_up=(0.0, 1.0, 0.0)),
        )
        plots = rrb.Vertical(
            rrb.TimeSeriesView(origin="/plots/error", name="error vs ground truth [m]"),
            rrb.TimeSeriesView(origin="/plots/blob_area", name="blob area [px]"),
            rrb.TimeSeriesView(origin="/plots/estimator_ms", name="estimator time [ms]"),
        )
        return rrb.Blueprint(
            rrb.Horizontal(rrb.Grid(*cams), field_view, plots, column_shares=[2, 3, 2]),
            collapse_panels=False,
        )

    def _open(self, *, force: bool) -> None:
        mode, target = self.target.mode, self.target.target
        bp = self.blueprint()
        if mode == "save":
            self._save = AtomicFile(Path(str(target)), force=force)
            self.rec.save(self._save.tmp, default_blueprint=bp)
        elif mode == "spawn":
            self.rec.spawn(default_blueprint=bp)
        elif mode == "connect":
            self.rec.connect_grpc(target, default_blueprint=bp)
        elif mode == "serve":
            uri = self.rec.serve_grpc(default_blueprint=bp)
            rr.serve_web_viewer(connect_to=uri)
        else:  # pragma: no cover - the CLI only offers the four
            raise ValueError(f"unknown Rerun mode {mode!r}")
        self._static()

    def _static(self) -> None:
        rec = self.rec
        rec.log("/field", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        strips = [[(x, y, 0.0) for x, y in s] for s in field_lines(self.field)]
        rec.log("/field/lines", rr.LineStrips3D(strips, colors=[(230, 230, 230)], radii=0.03),
                static=True)
        for robot in self.info.robots:
            cx, cy = self.centres.get(robot, (539.0, 539.0))
            rec.log(f"/robots/{robot}/camera/centre",
                    rr.Points2D([(cx, cy)], colors=[(255, 255, 255)], radii=3.0), static=True)
        for name in (*self.info.robots, "fused"):
            colour = FUSED_COLOUR if name == "fused" else self.colours[name]
            rec.log(f"/plots/error/{name}", rr.SeriesLines(colors=[colour], names=[name]),
                    static=True)
        for robot in self.info.robots:
            for plot in ("blob_area", "estimator_ms"):
                rec.log(f"/plots/{plot}/{robot}",
                        rr.SeriesLines(colors=[self.colours[robot]], names=[robot]), static=True)

    def _time(self, stamp_ns: int, index: int) -> None:
        self.rec.reset_time()
        self.rec.set_time("sim_time", duration=np.timedelta64(int(stamp_ns), "ns"))
        self.rec.set_time("frame", sequence=int(index))

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        rec = self.rec
        robot = result.robot
        cam = f"/robots/{robot}/camera"
        self._time(result.stamp_ns, result.frame)
        if image_bgr is not None:
            rec.log(f"{cam}/image", rr.Image(image_bgr, color_model="BGR").compress(95))
        det = result.detection
        if det is None:
            rec.log(f"{cam}/detection", rr.Clear(recursive=True))
        else:
            cx, cy = float(det.cx_px), float(det.cy_px)
            rec.log(f"{cam}/detection/centroid",
                    rr.Points2D([(cx, cy)], labels=[f"({cx:.1f}, {cy:.1f})"],
                                colors=[BALL_COLOUR], radii=4.0, show_labels=True))
            outline = getattr(det, "outline_px", None)
            if outline is not None and len(outline) >= 3:
                pts = np.asarray(outline, dtype=np.float32).reshape(-1, 2)
                pts = np.vstack([pts, pts[:1]])
                rec.log(f"{cam}/detection/outline",
                        rr.LineStrips2D([pts], colors=[(255, 255, 0)], radii=1.0))
            else:
                x, y, w, h = (float(v) for v in det.bbox_px)
                rec.log(f"{cam}/detection/outline",
                        rr.Boxes2D(mins=[(x, y)], sizes=[(w, h)], colors=[(255, 255, 0)]))
            c = result.centre_px
            label = f"r = {result.r_px:.1f} px" if result.r_px is not None else None
            rec.log(f"{cam}/detection/radius",
                    rr.LineStrips2D([[c, (cx, cy)]], colors=[(255, 0, 255)], radii=1.5,
                                    labels=[label] if label else None))
            rec.log(f"/plots/blob_area/{robot}", rr.Scalars(float(det.area_px)))
        rec.log(f"/plots/estimator_ms/{robot}", rr.Scalars(1e3 * result.estimator_s))
        pose = result.pose
        colour = self.colours[robot]
        if pose is not None:
            rec.log(f"/field/robots/{robot}",
                    rr.Points3D([(pose.x_m, pose.y_m, 0.0)], colors=[colour], radii=0.25,
                                labels=[robot]),
                    rr.Arrows3D(origins=[(pose.x_m, pose.y_m, 0.0)],
                                vectors=[(0.6 * math.cos(pose.yaw_rad),
                                          0.6 * math.sin(pose.yaw_rad), 0.0)],
                                colors=[colour]))
        est = result.estimate
        if est is None:
            rec.log(f"/field/robots/{robot}/estimate", rr.Clear(recursive=False))
            rec.log(f"/field/robots/{robot}/ray", rr.Clear(recursive=False))
        else:
            rec.log(f"/field/robots/{robot}/estimate",
                    rr.Points3D([(est.x_m, est.y_m, 0.11)], colors=[colour], radii=0.11))
            rec.log(f"/field/robots/{robot}/ray",
                    rr.LineStrips3D([[(est.robot_x_m, est.robot_y_m, 0.0),
                                      (est.x_m, est.y_m, 0.0)]], colors=[colour], radii=0.02))
        if result.error_m is not None:
            rec.log(f"/plots/error/{robot}", rr.Scalars(result.error_m))

    def step(self, result: StepResult) -> None:
        rec = self.rec
        rec.reset_time()
        rec.set_time("sim_time", duration=np.timedelta64(int(result.stamp_ns), "ns"))
        rec.set_time("step", sequence=int(result.step))
        fused = result.fused
        if fused is None:
            rec.log("/field/fused", rr.Clear(recursive=True))
        else:
            rec.log("/field/fused",
                    rr.Points3D([(fused.x_m, fused.y_m, 0.11)], colors=[FUSED_COLOUR],
                                radii=0.13, labels=[f"fused ({fused.x_m:.2f}, {fused.y_m:.2f})"]))
            rec.log("/field/fused/covariance",
                    rr.LineStrips3D([_ellipse(fused.x_m, fused.y_m, fused.covariance)],
                                    colors=[FUSED_COLOUR], radii=0.02))
        if result.truth is not None:
            rec.log("/field/ground_truth/ball",
                    rr.Points3D([(result.truth[0], result.truth[1], 0.11)],
                                colors=[TRUTH_COLOUR], radii=0.11))
        if result.error_m is not None:
            rec.log("/plots/error/fused", rr.Scalars(result.error_m))
        rec.reset_time()

    def close(self, ok: bool) -> None:
        """Flush and disconnect; a saved .rrd is renamed into place only when ``ok``."""
        try:
            self.rec.flush()
            self.rec.disconnect()
            if ok and self._save is not None:
                self._save.commit()
        finally:
            if self._save is not None:
                self._save.discard()
