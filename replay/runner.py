"""Replay a log: read, synchronise, run the estimator on every image, fuse, feed the sinks.

:func:`replay` is the one typed function the CLI calls::

    summary = replay(Path("run.mcap"), ReplayOptions(method="corrected", out=Path("r.json")))

Flow (streaming, memory bounded by the look-ahead): the reader yields poses, ground truth
and images in log-time order; poses and truth go to short histories; images wait in a
:class:`~replay.sync.DelayLine` until the log is ``lookahead`` past their stamp, then each is
decoded, its ball detected, paired with the robot's interpolated pose and turned into a
field estimate. Frames are grouped into fusion steps by stamp (``window``); each step is
fused. Every frame and step goes to the sinks (results JSON, estimates MCAP, Rerun).
"""

from __future__ import annotations

import hashlib
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Protocol

import cv2
import numpy as np

from dsp import contract
from replay.errors import (
    CalibrationError,
    EstimatorUnavailableError,
    ImageDecodeError,
    MissingPosesError,
    OptionsError,
    OutputExistsError,
)
from replay.reader import ImageMessage, LogInfo, LogReader, PoseMessage, TruthMessage
from replay.results import (
    ErrorStats,
    FrameResult,
    ResultsWriter,
    RobotEstimate,
    StepResult,
)
from replay.sync import DelayLine, FusionGrouper, History, interpolate_pose, interpolate_truth

__all__ = [
    "DEFAULT_FUSION",
    "METHODS",
    "ReplayOptions",
    "ReplaySummary",
    "RerunTarget",
    "RobotSummary",
    "Sink",
    "decode_image",
    "file_digest",
    "replay",
]

METHODS = ("paper", "corrected")
DEFAULT_FUSION = {"paper": "mean", "corrected": "weighted"}
"""Paper mode fuses as the paper does (eq. 20-21); the corrected estimator by inverse
covariance, the most accurate in dsp-eval's Table 1 and random scenes."""
DEFAULT_CENTRE_PX = (539.0, 539.0)
NS = 1_000_000_000


@dataclass(frozen=True)
class RerunTarget:
    """Where Rerun data goes: ``mode`` one of spawn, save, connect, serve."""

    mode: str
    target: str | None = None


@dataclass(frozen=True)
class ReplayOptions:
    """Everything a replay depends on (keyword arguments of the CLI, in seconds at the edge)."""

    method: str = "corrected"
    fusion: str | None = None
    """None: the method's own (:data:`DEFAULT_FUSION`)."""
    calibration: Path | None = None
    image_topic: str = contract.IMAGE_TOPIC
    pose_topic: str = contract.POSE_TOPIC
    robots: tuple[str, ...] | None = None
    start_s: float | None = None
    end_s: float | None = None
    pose_tolerance_s: float = 0.1
    window_s: float = 0.05
    recover: bool = False
    out: Path | None = None
    out_mcap: Path | None = None
    force: bool = False
    rerun: RerunTarget | None = None
    progress: bool | None = None
    """Show a progress bar: None = when stderr is a terminal."""

    @property
    def fusion_method(self) -> str:
        """The fusion in use: the one asked for, else the method's default."""
        return self.fusion or DEFAULT_FUSION.get(self.method, "mean")

    def results_view(self) -> dict[str, Any]:
        """The options that shape the results (no output paths, no display switches)."""
        return {
            "method": self.method,
            "fusion": self.fusion_method,
            "calibration": None if self.calibration is None else Path(self.calibration).name,
            "image_topic": self.image_topic,
            "pose_topic": self.pose_topic,
            "robots": None if self.robots is None else list(self.robots),
            "start_s": self.start_s,
            "end_s": self.end_s,
            "pose_tolerance_s": self.pose_tolerance_s,
            "window_s": self.window_s,
            "recover": self.recover,
        }


@dataclass(frozen=True)
class RobotSummary:
    frames: int
    detections: int
    estimates: int
    rmse_m: float | None
    mean_error_m: float | None
    max_error_m: float | None


@dataclass(frozen=True)
class ReplaySummary:
    """What a replay did. ``wall_s``, ``frames_per_s`` and ``estimator_ms`` are machine
    dependent: they go to the terminal and Rerun, never into results files."""

    path: Path
    robots: tuple[str, ...]
    frames: int
    steps: int
    fused_steps: int
    skipped: dict[str, int]
    per_robot: dict[str, RobotSummary]
    fused: RobotSummary
    undecodable_messages: int
    recovered: dict[str, Any] | None
    wall_s: float
    estimator_ms: float | None
    outputs: tuple[Path, ...] = ()

    @property
    def frames_per_s(self) -> float:
        return self.frames / self.wall_s if self.wall_s > 0 else float("nan")


class Sink(Protocol):
    """Receives every frame and step of a replay."""

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None: ...

    def step(self, result: StepResult) -> None: ...


# --- images -------------------------------------------------------------------------------


def decode_image(msg: ImageMessage) -> np.ndarray | None:
    """BGR pixels of an image message, None when it does not decode."""
    if msg.fmt == "raw":
        enc = msg.encoding.lower()
        channels = {"bgr8": 3, "rgb8": 3, "mono8": 1}.get(enc)
        if channels is None or msg.width_px <= 0 or msg.height_px <= 0:
            return None
        step = msg.step or msg.width_px * channels
        if step < msg.width_px * channels or len(msg.data) < step * msg.height_px:
            return None
        buf = np.frombuffer(msg.data, np.uint8, count=step * msg.height_px)
        px = buf.reshape(msg.height_px, step)[:, : msg.width_px * channels]
        px = px.reshape(msg.height_px, msg.width_px, channels)
        if enc == "rgb8":
            return cv2.cvtColor(px, cv2.COLOR_RGB2BGR)
        if enc == "mono8":
            return cv2.cvtColor(px, cv2.COLOR_GRAY2BGR)
        return np.ascontiguousarray(px)
    img = cv2.imdecode(np.frombuffer(msg.data, np.uint8), cv2.IMREAD_COLOR)
    return img if img is not None and img.size else None


def file_digest(path: Path) -> str:
    """SHA-256 of a file's bytes (hex), read in blocks."""
    h = hashlib.sha256()
    with Path(path).open("rb") as f:
        while block := f.read(1 << 20):
            h.update(block)
    return h.hexdigest()


# --- estimation ---------------------------------------------------------------------------


@dataclass
class _Estimation:
    """The estimator parts chosen by the options, per robot."""

    method: str
    detect: Callable[[np.ndarray], Any]
    locate: Callable[[str, Any, Any], RobotEstimate]
    """(robot, detection, pose) -> the robot's estimate."""
    fuse: Callable[[list[RobotEstimate]], Any]
    centres: dict[str, tuple[float, float]] = field(default_factory=dict)
    out_of_range: tuple[type[BaseException], ...] = ()


def _make_estimation(options: ReplayOptions, reader: LogReader) -> _Estimation:
    try:
        from estimator import calibration as cal
        from estimator import camera as cam
        from estimator import corrected, detection, fusion, paper
        from estimator.errors import EstimatorError
    except ImportError as err:
        raise EstimatorUnavailableError(f"{err} (is estimator/ complete?)") from err
    if options.method not in METHODS:
        raise OptionsError(f"--method {options.method!r}; choose one of {', '.join(METHODS)}")
    if options.fusion_method not in fusion.FUSION_METHODS:
        raise OptionsError(
            f"--fusion {options.fusion!r}; choose one of {', '.join(fusion.FUSION_METHODS)}"
        )
    fuser = fusion.get_fusion(options.fusion_method)

    centres: dict[str, tuple[float, float]] = {}
    calibrations: dict[str, Any] = {}
    camera_models: dict[str, Any] = {}
    cameras = reader.info.cameras.by_robot()
    for robot in reader.info.robots:
        centres[robot] = DEFAULT_CENTRE_PX
        calibrations[robot] = cal.PAPER_CALIBRATION
        if robot in cameras:
            try:
                model = cam.camera_from_dict(dict(cameras[robot]))
                centres[robot] = (float(model.centre_px[0]), float(model.centre_px[1]))
                calibrations[robot] = cal.CameraCalibration(model)
                camera_models[robot] = model
            except (ValueError, TypeError, EstimatorError) as err:
                raise CalibrationError(
                    f"{reader.path} metadata {contract.CAMERAS_METADATA}[{robot}]", str(err)
                ) from err
    if options.calibration is not None:
        path = Path(options.calibration)
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as err:
            raise CalibrationError(path, f"cannot read: {err.strerror or err}") from err
        try:
            model = cal.calibration_from_json(text)
        except (ValueError, TypeError, KeyError, EstimatorError) as err:
            raise CalibrationError(path, str(err)) from err
        calibrations = {robot: model for robot in reader.info.robots}

    def visibility(robot: str, det: Any, range_m: float) -> float:
        """How much of the ball the blob shows, when the log names the camera model."""
        model = camera_models.get(robot)
        if model is None:
            return 1.0
        expected = cam.ball_image_area_px(model, range_m)
        return corrected.ball_visibility(float(det.area_px), expected)

    def locate_paper(robot: str, det: Any, pose: Any) -> RobotEstimate:
        x, y = paper.locate_ball(float(det.cx_px), float(det.cy_px), pose.x_m, pose.y_m,
                                 pose.yaw_rad, centre_px=centres[robot])
        dx, dy = x - pose.x_m, y - pose.y_m
        bearing = math.atan2(dy, dx) - pose.yaw_rad
        bearing = (bearing + math.pi) % (2 * math.pi) - math.pi
        rng = math.hypot(dx, dy)
        return RobotEstimate(robot, x, y, rng, bearing, pose.x_m, pose.y_m, pose.yaw_rad,
                             visibility(robot, det, rng))

    def locate_corrected(robot: str, det: Any, pose: Any) -> RobotEstimate:
        e = corrected.estimate_ball(float(det.cx_px), float(det.cy_px), pose,
                                    calibrations[robot], centre_px=centres[robot], robot=robot)
        return RobotEstimate(robot, e.x_m, e.y_m, e.range_m, e.bearing_rad,
                             pose.x_m, pose.y_m, pose.yaw_rad, visibility(robot, det, e.range_m))

    def fuse(estimates: list[RobotEstimate]) -> Any:
        return fuser.fuse([
            corrected.BallEstimate(robot=e.robot, robot_x_m=e.robot_x_m, robot_y_m=e.robot_y_m,
                                   range_m=e.range_m, bearing_rad=e.bearing_rad,
                                   x_m=e.x_m, y_m=e.y_m, visibility=e.visibility)
            for e in estimates
        ])

    return _Estimation(
        method=options.method,
        detect=detection.detect_ball,
        locate=locate_paper if options.method == "paper" else locate_corrected,
        fuse=fuse,
        centres=centres,
        out_of_range=(EstimatorError,),
    )


# --- the replay ---------------------------------------------------------------------------


def _check_options(options: ReplayOptions) -> None:
    if not options.pose_tolerance_s >= 0:
        raise OptionsError(f"--pose-tolerance {options.pose_tolerance_s}; must be >= 0")
    if not options.window_s > 0:
        raise OptionsError(f"--window {options.window_s}; must be > 0")
    if options.start_s is not None and options.end_s is not None and (
        options.end_s < options.start_s
    ):
        raise OptionsError(f"--end {options.end_s} is before --start {options.start_s}")
    save = None
    if options.rerun is not None and options.rerun.mode == "save" and options.rerun.target:
        save = Path(options.rerun.target)
    for out in (options.out, options.out_mcap, save):
        if out is not None and Path(out).exists() and not options.force:
            raise OutputExistsError(out)
    if options.out is not None and options.out_mcap is not None and (
        Path(options.out).resolve() == Path(options.out_mcap).resolve()
    ):
        raise OptionsError("--out and --out-mcap name the same file")


class _Stats:
    def __init__(self, robots: Sequence[str]) -> None:
        self.frames = 0
        self.steps = 0
        self.fused_steps = 0
        self.decoded = 0
        self.skipped: dict[str, int] = {}
        self.robot_frames = dict.fromkeys(robots, 0)
        self.robot_detections = dict.fromkeys(robots, 0)
        self.robot_estimates = dict.fromkeys(robots, 0)
        self.robot_errors = {r: ErrorStats() for r in robots}
        self.fused_errors = ErrorStats()
        self.estimator_s = 0.0
        self.estimator_n = 0

    def summary_dict(self, undecodable: int) -> dict[str, Any]:
        return {
            "frames": self.frames,
            "steps": self.steps,
            "fused_steps": self.fused_steps,
            "skipped": dict(sorted(self.skipped.items())),
            "robots": {
                r: {"frames": self.robot_frames[r], "detections": self.robot_detections[r],
                    "estimates": self.robot_estimates[r], **self.robot_errors[r].to_dict()}
                for r in self.robot_frames
            },
            "fused": {"estimates": self.fused_steps, **self.fused_errors.to_dict()},
            "undecodable_messages": undecodable,
        }


def replay(path: Path | str, options: ReplayOptions | None = None) -> ReplaySummary:
    """Replay the log at ``path`` with ``options``; returns the summary. Raises
    :class:`~replay.errors.ReplayError` subclasses for known problems."""
    options = options or ReplayOptions()
    path = Path(path)
    _check_options(options)
    wall0 = time.perf_counter()
    tol_ns = round(options.pose_tolerance_s * NS)
    window_ns = max(1, round(options.window_s * NS))
    lookahead_ns = tol_ns + window_ns
    start_ns = None if options.start_s is None else round(options.start_s * NS)
    end_ns = None if options.end_s is None else round(options.end_s * NS)

    with LogReader(path, image_topic=options.image_topic, pose_topic=options.pose_topic,
                   robots=options.robots, recover=options.recover) as reader:
        info = reader.info
        if options.robots is not None:
            unknown = sorted(set(options.robots) - set(info.robots))
            if unknown:
                raise OptionsError(f"--robots {', '.join(unknown)}: not in {path}")
        est = _make_estimation(options, reader)
        digest = file_digest(path)
        results = mcap_sink = rerun_sink = None
        try:
            if options.out is not None:
                results = ResultsWriter(Path(options.out), force=options.force)
                results.open()
            if options.out_mcap is not None:
                from replay.mcap_sink import McapSink

                mcap_sink = McapSink(Path(options.out_mcap), force=options.force)
                mcap_sink.open()
            if options.rerun is not None:
                from replay.rerun_sink import RerunSink

                rerun_sink = RerunSink(options.rerun, info=info, digest=digest,
                                       options=options,
                                       centres=est.centres, force=options.force)
                rerun_sink.open()
            stats = _run(reader, info, est, options, tol_ns, window_ns, lookahead_ns,
                         start_ns, end_ns, results, mcap_sink, rerun_sink)
            _check_outcome(path, stats, info)
            header = {
                "log": {"file": path.name, "sha256": digest, "robots": list(info.robots),
                        "recovered": _recovered(reader)},
                "options": options.results_view(),
                "summary": stats.summary_dict(reader.undecodable),
            }
            ok = True
        except BaseException:
            ok = False
            raise
        finally:
            if results is not None:
                results.close(header if ok else None)
            if mcap_sink is not None:
                mcap_sink.close(ok)
            if rerun_sink is not None:
                rerun_sink.close(ok)

    def robot_summary(frames: int, det: int, n_est: int, e: ErrorStats) -> RobotSummary:
        return RobotSummary(frames, det, n_est, e.rmse_m, e.mean_m,
                            e.max_abs if e.n else None)

    return ReplaySummary(
        path=path,
        robots=info.robots,
        frames=stats.frames,
        steps=stats.steps,
        fused_steps=stats.fused_steps,
        skipped=dict(sorted(stats.skipped.items())),
        per_robot={r: robot_summary(stats.robot_frames[r], stats.robot_detections[r],
                                    stats.robot_estimates[r], stats.robot_errors[r])
                   for r in info.robots},
        fused=robot_summary(stats.steps, stats.fused_steps, stats.fused_steps,
                            stats.fused_errors),
        undecodable_messages=reader.undecodable,
        recovered=_recovered(reader),
        wall_s=time.perf_counter() - wall0,
        estimator_ms=(1e3 * stats.estimator_s / stats.estimator_n) if stats.estimator_n else None,
        outputs=tuple(Path(p) for p in (options.out, options.out_mcap) if p is not None),
    )


def _recovered(reader: LogReader) -> dict[str, Any] | None:
    if not reader.recover:
        return None
    loss = reader.loss
    return {"truncated": loss.truncated, "lost_bytes": loss.lost_bytes,
            "file_bytes": loss.file_bytes, "bad_chunks": loss.bad_chunks}


def _check_outcome(path: Path, stats: _Stats, info: LogInfo) -> None:
    if stats.frames == 0:
        return
    bad = stats.skipped.get("bad_image", 0)
    if bad == stats.frames:
        raise ImageDecodeError(path, f"none of the {bad} images decodes")
    no_pose = stats.skipped.get("no_pose", 0)
    if no_pose == stats.frames - bad:
        raise MissingPosesError(
            path, f"none of the {no_pose} images has a pose within the tolerance"
        )


def _pose_at(history: History[PoseMessage], t_ns: int, tol_ns: int, est: _Estimation) -> Any:
    """The interpolated pose, None when none is near enough or the quaternions are bad."""
    try:
        return interpolate_pose(history, t_ns, tol_ns)
    except est.out_of_range:  # estimator.errors.GeometryError: a zero or NaN quaternion
        return None


def _progress(options: ReplayOptions, info: LogInfo) -> Any:
    show = options.progress if options.progress is not None else sys.stderr.isatty()
    if not show:
        return None
    from tqdm import tqdm

    return tqdm(total=info.message_count, unit="msg", desc=info.path.name, leave=False,
                file=sys.stderr)


def _run(
    reader: LogReader, info: LogInfo, est: _Estimation, options: ReplayOptions,
    tol_ns: int, window_ns: int, lookahead_ns: int, start_ns: int | None, end_ns: int | None,
    results: ResultsWriter | None, mcap_sink: Any, rerun_sink: Any,
) -> _Stats:
    stats = _Stats(info.robots)
    horizon = 2 * lookahead_ns + window_ns
    poses: dict[str, History[PoseMessage]] = {r: History(horizon) for r in info.robots}
    truth: History[TruthMessage] = History(horizon)
    delay = DelayLine(lookahead_ns)
    grouper: FusionGrouper[FrameResult] = FusionGrouper(window_ns)
    bar = _progress(options, info)
    read_from = None if start_ns is None else max(0, start_ns - 2 * lookahead_ns)

    def emit_frame(result: FrameResult, image: np.ndarray | None) -> None:
        if results is not None:
            results.frame(result)
        if mcap_sink is not None:
            mcap_sink.frame(result)
        if rerun_sink is not None:
            rerun_sink.frame(result, image)

    def emit_step(t0: int, frames: dict[str, FrameResult]) -> None:
        ordered = tuple(frames[r] for r in info.robots if r in frames)
        estimates = [f.estimate for f in ordered if f.estimate is not None]
        fused = est.fuse(estimates) if estimates else None
        gt = interpolate_truth(truth, t0, tol_ns) if info.has_truth else None
        err = None
        if fused is not None:
            stats.fused_steps += 1
            if gt is not None:
                err = math.hypot(fused.x_m - gt[0], fused.y_m - gt[1])
                stats.fused_errors.add(err)
        step = StepResult(stats.steps, t0, ordered, fused, gt, err)
        stats.steps += 1
        if results is not None:
            results.step(step)
        if mcap_sink is not None:
            mcap_sink.step(step)
        if rerun_sink is not None:
            rerun_sink.step(step)

    def process(img: ImageMessage) -> None:
        if start_ns is not None and img.stamp_ns < start_ns:
            return
        if end_ns is not None and img.stamp_ns > end_ns:
            return
        index = stats.frames
        stats.frames += 1
        stats.robot_frames[img.robot] += 1
        centre = est.centres.get(img.robot, DEFAULT_CENTRE_PX)
        t_start = time.perf_counter()
        image = decode_image(img)
        status = "ok"
        det = pose_match = estimate = None
        r_px = None
        if image is None:
            status = "bad_image"
        else:
            stats.decoded += 1
            try:
                det = est.detect(image)
            except est.out_of_range:
                det, status = None, "detect_error"
            if det is None and status == "ok":
                status = "no_detection"
            elif det is not None:
                stats.robot_detections[img.robot] += 1
                r_px = math.hypot(det.cx_px - centre[0], det.cy_px - centre[1])
                pose_match = _pose_at(poses[img.robot], img.stamp_ns, tol_ns, est)
                if pose_match is None:
                    status = "no_pose"
                else:
                    try:
                        estimate = est.locate(img.robot, det, pose_match.pose)
                    except est.out_of_range:
                        status = "out_of_range"
        if status in ("ok", "no_detection") and pose_match is None:
            pose_match = _pose_at(poses[img.robot], img.stamp_ns, tol_ns, est)
            if pose_match is None:
                status = "no_pose"
        elapsed = time.perf_counter() - t_start
        if status not in ("ok", "no_detection"):  # a frame without a ball is not skipped
            stats.skipped[status] = stats.skipped.get(status, 0) + 1
        if image is not None:
            stats.estimator_s += elapsed
            stats.estimator_n += 1
        err = None
        # the truth goes with every frame, so a missed ball can be told from an absent one
        gt = interpolate_truth(truth, img.stamp_ns, tol_ns) if info.has_truth else None
        if estimate is not None:
            stats.robot_estimates[img.robot] += 1
            if gt is not None:
                err = math.hypot(estimate.x_m - gt[0], estimate.y_m - gt[1])
                stats.robot_errors[img.robot].add(err)
        result = FrameResult(
            frame=index, robot=img.robot, stamp_ns=img.stamp_ns, status=status,
            detection=det, r_px=r_px, centre_px=centre,
            pose=None if pose_match is None else pose_match.pose,
            pose_gap_ns=None if pose_match is None else pose_match.gap_ns,
            pose_interpolated=False if pose_match is None else pose_match.interpolated,
            estimate=estimate, truth=gt, error_m=err, estimator_s=elapsed,
        )
        emit_frame(result, image)
        for t0, frames in grouper.add(img.robot, img.stamp_ns, result):
            emit_step(t0, frames)

    try:
        for msg in reader.messages(start_ns=read_from):
            if bar is not None:
                bar.update(1)
            if isinstance(msg, PoseMessage):
                poses[msg.robot].add(msg)
                now = msg.stamp_ns
            elif isinstance(msg, TruthMessage):
                truth.add(msg)
                now = msg.stamp_ns
            else:
                if end_ns is not None and msg.stamp_ns > end_ns + lookahead_ns:
                    break
                delay.push(msg)
                now = msg.log_time_ns
            for ready in delay.ready(now):
                process(ready)
        for ready in delay.drain():
            process(ready)
        for t0, frames in grouper.flush():
            emit_step(t0, frames)
    finally:
        if bar is not None:
            bar.close()
    return stats


def options_dict(options: ReplayOptions) -> dict[str, Any]:
    """All options as plain values (for hashing into a Rerun recording id)."""
    d = asdict(options)
    d["fusion"] = options.fusion_method
    return {k: (str(v) if isinstance(v, Path) else v) for k, v in d.items()}
