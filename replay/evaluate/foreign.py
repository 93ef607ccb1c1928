"""Foreign logs: seeded match logs in a team's own layout, drawn without the recorder.

The replay's defaults must hold on logs the project did not record. This writes one such
log from a seed and a few parameters, with its own motion (:mod:`.foreign_scene`) and its
own omnidirectional camera and images (:mod:`.foreign_render`), numpy + OpenCV + the mcap
writer only (no pybullet, nothing of ``recorder/``)::

    python -m replay.evaluate.foreign OUT.mcap --seed 3 --robots 3 --rate 20 \
        --poses drift --drift 0.05,1.0 --covariance honest --duration 10 --image jpeg

The log holds what a team's rosbag2 MCAP holds, and nothing of the project's:

- ``/{robot}/camera/image_raw``: sensor_msgs/CompressedImage JPEG or sensor_msgs/Image
  rgb8, each robot's camera free-running at ``rate_hz`` from its own seeded phase;
- ``/{robot}/pose`` (geometry_msgs/PoseStamped) or, with a covariance,
  ``/{robot}/amcl_pose`` (PoseWithCovarianceStamped, the x, y and yaw variances stating
  the error's sigma times ``covariance_scale``): :data:`POSE_RATE_HZ`, each robot at its
  own phase, in the frame ``map`` (here the field frame), exact or drifting;
- ``/mocap/ball``: the ball's centre and velocity (nav_msgs/Odometry; or its centre alone,
  PointStamped or PoseStamped) at :data:`TRUTH_RATE_HZ`, a motion-capture system's topic;
- robots ``r1``, ``r2``, ...; stamps in Unix time from ``epoch_s``; no dsp metadata, no
  /tf, no /ground_truth topics.

Beside it, :func:`write_camera_file` writes the camera file that describes the cameras
exactly (a ``lookup`` calibration rendered from the camera itself, or with ``camera
"mirror"`` the project's mirror model with its height), so that
``dsp-replay LOG --cameras CAMS.yaml --image-topic ... --pose-topic ... --truth-topic
/mocap/ball`` replays and scores it (:func:`replay_arguments`). The same options and seed
give a byte-identical log.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import cv2
import numpy as np

from dsp import contract
from dsp.atomic import atomic_output
from dsp.camera_file import camera_file_text
from dsp.field import FIELDS, FieldSpec
from replay.evaluate.foreign_render import OmniModel, Renderer, lookup_table
from replay.evaluate.foreign_scene import BALL_RADIUS_M, PoseError, Scene, make_scene, pose_errors

__all__ = [
    "EPOCH_S",
    "IMAGE_TOPIC",
    "POSE_RATE_HZ",
    "TRUTH_RATE_HZ",
    "TRUTH_TOPIC",
    "ForeignOptions",
    "PoseStream",
    "camera_entry",
    "pose_streams",
    "pose_topic",
    "replay_arguments",
    "write_camera_file",
    "write_foreign_log",
]

EPOCH_S = 1_700_000_000
IMAGE_TOPIC = "/{robot}/camera/image_raw"
TRUTH_TOPIC = "/mocap/ball"
POSE_RATE_HZ = 50.0
TRUTH_RATE_HZ = 100.0
MAP_FRAME = "map"
JPEG_QUALITY = 90
USABLE_RANGE_M = 9.0
"""The camera file's usable radius: where a ball 9 m away shows."""
POSE_KINDS = ("exact", "drift")
COVARIANCES = ("none", "honest")
IMAGE_KINDS = ("jpeg", "raw")
TRUTH_KINDS = ("odometry", "point", "pose")
CAMERA_KINDS = ("own", "mirror")
EXACT_STATED_SIGMA = (0.001, math.radians(0.05))
"""The sigma an exact pose's covariance states (m, rad): an all-zero covariance would read
as "unknown"."""


@dataclass(frozen=True)
class ForeignOptions:
    """What one foreign log is drawn with (see the module docstring)."""

    seed: int = 0
    robots: int = 3
    rate_hz: float = 20.0
    duration_s: float = 10.0
    poses: str = "exact"
    drift: tuple[float, float] = (0.05, 1.0)
    """The drifting bias's stationary sigma (m, deg) with ``poses="drift"``."""
    tau_s: float = 3.0
    covariance: str = "none"
    covariance_scale: float = 1.0
    """The stated sigma over the honest one (1: honest; 0.5: the localiser is overconfident)."""
    image: str = "jpeg"
    camera: str = "own"
    """The mirror's profile (:class:`~replay.evaluate.foreign_render.OmniModel`): "own", in
    the camera file as a lookup table; "mirror", as the project's mirror model with its
    height (so the replay can cross rays in 3-D)."""
    size_px: int = 640
    centre_offset_px: tuple[float, float] = (2.0, -3.0)
    field: str = "18x12"
    names_field: bool = False
    """The camera file names the field (its ``field`` key), as a team's may: the default
    then corrects the poses from the field lines where a robot's camera has a model (the
    "mirror" profile; a lookup table names no camera height, so no line fit)."""
    truth: str = "odometry"
    """/mocap/ball as nav_msgs/Odometry (position and velocity: the replay scores both),
    geometry_msgs/PointStamped or PoseStamped (position only)."""
    epoch_s: int = EPOCH_S

    def __post_init__(self) -> None:
        for name, value, allowed in (("poses", self.poses, POSE_KINDS),
                                     ("covariance", self.covariance, COVARIANCES),
                                     ("image", self.image, IMAGE_KINDS),
                                     ("truth", self.truth, TRUTH_KINDS),
                                     ("camera", self.camera, CAMERA_KINDS),
                                     ("field", self.field, tuple(FIELDS))):
            if value not in allowed:
                raise ValueError(f"{name} = {value!r}: give one of {', '.join(allowed)}")
        if self.robots < 1 or not self.rate_hz > 0 or not self.duration_s > 0:
            raise ValueError("a foreign log needs a robot, a camera rate and a duration")

    @property
    def pose_error(self) -> PoseError:
        return PoseError() if self.poses == "exact" else PoseError.drift(*self.drift,
                                                                          tau_s=self.tau_s)

    @property
    def model(self) -> OmniModel:
        return OmniModel.for_size(self.size_px, self.size_px, self.centre_offset_px,
                                  profile=self.camera)

    @property
    def field_spec(self) -> FieldSpec:
        return FIELDS[self.field]


def pose_topic(options: ForeignOptions) -> str:
    """Where the poses go: AMCL's topic when they carry a covariance."""
    return "/{robot}/pose" if options.covariance == "none" else "/{robot}/amcl_pose"


def replay_arguments(log: Path, cameras: Path, options: ForeignOptions) -> list[str]:
    """The ``dsp-replay`` arguments that replay and score the log."""
    return [str(log), "--cameras", str(cameras), "--image-topic", IMAGE_TOPIC,
            "--pose-topic", pose_topic(options), "--truth-topic", TRUTH_TOPIC]


def camera_entry(options: ForeignOptions) -> dict[str, Any]:
    """The camera file's ``default`` entry: the image, its centre, the usable radius, and the
    lookup calibration of :func:`~replay.evaluate.foreign_render.lookup_table` (camera
    "own") or the mirror model's parameters (camera "mirror")."""
    m = options.model
    r_px, d_m = lookup_table(m, BALL_RADIUS_M, step_px=1.0)
    usable = round(float(np.interp(USABLE_RANGE_M, d_m, r_px)), 2)
    head = {"width_px": m.width_px, "height_px": m.height_px, "cu_px": m.cu_px,
            "cv_px": m.cv_px}
    if m.profile == "mirror":
        return {"model": "mirror", **head, "max_radius_px": m.radius_px,
                "height_m": m.height_m, "a_m": m.a_m, "b_rad_per_px": m.b_rad_per_px,
                "self_radius_px": m.self_radius_px, "usable_radius_px": usable}
    return {"model": "lookup", **head, "usable_radius_px": usable,
            "calibration": {"model": "lookup", "r_px": r_px, "d_m": d_m}}


def write_camera_file(path: Path, options: ForeignOptions, *, force: bool = False) -> None:
    with atomic_output(path, force=force) as tmp:
        tmp.write_text(camera_file_text(
            {"default": camera_entry(options)}, path.suffix.lower(),
            header="The cameras of a foreign log, described exactly "
            "(python -m replay.evaluate.foreign).",
            field=options.field if options.names_field else None), encoding="utf-8")


@dataclass(frozen=True)
class _Event:
    t_ns: int
    rank: int
    """0 truth, 1 pose, 2 image: the order of messages of one stamp."""
    robot: int
    index: int
    """The pose's index in the robot's pose stream."""


def _stamps(rng: np.random.Generator, rate_hz: float, duration_ns: int) -> np.ndarray:
    period = round(1e9 / rate_hz)
    phase = int(rng.integers(0, period))
    return np.arange(phase, duration_ns, period, dtype=np.int64)


def _events(options: ForeignOptions, duration_ns: int, rng: np.random.Generator
            ) -> tuple[list[_Event], list[np.ndarray]]:
    """Every message's stamp in writing order, and each robot's pose stamps."""
    truth = np.arange(0, duration_ns, round(1e9 / TRUTH_RATE_HZ), dtype=np.int64)
    events = [_Event(int(t), 0, -1, 0) for t in truth]
    pose_stamps = []
    for r in range(options.robots):
        poses = _stamps(rng, POSE_RATE_HZ, duration_ns)
        pose_stamps.append(poses)
        events += [_Event(int(t), 1, r, i) for i, t in enumerate(poses)]
        events += [_Event(int(t), 2, r, 0) for t in _stamps(rng, options.rate_hz, duration_ns)]
    return sorted(events, key=lambda e: (e.t_ns, e.rank, e.robot)), pose_stamps


def _yaw_quaternion(yaw: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


class _Log:
    """The MCAP writer with its schemas registered on first use."""

    def __init__(self, stream: IO[bytes]) -> None:
        from mcap.writer import CompressionType
        from mcap_ros2.writer import Writer

        self.writer = Writer(stream, chunk_size=1 << 20, compression=CompressionType.ZSTD)
        self.schemas: dict[str, Any] = {}

    def write(self, topic: str, schema: str, msg: dict[str, Any], t_ns: int) -> None:
        if schema not in self.schemas:
            self.schemas[schema] = self.writer.register_msgdef(
                schema, contract.MESSAGE_DEFINITIONS[schema])
        self.writer.write_message(topic, self.schemas[schema], msg, log_time=t_ns,
                                  publish_time=t_ns)


def _pose_message(options: ForeignOptions, t_ns: int, pose: np.ndarray
                  ) -> tuple[str, dict[str, Any]]:
    x, y, yaw = (float(v) for v in pose)
    q = _yaw_quaternion(yaw)
    if options.covariance == "none":
        return contract.POSE_STAMPED, contract.pose_stamped(t_ns, x, y, 0.0, q,
                                                            frame_id=MAP_FRAME)
    err = options.pose_error
    sigma_m, sigma_rad = EXACT_STATED_SIGMA if err.exact else err.stated_sigma()
    k2 = options.covariance_scale ** 2
    msg = contract.pose_with_covariance_stamped(
        t_ns, x, y, [[k2 * sigma_m ** 2, 0.0], [0.0, k2 * sigma_m ** 2]], q=q,
        frame_id=MAP_FRAME)
    msg["pose"]["covariance"][35] = k2 * sigma_rad ** 2  # yaw (rotation about z)
    return contract.POSE_WITH_COVARIANCE_STAMPED, msg


def _truth_message(options: ForeignOptions, t_ns: int, scene: Scene, scene_ns: int
                   ) -> tuple[str, dict[str, Any]]:
    ball = scene.ball_at(scene_ns)
    if options.truth == "odometry":
        vx, vy, vz = scene.ball_velocity_at(scene_ns)
        return contract.ODOMETRY, contract.odometry(t_ns, "ball", ball[0], ball[1], vx, vy,
                                                    z_m=ball[2], vz_m_s=vz, frame_id=MAP_FRAME)
    if options.truth == "point":
        return contract.POINT_STAMPED, contract.point_stamped(t_ns, *ball, frame_id=MAP_FRAME)
    return contract.POSE_STAMPED, contract.pose_stamped(t_ns, *ball, frame_id=MAP_FRAME)


def _image_message(options: ForeignOptions, robot: str, t_ns: int, img: np.ndarray
                   ) -> tuple[str, dict[str, Any]]:
    frame = f"{robot}/camera"
    if options.image == "jpeg":
        ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
        assert ok
        return contract.COMPRESSED_IMAGE, contract.compressed_image(
            t_ns, frame, "jpeg", buf.tobytes())
    rgb = cv2.cvtColor(img, cv2.COLOR_BGR2RGB)
    return contract.IMAGE, {
        "header": contract.header(t_ns, frame), "height": rgb.shape[0], "width": rgb.shape[1],
        "encoding": "rgb8", "is_bigendian": 0, "step": rgb.shape[1] * 3, "data": rgb.tobytes()}


@dataclass(frozen=True)
class PoseStream:
    """One robot's pose messages: stamps from the log's start [ns], the true poses and the
    published ones, (n, 3) arrays of x [m], y [m], yaw [rad]."""

    robot: str
    stamps_ns: np.ndarray
    truth: np.ndarray
    believed: np.ndarray


@dataclass(frozen=True)
class _Drawn:
    scene: Scene
    events: list[_Event]
    poses: list[PoseStream]


def _draw(options: ForeignOptions, *, ball: bool = True
          ) -> tuple[_Drawn, np.random.Generator, np.random.Generator]:
    """The scene, the messages' stamps and the poses (each from its own seeded stream, so
    one part's draws never shift another's); the texture's and the renderer's streams.
    Without ``ball`` the ball's track is not integrated (the rest is the same)."""
    scene_rng, texture_rng, stamp_rng, error_rng, render_rng = (
        np.random.default_rng(s) for s in np.random.SeedSequence(options.seed).spawn(5))
    duration_ns = round(options.duration_s * 1e9)
    scene = make_scene(scene_rng, options.field_spec, options.robots, duration_ns, ball=ball)
    events, pose_stamps = _events(options, duration_ns, stamp_rng)
    poses = []
    for r, stamps in enumerate(pose_stamps):
        truth = np.stack(scene.robot_pose(r, stamps), axis=1)
        believed = truth + pose_errors(error_rng, options.pose_error, stamps)
        believed[:, 2] = np.remainder(believed[:, 2] + math.pi, math.tau) - math.pi
        poses.append(PoseStream(scene.robots[r], stamps, truth, believed))
    return _Drawn(scene, events, poses), texture_rng, render_rng


def pose_streams(options: ForeignOptions) -> list[PoseStream]:
    """Every robot's poses as the log holds them (no image drawn: cheap for long streams)."""
    return _draw(options, ball=False)[0].poses


def _messages(options: ForeignOptions) -> Iterator[tuple[str, str, dict[str, Any], int]]:
    """(topic, schema, message, Unix stamp [ns]) of every message, in writing order."""
    drawn, texture_rng, render_rng = _draw(options)
    scene, events = drawn.scene, drawn.events
    believed = [p.believed for p in drawn.poses]
    renderer = Renderer(options.model, options.field_spec, texture_rng)
    topic, offset = pose_topic(options), options.epoch_s * 1_000_000_000
    for e in events:
        stamp = e.t_ns + offset
        if e.rank == 0:
            yield (TRUTH_TOPIC, *_truth_message(options, stamp, scene, e.t_ns), stamp)
            continue
        robot = scene.robots[e.robot]
        if e.rank == 1:
            schema, msg = _pose_message(options, stamp, believed[e.robot][e.index])
            yield topic.format(robot=robot), schema, msg, stamp
            continue
        x, y, yaw = (float(v) for v in scene.robot_pose(e.robot, e.t_ns))
        others = [(float(ox), float(oy)) for ox, oy, _ in
                  (scene.robot_pose(o, e.t_ns) for o in range(options.robots) if o != e.robot)]
        img = renderer.render((x, y, yaw), scene.ball_at(e.t_ns), others, render_rng,
                              BALL_RADIUS_M)
        yield (IMAGE_TOPIC.format(robot=robot), *_image_message(options, robot, stamp, img),
               stamp)


def write_foreign_log(path: Path, options: ForeignOptions, *, force: bool = False) -> int:
    """Write the log (refusing an existing file unless ``force``); return its message count.
    Stamps in the messages and the log are ``epoch_s`` plus the scene's time."""
    count = 0
    with atomic_output(path, force=force) as tmp, tmp.open("wb") as f:
        log = _Log(f)
        for topic, schema, msg, t_ns in _messages(options):
            log.write(topic, schema, msg, t_ns)
            count += 1
        log.writer.finish()  # type: ignore[no-untyped-call]
    return count


if __name__ == "__main__":  # pragma: no cover
    # ``python -m replay.evaluate.foreign`` runs the command module; the writer itself never
    # imports a command (tests/test_structure.py)
    import runpy

    runpy.run_module("replay.evaluate.foreign_cli", run_name="__main__", alter_sys=True)
