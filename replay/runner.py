"""Replay a log: the streaming loop from the reader to the sinks.

:func:`replay` is the one typed function the CLI calls::

    summary = replay(Path("run.mcap"), ReplayOptions(method="corrected", out=Path("r.json")))

Flow (streaming, memory bounded by the look-ahead): the reader yields poses, ground truth
and images in log-time order; poses and truth go to short histories; images wait in a
:class:`~replay.sync.DelayLine` until the log is ``lookahead`` past their stamp. Then each is
decoded and handed to the :class:`~replay.estimation.FrameEstimator` (detect, pair with the
robot's interpolated pose, locate). Frames are grouped into fusion steps by stamp
(``window``); each step is fused. Every frame and step goes to every sink (statistics,
results JSON, estimates MCAP, Rerun), all opened in one ExitStack that closes them with
``ok`` False when the replay fails.

Each robot's camera comes from the options or the log (:func:`replay.cameras.cameras_for`:
none is guessed). Once the log is read, :class:`~replay.diagnosis.Diagnosis` says what the
user must know (skipped messages and images, a robot that saw no ball, balls out of range,
images of another size than the camera's): in the summary's ``warnings``, which the
commands print, or, with ``strict``, the replay's error before any output is written.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import math
import sys
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dsp import contract
from dsp.ball_file import read_ball_file, shipped_check
from dsp.errors import UsageError
from dsp.field import FieldSpec
from dsp.progress import Progress, progress_bar
from dsp.text import printable
from estimator.errors import EstimatorError
from estimator.localisation import PoseCorrection
from estimator.tracking.bias import BiasEstimator, BiasParams
from estimator.tracking.pose_noise import PoseNoiseEstimator
from replay.ahead import Ahead, Decoded, decode_and_detect
from replay.aloft import width_robots
from replay.cameras import cameras_for
from replay.clock import Clock
from replay.detector_choice import choose_detector, inline_ball_model
from replay.diagnosis import Diagnosis
from replay.errors import ImageDecodeError, MissingPosesError, NoFramesError, StrictError
from replay.estimation import FrameEstimator
from replay.localise import Localiser, check_field, field_for, prior_covariance
from replay.log import (
    ImageMessage,
    LogInfo,
    LogReader,
    PoseMessage,
    RecoveryLoss,
    TruthMessage,
)
from replay.options import ReplayOptions, Timing
from replay.profiles import Pipeline, decide
from replay.real_ball import BallFinder
from replay.records import FrameResult, FrameStatus, Localisation
from replay.selection import check_selected, check_selection, log_origin_ns
from replay.sink import Sink
from replay.sinks.outputs import OutputContext, open_outputs
from replay.stats import ReplayStats, ReplaySummary
from replay.sync import (
    DelayLine,
    FusionGrouper,
    History,
    PoseMatch,
    interpolate_pose,
    interpolate_truth,
    interpolate_truth_velocity,
    interpolate_truth_z,
)

__all__ = ["file_digest", "replay"]


def file_digest(path: Path) -> str:
    """SHA-256 of a file's bytes (hex), read in blocks."""
    h = hashlib.sha256()
    with Path(path).open("rb") as f:
        while block := f.read(1 << 20):
            h.update(block)
    return h.hexdigest()


def replay(path: Path | str, options: ReplayOptions | None = None, *,
           sinks: Sequence[Sink] = ()) -> ReplaySummary:
    """Replay the log at ``path`` with ``options``; returns the summary. ``sinks`` receive
    every frame and step besides the outputs the options ask for. Raises
    :class:`~replay.errors.ReplayError` subclasses for known problems."""
    options = options or ReplayOptions()
    path = Path(path)
    options.check_outputs(path)
    wall0 = time.perf_counter()
    with LogReader(path, image_topic=options.image_topic, pose_topic=options.pose_topic,
                   truth_topic=options.truth_topic or contract.GT_BALL_TOPIC,
                   robots=options.robots, recover=options.recover,
                   limits=options.limits()) as reader:
        info = reader.info
        _check_options(path, info, options)
        cameras = cameras_for(
            info.robots, log=str(path), cameras=options.cameras, calibration=options.calibration,
            calibration_model=options.calibration_part(),
            metadata=info.cameras.camera_set(f"{path}: metadata {contract.CAMERAS_METADATA}"))
        field, field_note = field_for(None if info.scenario is None else info.scenario.field,
                                      cameras.field, cameras.field_source)
        options, pipeline = decide(
            options, field=None if field is None else field.name, robots=info.robots,
            camera_robots=tuple(cameras.models), notes=() if field_note is None else
            (field_note,))
        options, pipeline, chosen = choose_detector(reader, options, pipeline, cameras)
        width = width_robots(options, info.robots, cameras.models)
        pipeline = dataclasses.replace(pipeline, width=tuple(sorted(width)))
        model = (read_ball_file(options.ball) if options.ball is not None
                 else inline_ball_model(cameras) if options.detector_name == "real" else None)
        finder = None if model is None else BallFinder(model, shipped_check())
        estimator = FrameEstimator(
            method=options.method, fusion_method=options.fusion_method, cameras=cameras,
            smooth=options.smooth, hops=options.hops, noise=options.noise, finder=finder,
            width_robots=width, width_checked=options.width_range is None,
            detector=options.detector_part(),
            pose_covariance=prior_covariance(*options.pose_sigma)
            if options.pose_uncertainty and options.pose_sigma_given else None,
            pose_noise=PoseNoiseEstimator()
            if options.pose_uncertainty and not options.pose_sigma_given else None,
            bias=_bias(options) if options.localise == "ball" else None)
        localiser = _localiser(options, field, estimator, path)
        stats = ReplayStats(info.robots, width_range=bool(width))
        diagnosis = Diagnosis(path, info.robots, cameras, detector=options.detector_name,
                              ball=options.ball, early=chosen)
        with contextlib.ExitStack() as stack:
            outputs = _open_outputs(stack, reader, options, estimator, stats,
                                    pipeline if options.profile is not None else None, field)
            ahead = stack.enter_context(Ahead(options.thread_count, work=functools.partial(
                decode_and_detect, max_pixels=options.max_image_pixels, finder=finder,
                detector=estimator.detector,
                line_points=None if localiser is None else localiser.points)))
            stream = _Stream(reader, estimator, options.timing(log_origin_ns(info)),
                             estimator.sinks([stats, diagnosis, *outputs, *sinks]), ahead,
                             localiser)
            with _progress(options, reader) as bar:
                stream.run(bar)
            estimator.flush()  # smoothing: the steps, once the whole log is read
            check_selected(path, info, options, stats.frames)
            _check_outcome(path, stats, reader, stream.bad_images)
            stats.finish(undecodable=reader.undecodable, recovered=_recovered(reader),
                         beliefs=estimator.beliefs() if localiser is None
                         else localiser.beliefs(estimator.beliefs()))
            warnings = diagnosis.warnings(bad_images=stream.bad_images,
                                          bad_messages=reader.bad_messages)
            if stream.clock is not None and (note := stream.clock.note(
                    printable(str(path), limit=200))):
                warnings.append(note)
            if options.strict and warnings:
                raise StrictError(warnings)  # before the outputs are committed
    saved = options.save_path
    summary = stats.summary(path, wall_s=time.perf_counter() - wall0, outputs=tuple(
        Path(p) for p in (options.out, options.out_mcap, options.out_csv, options.plot, saved)
        if p is not None))
    return dataclasses.replace(summary, warnings=tuple(warnings),
                               pipeline=pipeline.describe() if options.profile else None)


def _bias(options: ReplayOptions) -> BiasEstimator:
    """``--localise ball``'s filters: each robot's spread learnt from the log, or
    ``--pose-sigma``'s for every robot."""
    if not options.pose_sigma_given:
        return BiasEstimator(BiasParams(), learnt=PoseNoiseEstimator())
    sigma_m, sigma_deg = options.pose_sigma
    return BiasEstimator(BiasParams(sigma_m, math.radians(sigma_deg)))


def _localiser(options: ReplayOptions, field: FieldSpec | None, estimator: FrameEstimator,
               path: Path) -> Localiser | None:
    """The field-line correction the options ask for, on the field the log or the camera
    file names (:func:`~replay.localise.field_for`)."""
    if options.localise != "lines":
        return None
    cams = estimator.cameras
    sigma_m, sigma_deg = options.pose_sigma
    return Localiser(check_field(field, str(path)), cams.models, sigma_m=sigma_m,
                     sigma_deg=sigma_deg,
                     mount_yaw_rad={r: cams.mount_yaw_rad(r) for r in cams.models},
                     learn=not options.pose_sigma_given)


def _open_outputs(stack: contextlib.ExitStack[bool | None], reader: LogReader,
                  options: ReplayOptions, estimator: FrameEstimator,
                  stats: ReplayStats, pipeline: Pipeline | None,
                  field: FieldSpec | None) -> list[Sink]:
    """The sinks the options ask for, each entered in ``stack``."""
    return open_outputs(stack, options, OutputContext(
        reader.info, reader.path.name, file_digest(reader.path), stats, estimator.centres,
        None if pipeline is None else pipeline.to_dict(), field))


def _recovered(reader: LogReader) -> RecoveryLoss | None:
    return reader.loss if reader.recover else None


def _check_options(path: Path, info: LogInfo, options: ReplayOptions) -> None:
    """What the options ask of the log that it does not have."""
    if options.robots is not None:
        unknown = sorted(set(options.robots) - set(info.robots))
        if unknown:
            raise UsageError(f"--robots {', '.join(unknown)}: not in {path}")
    if options.truth_topic is not None and not info.has_truth:
        raise UsageError(f"--truth-topic {options.truth_topic}: no such topic in {path}")
    check_selection(path, info, options)


def _check_outcome(path: Path, stats: ReplayStats, reader: LogReader,
                   bad_images: dict[str, int]) -> None:
    if stats.frames == 0:
        raise NoFramesError(path, "no image in the selected time range and robots"
                            + (" (the log's readable part holds none)" if reader.recover
                               else ""))
    bad = stats.skipped.get(FrameStatus.BAD_IMAGE.value, 0)
    if bad == stats.frames:
        why = max(bad_images.items(), key=lambda kv: kv[1], default=("", 0))[0]
        raise ImageDecodeError(path, f"none of the {bad} images decodes"
                               + (f" ({bad_images[why]}: {why})" if why else ""))
    no_pose = stats.skipped.get(FrameStatus.NO_POSE.value, 0)
    if no_pose == stats.frames - bad:
        raise MissingPosesError(
            path, f"none of the {no_pose} images has a pose within the tolerance"
        )


@contextlib.contextmanager
def _progress(options: ReplayOptions, reader: LogReader) -> Iterator[Progress | None]:
    """Progress over the log's messages (``progress`` None: a bar on a terminal, plain
    lines otherwise; :func:`dsp.progress.progress_bar`), or None when there is none."""
    if options.progress is False:
        yield None
        return
    show = True if options.progress is None and sys.stderr.isatty() else options.progress
    with progress_bar(reader.info.message_count, reader.path.name, show, unit="msg") as bar:
        yield bar


MAX_PENDING = 64
"""The most frames held back for their line fits (the oldest go on early beyond it)."""


def _nothing() -> None:
    return None


def _same(pose: PoseMatch | None) -> PoseMatch | None:
    return pose


@dataclass(frozen=True)
class _Pending:
    """A frame whose poses are known, waiting for its line fit."""

    img: ImageMessage
    decoded: Decoded
    pose: PoseMatch | None
    fit: Callable[[], PoseCorrection | None]
    prior: np.ndarray | None = None
    """The covariance the fit searched with."""


class _Stream:
    """One pass over the log: histories of poses and truth, images delayed until their
    poses and step are complete, frames grouped into fusion steps, results to the sinks."""

    def __init__(self, reader: LogReader, estimator: FrameEstimator, timing: Timing,
                 sinks: Sequence[Sink], ahead: Ahead, localiser: Localiser | None = None) -> None:
        self.reader = reader
        self.robots = reader.info.robots
        self.has_truth = reader.info.has_truth
        self.estimator = estimator
        self.timing = timing
        self.sinks = sinks
        self.ahead = ahead
        self.localiser = localiser
        self.pending: deque[_Pending] = deque()
        horizon = 2 * timing.lookahead_ns + timing.window_ns + timing.lead_ns
        self.poses: dict[str, History[PoseMessage]] = {r: History(horizon) for r in self.robots}
        self.truth: History[TruthMessage] = History(horizon)
        self.delay = DelayLine(timing.lookahead_ns)
        self.grouper: FusionGrouper[FrameResult] = FusionGrouper(
            estimator.step_window_ns(timing.window_ns))
        self.frames = 0
        self.steps = 0
        self.clock = None if timing.clock_ns is None else Clock(timing.clock_ns,
                                                                 timing.tolerance_ns)
        self.bad_images: dict[str, int] = {}
        """Images that do not decode, by why (:func:`replay.log.image_problem`)."""

    def run(self, bar: Progress | None) -> None:
        t = self.timing
        for msg in self.reader.messages(start_ns=t.read_from_ns):
            if bar is not None:
                bar.update(1)
            if isinstance(msg, PoseMessage):
                self.poses[msg.robot].add(msg, self.delay.clock_ns)
                now = msg.stamp_ns
            elif isinstance(msg, TruthMessage):
                self.truth.add(msg, self.delay.clock_ns)
                now = msg.stamp_ns
            else:
                if t.end_ns is not None and msg.stamp_ns > t.end_ns + t.lookahead_ns:
                    break
                self.delay.push(msg)
                if self._wanted(msg):
                    self.ahead.push(msg)  # decoded and detected in the pool meanwhile
                now = msg.log_time_ns
            for ready in self.delay.ready(now):
                self._ready(ready)
            if self.pending:
                self._settle(now)
        for ready in self.delay.drain():
            self._ready(ready)
        if self.pending:
            self._settle(None)
        for t0, frames in self.grouper.flush():
            self._step(t0, frames)

    def _truth_at(self, t_ns: int) -> tuple[float, float] | None:
        if not self.has_truth:
            return None
        return interpolate_truth(self.truth, t_ns, self.timing.tolerance_ns)

    def _pose_at(self, robot: str, t_ns: int) -> PoseMatch | None:
        """The interpolated pose, None when none is near enough or the quaternions are bad."""
        try:
            return interpolate_pose(self.poses[robot], t_ns, self.timing.tolerance_ns)
        except EstimatorError:  # estimator.errors.GeometryError: a zero or NaN quaternion
            return None

    def _wanted(self, img: ImageMessage) -> bool:
        """Whether the image is within --start / --end."""
        t = self.timing
        return not ((t.start_ns is not None and img.stamp_ns < t.start_ns)
                    or (t.end_ns is not None and img.stamp_ns > t.end_ns))

    def _ready(self, img: ImageMessage) -> None:
        """An image whose poses are all in: estimated now, or (localising) its line fit
        prepared from the believed pose now known (and the robot's prior and start, in
        frame order), and the frame held back until the log is ``lead`` further on
        (:meth:`_settle`)."""
        if not self._wanted(img):
            return
        decoded = self.ahead.take(img)
        if self.localiser is None:
            self._image(img, decoded,
                        functools.partial(self._pose_at, img.robot, img.stamp_ns), None)
            return
        pose = self._pose_at(img.robot, img.stamp_ns)
        field_pose = None if pose is None else self.estimator.field_pose(img.robot, pose)
        fit: Callable[[], PoseCorrection | None] = _nothing
        prior = self.localiser.prior(img.robot)
        if field_pose is not None and decoded.points is not None:
            start = self.localiser.start(img.robot, img.stamp_ns, field_pose.pose)
            # on this thread when settled, not in the pool: the fit is many small numpy calls
            # that hold the GIL, where a pool thread would wait for it and hold up decoding
            fit = functools.partial(self.localiser.fit, decoded.points, field_pose.pose, start,
                                    prior)
        self.pending.append(_Pending(img, decoded, pose, fit, prior))

    def _settle(self, now_ns: int | None) -> None:
        """The held-back frames whose lead has passed at log time ``now_ns`` (None: all),
        in order: each robot's correction settled (a failed fit holds the last one), then
        the frame estimated from it."""
        assert self.localiser is not None
        t = self.timing
        while self.pending and (now_ns is None or len(self.pending) > MAX_PENDING or (
                self.pending[0].img.stamp_ns + t.lookahead_ns + t.lead_ns < now_ns)):
            p = self.pending.popleft()
            loc = None if p.pose is None else self.localiser.settle(
                p.img.robot, p.img.stamp_ns, self.estimator.field_pose(p.img.robot, p.pose).pose,
                p.fit(), p.decoded.points, p.prior)
            self._image(p.img, p.decoded, functools.partial(_same, p.pose), loc)

    def _image(self, img: ImageMessage, decoded: Decoded,
               pose_at: Callable[[], PoseMatch | None], loc: Localisation | None) -> None:
        image = decoded.image
        if decoded.problem is not None:
            self.bad_images[decoded.problem] = self.bad_images.get(decoded.problem, 0) + 1
        t_start = time.perf_counter()
        outcome = self.estimator.estimate(img.robot, image, pose_at, stamp_ns=img.stamp_ns,
                                          detected=decoded.detected, localisation=loc)
        elapsed = decoded.seconds + time.perf_counter() - t_start
        # the truth goes with every frame, so a missed ball can be told from an absent one
        truth = self._truth_at(img.stamp_ns)
        est = outcome.estimate
        err = None
        if est is not None and truth is not None:
            err = math.hypot(est.x_m - truth[0], est.y_m - truth[1])
        pose = outcome.pose
        result = FrameResult(
            frame=self.frames, robot=img.robot, stamp_ns=img.stamp_ns, status=outcome.status,
            detection=outcome.detection, r_px=outcome.r_px,
            centre_px=self.estimator.centre(img.robot),
            pose=None if pose is None else pose.pose,
            pose_gap_ns=None if pose is None else pose.gap_ns,
            pose_interpolated=False if pose is None else pose.interpolated,
            estimate=est, truth=truth, error_m=err, localisation=outcome.localisation,
            estimator_s=elapsed, candidates=outcome.candidates,
        )
        self.frames += 1
        self._emit_frame(result, image)
        for t0, frames in self.grouper.add(img.robot, img.stamp_ns, result):
            self._step(t0, frames)

    def _emit_frame(self, result: FrameResult, image: np.ndarray | None) -> None:
        for sink in self.sinks:
            sink.frame(result, image)

    def _step(self, t0: int, frames: dict[str, FrameResult]) -> None:
        """The step at t0, with the clock's ticks before it (and at t0, after it)."""
        self._ticks(t0, inclusive=False)
        self._emit_step(t0, frames)
        self._ticks(t0, inclusive=True)

    def _ticks(self, t_ns: int, *, inclusive: bool) -> None:
        """Steps without images at the clock's ticks near the images before ``t_ns`` (and
        at it when ``inclusive``), from the first tick at or after the first step."""
        if self.clock is None:
            return
        for tick in (self.clock.at(t_ns) if inclusive else self.clock.before(t_ns)):
            self._emit_step(tick, {})

    def _emit_step(self, t0: int, frames: dict[str, FrameResult]) -> None:
        ordered = tuple(frames[r] for r in self.robots if r in frames)
        velocity = None if not self.has_truth else interpolate_truth_velocity(
            self.truth, t0, self.timing.tolerance_ns)
        height = None if not self.has_truth else interpolate_truth_z(
            self.truth, t0, self.timing.tolerance_ns)
        step = self.estimator.step(self.steps, t0, ordered, self._truth_at(t0), velocity,
                                   height)
        self.steps += 1
        for sink in self.sinks:
            sink.step(step)
