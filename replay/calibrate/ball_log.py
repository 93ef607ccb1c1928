"""``dsp-calibrate --ball-from LOG.mcap``: the ball's boxes drawn from a simulated log's truth.

A log written by ``dsp-record`` carries what a team draws by hand: where the ball truly is
(``/ground_truth/ball``, or its odometry) and where each robot truly stands
(``/ground_truth/{robot}/pose``), and each camera's projection model in its ``dsp.cameras``
metadata. For each of the first N images (by stamp, then robot) the ball's true centre and
the robot's true pose at the image's stamp (interpolated between the 240 Hz samples, as the
replay does: :mod:`replay.sync`) place
the ball in the camera's frame; the cone of rays tangent to it, through the model
(:func:`estimator.camera.ball_outline_px`), gives its outline and so its box, as a labelled
frame's box. The frames then go to the same fit as a folder's
(:func:`replay.calibrate.ball.fit_samples`).

The truth does not say whether the ball is hidden (behind a robot, under a goal's crossbar,
under the ideal camera's painted footprint of its own robot), so the pixels decide: each
box's ball pixels (the ellipse the fit uses) are compared, as a colour histogram, with the
mean of every box's (:func:`visible`); a box unlike the rest (a Bhattacharyya coefficient
under :data:`VISIBLE_SHARE` of the median) shows something else and its frame is left out,
as is a frame whose ball the image's edge or circle cuts. A frame whose ball lies wholly
outside the image is kept as a frame without a ball. Those left out are counted in the
model's ``fit``.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar, overload

import cv2
import numpy as np
import numpy.typing as npt

from dsp import contract
from dsp.cameras import CameraSpec
from dsp.errors import InputError
from estimator.camera import ball_outline_px
from estimator.constants import BALL_RADIUS_M, NS_PER_S
from estimator.detection.real import Box
from estimator.detection.real.colour import to_ycrcb
from estimator.geometry import RobotPose
from replay.errors import MissingPosesError
from replay.log import ImageMessage, LogReader, PoseMessage, TruthMessage, decode_image
from replay.sync import History, interpolate_pose, interpolate_truth, interpolate_truth_z

__all__ = ["VISIBLE_SHARE", "LogFrames", "frames_from_log", "visible"]

VISIBLE_SHARE = 0.75
"""A box is the ball's when its colour histogram's Bhattacharyya coefficient with the mean
box's is at least this share of the median box's."""
MAX_TRUTH_GAP_NS = 50_000_000
"""An image farther than this from the nearest true pose or ball sample has no label."""
Image = npt.NDArray[np.uint8]
T = TypeVar("T", PoseMessage, TruthMessage)


@dataclass
class _Truth:
    """What the log says: the chosen images, the true poses and the ball's truth."""

    images: list[ImageMessage]
    poses: dict[str, list[PoseMessage]]
    ball: list[TruthMessage]


def _done(truth: _Truth, count: int | None) -> bool:
    """The first ``count`` images are in, with truth past the last of them."""
    if count is None or len(truth.images) < count or not truth.ball:
        return False
    last = truth.images[-1].stamp_ns
    return truth.ball[-1].stamp_ns >= last and all(
        truth.poses.get(img.robot) and truth.poses[img.robot][-1].stamp_ns >= img.stamp_ns
        for img in truth.images)


def _read(reader: LogReader, count: int | None) -> _Truth:
    truth = _Truth([], {}, [])
    for msg in reader.messages():
        if isinstance(msg, ImageMessage):
            if count is None or len(truth.images) < count:
                truth.images.append(msg)
        elif isinstance(msg, PoseMessage):
            truth.poses.setdefault(msg.robot, []).append(msg)
        elif isinstance(msg, TruthMessage):
            truth.ball.append(msg)
        if _done(truth, count):
            break
    truth.images.sort(key=lambda m: (m.stamp_ns, m.robot))
    return truth


def _history(samples: Sequence[T]) -> History[T]:
    """All of a stream's samples, for interpolation at any image's stamp."""
    history: History[T] = History(horizon_ns=2**62, max_samples=len(samples) + 2)
    for sample in samples:
        history.add(sample)
    return history


def _box(spec: CameraSpec, outline: npt.NDArray[np.float64]) -> Box | str | None:
    """The box around a ball's outline; None when the ball is wholly outside the image,
    "cut" when the image's edge or circle cuts it."""
    u, v = outline[:, 0], outline[:, 1]
    cu, cv_ = spec.centre_px
    limit = spec.max_radius_px or math.inf
    with np.errstate(invalid="ignore"):
        inside = ((u >= 0) & (u <= spec.width_px - 1) & (v >= 0) & (v <= spec.height_px - 1)
                  & (np.hypot(u - cu, v - cv_) <= limit))
    if not inside.any():
        return None
    if not inside.all():
        return "cut"
    # a labelled box's convention (YOLO's: pixel i spans [i, i + 1)), half a pixel on from
    # the camera model's (pixel i at i)
    return (float(u.min()) + 0.5, float(v.min()) + 0.5, float(u.max()) + 0.5,
            float(v.max()) + 0.5)


def _label(spec: CameraSpec, pose: RobotPose, ball: tuple[float, float, float]
           ) -> Box | str | None:
    """The ball's box in the image of a camera at ``pose`` (field frame)."""
    if spec.camera is None:
        raise ValueError("no projection model")
    x, y, yaw = pose.x_m, pose.y_m, pose.yaw_rad
    if spec.map_to_field is not None:
        x, y, yaw = spec.map_to_field.apply(x, y, yaw)
    heading = yaw + spec.mount_yaw_rad  # the field direction image up shows
    dx, dy = float(ball[0]) - x, float(ball[1]) - y
    c, s = math.cos(heading), math.sin(heading)
    centre = np.array([c * dx + s * dy, -s * dx + c * dy, float(ball[2])])
    return _box(spec, ball_outline_px(spec.camera, centre))


class LogFrames(Sequence[tuple[Image, list[Box]]]):
    """The labelled frames of a log, each image decoded when it is asked for (a match's
    frames would not fit in memory at once)."""

    def __init__(self, log: Path, images: Sequence[ImageMessage],
                 boxes: Sequence[list[Box]]) -> None:
        self.log, self.images, self.boxes = log, list(images), list(boxes)

    def __len__(self) -> int:
        return len(self.images)

    @overload
    def __getitem__(self, index: int) -> tuple[Image, list[Box]]: ...
    @overload
    def __getitem__(self, index: slice) -> Sequence[tuple[Image, list[Box]]]: ...

    def __getitem__(self, index: int | slice
                    ) -> tuple[Image, list[Box]] | Sequence[tuple[Image, list[Box]]]:
        if isinstance(index, slice):
            return LogFrames(self.log, self.images[index], self.boxes[index])
        msg = self.images[index]
        image = decode_image(msg)
        if image is None:
            raise InputError(f"{self.log}: the image of {frame_name(msg)} does not decode")
        return image, self.boxes[index]

    def __iter__(self) -> Iterator[tuple[Image, list[Box]]]:
        return (self[i] for i in range(len(self)))


def frame_name(msg: ImageMessage) -> str:
    """How an image of a log is named: its robot and stamp."""
    return f"{msg.robot} at {msg.stamp_ns / NS_PER_S:.3f} s"


def _histogram(image: Image, box: Box) -> npt.NDArray[np.float64]:
    """The normalised (Y / 64, Cr / 8, Cb / 8) histogram of the ball's ellipse in ``box``
    (0.8 of its half-sides, as the fit takes the ball's pixels)."""
    x0, y0 = max(0, math.floor(box[0])), max(0, math.floor(box[1]))
    x1, y1 = min(image.shape[1], math.ceil(box[2])), min(image.shape[0], math.ceil(box[3]))
    crop = to_ycrcb(np.ascontiguousarray(image[y0:y1, x0:x1]))
    mask = np.zeros(crop.shape[:2], np.uint8)
    centre = (round(((box[0] + box[2]) / 2.0 - x0) * 16), round(((box[1] + box[3]) / 2.0 - y0)
                                                                * 16))
    axes = (max(round((box[2] - box[0]) * 0.4 * 16), 8), max(round((box[3] - box[1]) * 0.4
                                                                   * 16), 8))
    cv2.ellipse(mask, centre, axes, 0, 0, 360, 1, -1, cv2.LINE_8, 4)
    px = crop[mask.view(np.bool_)].astype(np.intp)
    bins = ((px[:, 0] >> 6) * 32 + (px[:, 1] >> 3)) * 32 + (px[:, 2] >> 3)
    hist = np.bincount(bins, minlength=4 * 32 * 32).astype(np.float64)
    return np.asarray(hist / max(float(hist.sum()), 1.0), np.float64)


def visible(histograms: Sequence[npt.NDArray[np.float64]]) -> list[bool]:
    """Which boxes show the ball: their histograms like the mean box's (module docstring)."""
    if not histograms:
        return []
    mean = np.mean(histograms, axis=0)
    scores = np.array([float(np.sqrt(h * mean).sum()) for h in histograms])
    return [bool(s >= VISIBLE_SHARE * float(np.median(scores))) for s in scores]


def _open_truth(log: Path, count: int | None) -> tuple[_Truth, dict[str, CameraSpec]]:
    """The log's first ``count`` images and truth, and each of their robots' camera."""
    def no_truth(what: str) -> InputError:
        return InputError(f"{log}: no ground truth ({what}): a ball model from a log needs a "
                          "simulated one (dsp-record); give a folder of labelled images instead")

    try:
        with LogReader(log, pose_topic=contract.GT_POSE_TOPIC) as reader:
            if not reader.info.has_truth:
                raise no_truth(f"no {contract.GT_BALL_TOPIC}")
            cameras = reader.info.cameras.camera_set(
                f"{log}: metadata {contract.CAMERAS_METADATA}")
            truth = _read(reader, count)
    except MissingPosesError as err:
        raise no_truth(f"no robot's true pose on {contract.GT_POSE_TOPIC}") from err
    specs: dict[str, CameraSpec] = {}
    for robot in sorted({m.robot for m in truth.images}):
        spec = None if cameras is None else cameras.for_robot(robot)
        if spec is None or spec.camera is None:
            raise InputError(f"{log}: metadata {contract.CAMERAS_METADATA} gives {robot} no "
                             "projection model (ideal, fisheye or mirror) to place the ball "
                             "with")
        specs[robot] = spec
    return truth, specs


def frames_from_log(log: Path, train_count: int | None
                    ) -> tuple[LogFrames, dict[str, object]]:
    """The first ``train_count`` images of ``log`` (None: all) with their ball boxes, less
    those left out, and what the fit records of them."""
    truth, specs = _open_truth(log, train_count)
    ball = _history(truth.ball)
    poses = {r: _history(msgs) for r, msgs in truth.poses.items()}
    kept: list[ImageMessage] = []
    boxes: list[list[Box]] = []
    left_out = 0
    for msg in truth.images:
        t = msg.stamp_ns
        pose = (interpolate_pose(poses[msg.robot], t, MAX_TRUTH_GAP_NS) if msg.robot in poses
                else None)
        xy = interpolate_truth(ball, t, MAX_TRUTH_GAP_NS)
        z = interpolate_truth_z(ball, t, MAX_TRUTH_GAP_NS)
        label = None if pose is None or xy is None else _label(
            specs[msg.robot], pose.pose, (*xy, BALL_RADIUS_M if z is None else z))
        if pose is None or xy is None or isinstance(label, str):
            left_out += 1
            continue
        kept.append(msg)
        boxes.append([] if label is None else [label])
    frames = LogFrames(log, kept, boxes)
    hist = [_histogram(frames[i][0], b[0]) for i, b in enumerate(boxes) if b]
    shown = iter(visible(hist))
    keep = [i for i, b in enumerate(boxes) if not b or next(shown)]
    left_out += len(boxes) - len(keep)
    frames = LogFrames(log, [kept[i] for i in keep], [boxes[i] for i in keep])
    if not any(frames.boxes):
        raise InputError(f"{log}: the ball is in no camera's view in the first "
                         f"{len(truth.images)} images: take more (--train-count)")
    info: dict[str, object] = {"images": len(frames), "first": frame_name(frames.images[0]),
                               "last": frame_name(frames.images[-1]), "log": log.name,
                               "left_out": left_out}
    return frames, info

