"""Which ball detector suits a log: the question its images answer, not where it came from.

The paper's colour chain (a fixed HSV box tuned to the simulator's orange ball) finds the
real ball in about 4 % of real MSL camera images; the real-ball detector with the shipped
generic model finds 81-84 % there, and 8 of 240 simulated balls, where the colour chain
finds 229. So the default (a profile's options with no ``--detector`` and no ``--ball``, and
not the paper's method, which keeps the paper's chain) chooses, in this order:

1. **A camera file's ball model** (``ball:`` in a robot's entry, :mod:`dsp.cameras`): the
   real detector with it.
2. **What a dsp-record log states**: its ``dsp.recorder`` metadata (it rendered the images)
   and its recording's ball colour (``dsp.scenario`` ``params.recording.ball_colour``).
   The orange ball is the colour chain's: it runs, without probing, and the results are
   byte for byte as before the choice existed (the header records nothing more). A ball of
   another colour is left to the images.
3. **The log's images** (:func:`probe`): per robot at most :data:`PROBE_IMAGES` images
   spread over its first :data:`PROBE_SECONDS` s (after ``--start``), decoded as the replay
   decodes them, each given to both detectors. An image counts for a detector when it
   finds one clear ball there: the real detector reports a ball (its check's P(ball) at
   or above the model's threshold); the colour chain finds one to :data:`MAX_CLEAR_BLOBS`
   blobs that are round (circularity >= :data:`MIN_CIRCULARITY`) and of a ball's size (at
   least :data:`MIN_AREA_PX` px, a disc about 6 px across; the chain's own area and fill
   limits): the ball and a look-alike or two beside the field. On real images it finds a
   scatter of small ball-coloured specks instead (a blob like that in about a third of
   them, the ball in 5 %), and the real detector reports a ball in about 9 of 10. The
   real detector (the shipped generic model) is chosen when it counts more images over
   all robots; otherwise (a tie too) the colour chain, the cheaper and the one every
   simulated result was made with.

Where the robots' poses and cameras place the balls found on the field, the probe also
counts, per robot, the balls that another robot's agrees with (within :data:`AGREE_M` at
stamps :data:`AGREE_NS` apart). That is not part of the choice (a fake or poor pose would
decide it, and two robots agree just as well on an orange box beside the field) but of what
the replay says: the line gives the count, and a robot the chosen detector finds no clear
ball for, or (two robots or more finding one) whose balls none of the others' agrees with,
is named in a warning (unless the whole replay's own warning says more: that the robot saw
no ball at all, or that none of its balls agreed with another robot's;
:mod:`replay.diagnosis`).

The choice is a pure function of the log's bytes and the options (the images are detected
in a pool but counted in a fixed order), so outputs do not depend on ``--threads``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path
from typing import Any

import numpy as np

from dsp.ball_file import GENERIC_NAME, shipped_check, shipped_generic
from dsp.errors import InputError
from dsp.text import printable
from estimator.constants import NS_PER_S
from estimator.detection.chain import Detection, DetectionParams, detect_blobs
from estimator.detection.real import BallModel, model_from_dict
from estimator.errors import BallModelError, EstimatorError
from replay.cameras import Cameras
from replay.estimation import Detected, FrameEstimator
from replay.log import ImageMessage, LogInfo, LogReader, PoseMessage, decode_image
from replay.options import ReplayOptions
from replay.profiles import Pipeline
from replay.real_ball import BallFinder
from replay.selection import log_origin_ns
from replay.sync import History, PoseMatch, interpolate_pose

__all__ = ["AGREE_M", "AGREE_NS", "MAX_CLEAR_BLOBS", "MIN_AREA_PX", "MIN_CIRCULARITY",
           "PROBE_IMAGES", "PROBE_SECONDS", "Choice", "Probe", "choice_for", "choose_detector",
           "generic_ball_path", "inline_ball_model", "probe"]

PROBE_SECONDS = 5.0
"""The probe looks at each robot's images of its first this many seconds."""
PROBE_IMAGES = 20
"""... at most this many per robot, one per :data:`PROBE_SECONDS` / :data:`PROBE_IMAGES`."""
MIN_AREA_PX = 30.0
"""A colour-chain blob smaller than this is no clear ball (real images' specks are 12-50 px,
a simulated ball at 8 m about 40 px)."""
MIN_CIRCULARITY = 0.7
"""A colour-chain blob less round than this is no clear ball (a simulated ball: 0.75-0.95)."""
AGREE_M = 0.5
"""Two robots' balls agree when they lie this close on the field ..."""
AGREE_NS = 100_000_000
"""... at stamps this close (a ball rolling at 5 m/s moves 0.5 m in it)."""
MAX_CLEAR_BLOBS = 3
"""More ball-like colour-chain blobs than this in one image are no clear ball."""
Seen = tuple[Detection | None, Detection | None]
"""An image's clear ball to the colour chain and to the real detector (None: none)."""
METADATA_BALL = "orange"
"""The ball colour the colour chain's HSV box is made for."""


@dataclass(frozen=True)
class Probe:
    """What each detector found in each robot's probe images."""

    images: Mapping[str, int]
    """Robot -> its probe images that decoded."""
    paper: Mapping[str, int]
    """Robot -> images in which the colour chain finds one clear ball."""
    real: Mapping[str, int]
    """Robot -> images in which the real detector (generic model) reports a ball."""
    agree: Mapping[str, Mapping[str, int]] = dataclasses.field(default_factory=dict)
    """Detector -> robot -> its balls on the field that another robot's agrees with
    (:func:`_agreeing`); empty when the probe was given no cameras."""

    def found(self, detector: str) -> Mapping[str, int]:
        return self.real if detector == "real" else self.paper

    def total(self, detector: str) -> int:
        return sum(self.found(detector).values())

    def describe(self, detector: str) -> str:
        """"robot1 18/20, robot2 17/20" for one detector (names from the log made printable)."""
        found = self.found(detector)
        return ", ".join(f"{printable(r, limit=60)} {found[r]}/{n}"
                         for r, n in self.images.items())


@dataclass(frozen=True)
class Choice:
    """The detector chosen for a log, why, and what the replay must warn about."""

    detector: str
    why: str
    recorded: bool = True
    """Whether the results header records ``why`` (not for a dsp-record log's orange ball:
    its results stay as they were)."""
    ball: Path | None = None
    """The real detector's ball model file."""
    warnings: Mapping[str, str] = dataclasses.field(default_factory=dict)
    """Robot -> a warning: the chosen detector found no clear ball in its probe images."""
    probe: Probe | None = None


def generic_ball_path() -> Path:
    """The shipped generic ball model's file (``dsp-calibrate --ball-generic`` writes it)."""
    return Path(str(files("estimator.detection.real").joinpath(GENERIC_NAME)))


def _chooses(options: ReplayOptions) -> bool:
    """Whether the options leave the detector to the log: a profile's, with no detector or
    ball given, and not the paper's method (which is the paper's chain with its constants)."""
    return (options.profile is not None and options.detector is None and options.ball is None
            and options.method != "paper")


def choose_detector(reader: LogReader, options: ReplayOptions, pipeline: Pipeline,
                    cameras: Cameras) -> tuple[ReplayOptions, Pipeline, dict[str, str]]:
    """The options and pipeline with the detector chosen from the log (unchanged when the
    options choose it), and the warnings the choice gives, by robot. ``--detector real``
    with no ``--ball`` takes the ball model a camera file names, else the generic one."""
    if options.detector_name == "real" and options.ball is None:
        named = _camera_ball(cameras)
        ball, why = ((named.ball, named.why) if named is not None
                     else (generic_ball_path(), "--detector real with no --ball: the generic "
                           "ball model"))
        return (dataclasses.replace(options, ball=ball),
                dataclasses.replace(pipeline, detector="real", detector_choice=why), {})
    if not _chooses(options):
        return options, pipeline, {}
    choice = choice_for(reader, options, cameras)
    settled = options
    if choice.detector == "real":  # a camera file's inline model: no file (the runner's)
        ball = choice.ball or (None if inline_ball_model(cameras) else generic_ball_path())
        settled = dataclasses.replace(options, detector="real", ball=ball)
    return settled, dataclasses.replace(
        pipeline, detector=choice.detector, detector_choice=choice.why,
        detector_choice_recorded=choice.recorded), dict(choice.warnings)


def choice_for(reader: LogReader, options: ReplayOptions, cameras: Cameras) -> Choice:
    """The detector for the log (see the module docstring for the order)."""
    named = _camera_ball(cameras)
    if named is not None:
        return named
    info = reader.info
    colour = _recorded_ball(info)
    if colour == METADATA_BALL:
        return Choice("paper", "the log's dsp-record metadata states the colour chain's "
                      "orange ball", recorded=False)
    found = probe(reader, options, cameras)
    if not found.images:
        return Choice("paper", "no image of the log's first seconds decodes: the colour "
                      "chain, as before")
    detector = "real" if found.total("real") > found.total("paper") else "paper"
    other = "paper" if detector == "real" else "real"
    name = {"real": "the real detector (generic model)", "paper": "the colour chain"}
    why = (f"in its first images {name[detector]} finds a clear ball in "
           f"{found.describe(detector)}, {name[other]} in {found.describe(other)}")
    agree = found.agree.get(detector, {})
    if agree and len(found.images) > 1:
        why += (f"; {sum(agree.values())} of the {found.total(detector)} balls agree with "
                "another robot's on the field")
    if colour is not None:
        why = f"the log's ball is {colour}, not the colour chain's orange; {why}"
    return Choice(detector, why, warnings=_warnings(str(reader.path), found, detector),
                  probe=found)


def _warnings(log: str, found: Probe, detector: str) -> dict[str, str]:
    """Robot -> what the chosen detector found wrong in its first images: no clear ball, or
    (two robots or more finding one) none that another robot's agrees with."""
    where = printable(log, limit=200)
    seeing = {r: n for r, n in found.found(detector).items() if n}
    agree = found.agree.get(detector, {})
    out = {}
    for r, n in found.found(detector).items():
        if n == 0:
            out[r] = (f"{where}: {printable(r, limit=60)} shows no clear ball in its "
                      f"{found.images[r]} first images to the chosen {detector} detector: is "
                      "its camera covered, the ball out of its sight, or the ball unlike the "
                      "detector's (dsp-calibrate --ball-from labelled frames fits a model)?")
        elif agree and len(seeing) > 1 and agree.get(r, 0) == 0:
            out[r] = (f"{where}: none of the {n} balls the {detector} detector finds in "
                      f"{printable(r, limit=60)}'s first images agrees with another robot's "
                      f"(within {AGREE_M:g} m, {AGREE_NS / NS_PER_S:g} s): is its pose, its "
                      "camera description or what the detector takes for the ball wrong?")
    return out


def _camera_ball(cameras: Cameras) -> Choice | None:
    """The real detector with the ball model a camera description gives (a file's path,
    else an inline object: :func:`inline_ball_model`), if one does."""
    models = cameras.ball_models()
    paths = sorted({str(m) for m in models.values() if isinstance(m, str)})
    robots = ", ".join(printable(r, limit=60) for r in sorted(models))
    if not paths:
        inline = sorted(r for r, m in models.items() if not isinstance(m, str))
        if not inline:
            return None
        return Choice("real", f"the camera description gives {printable(inline[0], limit=60)}"
                      f"'s ball model inline ({robots})")
    why = f"the camera description names the ball model {Path(paths[0]).name} ({robots})"
    if len(paths) > 1:
        why += f"; the others ({', '.join(Path(p).name for p in paths[1:])}) are not used"
    return Choice("real", why, ball=Path(paths[0]))


def inline_ball_model(cameras: Cameras) -> BallModel | None:
    """The ball model a camera description gives as an object (``ball: {...}``, the JSON of
    a ``ball.json``), read; the first robot's by name where several do, None where none
    does. A file's path goes before it (:func:`_camera_ball`), as ``--ball`` does. Raises
    :class:`~dsp.errors.InputError` naming the description and the robot for an object that
    is no ball model."""
    inline = {r: m for r, m in cameras.ball_models().items() if not isinstance(m, str)}
    if not inline:
        return None
    robot = sorted(inline)[0]
    try:
        return model_from_dict(inline[robot])
    except BallModelError as err:
        where = (cameras.sources or {}).get(robot, "the camera description")
        raise InputError(f"{where}: {robot}.ball: {err}") from None


def _recorded_ball(info: LogInfo) -> str | None:
    """The ball colour a dsp-record log states (None: the log states none)."""
    scenario = info.scenario
    if info.recorder is None or scenario is None or scenario.recording is None:
        return None
    return scenario.recording.ball_colour


def probe(reader: LogReader, options: ReplayOptions, cameras: Cameras | None = None) -> Probe:
    """Both detectors on each robot's first images (see the module docstring); with
    ``cameras``, where each ball found lies on the field, and which agree (:func:`_agreeing`)."""
    picked, poses = _probe_images(reader, options)
    finder = BallFinder(shipped_generic(), shipped_check())
    with ThreadPoolExecutor(max(1, options.thread_count)) as pool:
        seen = list(pool.map(lambda m: _seen(m, options.max_image_pixels, finder), picked))
    order = [r for r in reader.info.robots if any(m.robot == r and s is not None
                                                  for m, s in zip(picked, seen, strict=True))]
    images = dict.fromkeys(order, 0)
    found: dict[str, dict[str, int]] = {d: dict.fromkeys(order, 0) for d in ("paper", "real")}
    for msg, both in zip(picked, seen, strict=True):
        if both is not None:
            images[msg.robot] += 1
            for d, det in zip(("paper", "real"), both, strict=True):
                found[d][msg.robot] += det is not None
    agree: dict[str, Mapping[str, int]] = {}
    if cameras is not None:
        tolerance = options.timing(log_origin_ns(reader.info)).tolerance_ns
        where = _located(picked, seen, poses, options, cameras, tolerance)
        agree = {d: _agreeing(where[d], order) for d in where}
    return Probe(images, found["paper"], found["real"], agree)


def _located(picked: Sequence[ImageMessage], seen: Sequence[Seen | None],
             poses: Mapping[str, History[PoseMessage]], options: ReplayOptions,
             cameras: Cameras, tolerance_ns: int) -> dict[str, list[tuple[str, int, float, float]]]:
    """Detector -> (robot, stamp, x, y) of each clear ball located from the robot's pose."""
    locate = FrameEstimator(method=options.method, fusion_method="mean", cameras=cameras)
    out: dict[str, list[tuple[str, int, float, float]]] = {"paper": [], "real": []}
    for msg, both in zip(picked, seen, strict=True):
        for d, det in zip(("paper", "real"), both or (None, None), strict=True):
            if det is None:
                continue
            try:
                pose = interpolate_pose(poses[msg.robot], msg.stamp_ns, tolerance_ns)
            except EstimatorError:  # a zero or NaN quaternion
                continue
            est = locate.estimate(msg.robot, None, functools.partial(_same, pose),
                                  detected=Detected(None, det)).estimate
            if est is not None:
                out[d].append((msg.robot, msg.stamp_ns, est.x_m, est.y_m))
    return out


def _same(pose: PoseMatch | None) -> PoseMatch | None:
    return pose


def _agreeing(where: Sequence[tuple[str, int, float, float]],
              robots: Sequence[str]) -> dict[str, int]:
    """Robot -> its located balls that another robot's lies within :data:`AGREE_M` of, at a
    stamp within :data:`AGREE_NS`."""
    out = dict.fromkeys(robots, 0)
    for robot, t, x, y in where:
        out[robot] += any(r != robot and abs(t2 - t) <= AGREE_NS
                          and math.hypot(x2 - x, y2 - y) <= AGREE_M
                          for r, t2, x2, y2 in where)
    return out


def _probe_images(reader: LogReader, options: ReplayOptions
                  ) -> tuple[list[ImageMessage], dict[str, History[PoseMessage]]]:
    """Per robot, the first image at or after each of :data:`PROBE_IMAGES` instants spread
    over its first :data:`PROBE_SECONDS` s, and the poses read meanwhile; reading stops at
    the first image logged a second after that span (of the first image's), or when every
    robot has its images."""
    info = reader.info
    start = options.timing(log_origin_ns(info)).start_ns
    span = round(PROBE_SECONDS * NS_PER_S)
    step = span // PROBE_IMAGES
    first: dict[str, int] = {}
    taken: dict[str, list[ImageMessage]] = {r: [] for r in info.robots}
    poses: dict[str, History[PoseMessage]] = {r: History(2 * span, 1 << 16)
                                              for r in info.robots}
    t0: int | None = None
    bad = dict(reader.bad_messages)
    try:
        for msg in reader.messages(start_ns=start):
            if isinstance(msg, PoseMessage):
                poses[msg.robot].add(msg)
            if not isinstance(msg, ImageMessage) or (start is not None and msg.stamp_ns < start):
                continue
            if t0 is not None and msg.log_time_ns > t0 + span + NS_PER_S:
                break
            t0 = msg.log_time_ns if t0 is None else t0
            s0 = first.setdefault(msg.robot, msg.stamp_ns)
            mine = taken[msg.robot]
            if len(mine) < PROBE_IMAGES and s0 + len(mine) * step <= msg.stamp_ns < s0 + span:
                mine.append(msg)
            if all(len(v) >= PROBE_IMAGES for v in taken.values()):
                break
    finally:
        reader.bad_messages = bad  # the replay's pass counts them, once
    return [m for r in info.robots for m in taken[r]], poses


def _seen(msg: ImageMessage, max_pixels: int, finder: BallFinder) -> Seen | None:
    """The image's clear ball to each detector; None: the image does not decode."""
    image = decode_image(msg, max_pixels=max_pixels)
    if image is None:
        return None
    try:
        real = finder(image).detection
    except EstimatorError:
        real = None
    return _paper_clear(image), real


def _paper_clear(image: np.ndarray[Any, Any],
                 params: DetectionParams | None = None) -> Detection | None:
    """The colour chain's most ball-like blob when it finds 1 to :data:`MAX_CLEAR_BLOBS`
    round blobs of a ball's size (in its own order, best first), else None."""
    p = params or DetectionParams()
    try:
        blobs = detect_blobs(image, p)
    except EstimatorError:
        return None
    clear = [b for b in blobs if _ball_like(b.area_px, b.bbox_px, b.circularity, p)]
    return clear[0] if 1 <= len(clear) <= MAX_CLEAR_BLOBS else None


def _ball_like(area_px: float, bbox_px: Sequence[int], circularity: float,
               p: DetectionParams) -> bool:
    w, h = bbox_px[2], bbox_px[3]
    fill = area_px / max(1, w * h)
    return (max(MIN_AREA_PX, p.min_area_px) <= area_px <= p.max_area_px
            and circularity >= MIN_CIRCULARITY and p.min_fill_ratio <= fill <= p.max_fill_ratio)
