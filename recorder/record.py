"""Record a scenario to a log: the one typed function the CLI (and others) call.

Timeline (integer sim nanoseconds from 0): camera frames every ``T = 1 / rate`` and poses,
``/tf`` and ground truth every ``T / 2`` (twice the camera rate, so replay can interpolate
a pose at any image stamp). Physics steps at 240 Hz in between. Images are rendered from
each robot's true pose; ``/robotN/pose`` and ``/tf`` carry what the robot believes (the
truth plus optional Gaussian noise); ``/ground_truth/...`` carry the truth.

:func:`record` resolves a :class:`RecordOptions` against the scenario, writes the metadata
records (:func:`log_metadata`) and runs the frame loop (:class:`_Simulation`).

The log is written as ``<name>.partial.mcap`` in the output's folder (numbered,
``<name>.partial-2.mcap``, when one exists: an earlier partial log is never replaced) and
renamed when done. On Ctrl-C the MCAP is finished (so it is readable), kept there and
``RecordingInterrupted`` says where; a killed recording leaves it too, readable with
``dsp-replay --recover`` up to its last whole sim second (``recorder.writer``).
:func:`partial_logs` lists such files, so the next recording to the same path names them.
"""

from __future__ import annotations

import platform
import time
from collections.abc import Callable
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from dsp import contract as c
from dsp import metadata as meta
from dsp.atomic import AtomicFile, check_output_path, partial_paths
from dsp.checks import check_int, check_number
from dsp.cli import check_suffix, progress_bar
from dsp.errors import UsageError
from estimator.camera import CAMERA_MODELS, CameraModel, make_camera
from recorder.errors import RecorderError, UnknownScenarioError
from recorder.field import field_spec
from recorder.omni import DEFAULT_FACE_PX, OmniRenderer
from recorder.scenarios import SCENARIOS, Scenario, make_scenario, scenario_from_path
from recorder.world import PHYSICS_HZ, World
from recorder.writer import LogWriter

__all__ = [
    "IMAGE_FORMATS",
    "RecordOptions",
    "RecordSummary",
    "RecordingInterrupted",
    "log_metadata",
    "partial_logs",
    "record",
]

IMAGE_FORMATS = ("png", "jpeg")
_NS = 1_000_000_000
MAX_SEED = 2**63 - 1
MAX_DURATION_S = 86_400.0
"""The longest recording [sim s] (a day); with --rate at most MAX_FRAMES frames."""
MAX_FRAMES = 10_000_000
MAX_FACE_PX = 4096
"""Six faces of 4096^2 RGB are ~300 MB; larger would exhaust memory, not sharpen the image."""
MAX_POSE_NOISE_M = 100.0


class RecordingInterrupted(RecorderError):
    """Ctrl-C: the partial log was finished and kept at ``partial_path``."""

    exit_code = 130

    def __init__(self, partial_path: Path, frames: int) -> None:
        super().__init__(
            f"interrupted after {frames} frame(s); the partial log is readable at {partial_path}"
        )
        self.partial_path = partial_path
        self.frames = frames


@dataclass(frozen=True)
class RecordOptions:
    """What to record and how; checked when made (``UsageError`` names the bad value).

    ``duration_s`` or ``frames`` (default: the scenario's, 1 s for static scenes) at
    ``rate_hz`` camera frames per second (default: the scenario's, 5 Hz for static scenes).
    ``pose_noise_m`` / ``yaw_noise_deg``: standard deviations of the believed pose's noise.
    ``renderer``: "auto" (EGL if it loads, else TinyRenderer; env DSP_RENDERER overrides),
    "egl" or "tiny". ``scenario`` None: the one the output's file name names.
    """

    scenario: str | None = None
    seed: int = 0
    duration_s: float | None = None
    frames: int | None = None
    rate_hz: float | None = None
    camera: str = "ideal"
    image_format: str = "png"
    jpeg_quality: int = 90
    pose_noise_m: float = 0.0
    yaw_noise_deg: float = 0.0
    robots: int | None = None
    field: str = "18x12"
    face_px: int = DEFAULT_FACE_PX
    renderer: str = "auto"
    force: bool = False
    progress: bool | None = False
    """True a bar, False none, None plain lines (:func:`dsp.cli.progress_bar`)."""

    def __post_init__(self) -> None:
        if self.camera not in CAMERA_MODELS:
            raise UsageError(
                f"unknown camera {self.camera!r}; choose one of {', '.join(CAMERA_MODELS)}")
        if self.image_format not in IMAGE_FORMATS:
            raise UsageError(f"unknown image format {self.image_format!r}; choose png or jpeg")
        check_int("--seed", self.seed, low=0, high=MAX_SEED)
        check_int("--jpeg-quality", self.jpeg_quality, low=1, high=100)
        check_number("--pose-noise", self.pose_noise_m, low=0, high=MAX_POSE_NOISE_M, unit="m")
        check_number("--yaw-noise", self.yaw_noise_deg, low=0, high=180, unit="deg")
        check_int("--face-px", self.face_px, low=256, high=MAX_FACE_PX)
        field_spec(self.field)
        if self.renderer not in c.RENDERERS:
            raise UsageError(
                f"unknown renderer {self.renderer!r}; choose one of {', '.join(c.RENDERERS)}")
        if self.frames is not None and self.duration_s is not None:
            raise UsageError("give --frames or --duration, not both")
        check_int("--frames", self.frames, low=1, high=MAX_FRAMES)
        check_number("--duration", self.duration_s, low=0, high=MAX_DURATION_S, low_open=True,
                     unit="s")
        check_number("--rate", self.rate_hz, low=0, high=1000, low_open=True, unit="Hz")
        check_int("--robot-count", self.robots, low=1, high=8)


@dataclass(frozen=True)
class RecordSummary:
    """What a recording produced."""

    path: Path
    scenario: str
    seed: int
    frames: int
    robots: int
    camera: str
    image_format: str
    rate_hz: float
    sim_duration_ns: int
    """Stamp of the last message (poses run half a camera period past the last image)."""
    messages: int
    file_size_bytes: int
    renderer: str
    wall_time_s: float


@dataclass(frozen=True)
class _Plan:
    """Options resolved against the scenario: what the frame loop runs."""

    scenario: Scenario
    rate_hz: float
    frames: int

    @property
    def pose_period_ns(self) -> int:
        return max(1, round(_NS / self.rate_hz / 2))  # poses at twice the camera rate


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "unknown"


def _resolve_scenario(path: Path, scenario: str | None) -> str:
    name = scenario if scenario is not None else scenario_from_path(path)
    if name is None:
        raise UnknownScenarioError(
            f"cannot tell the scenario from the file name {path.name!r}; pass --scenario "
            f"or name the file after one of: {', '.join(SCENARIOS)}"
        )
    if name not in SCENARIOS:
        raise UnknownScenarioError(
            f"unknown scenario {name!r}; choose one of: {', '.join(SCENARIOS)}"
        )
    return name


def _plan(path: Path, options: RecordOptions) -> _Plan:
    """The scenario, rate and frame count; refuses a missing folder or an existing log."""
    name = _resolve_scenario(path, options.scenario)
    sc = make_scenario(name, options.seed, robots=options.robots, field=options.field)
    rate = sc.default_rate_hz if options.rate_hz is None else options.rate_hz
    if options.frames is not None:
        frames = options.frames
    else:
        duration = sc.default_duration_s if options.duration_s is None else options.duration_s
        frames = max(1, round(duration * rate))
    check_suffix("output", path, (".mcap",))
    check_output_path(path, force=options.force)
    return _Plan(sc, rate, frames)


def log_metadata(
    sc: Scenario, options: RecordOptions, *, rate_hz: float, frames: int, renderer: str,
    camera: CameraModel,
) -> tuple[meta.ScenarioMetadata, meta.CamerasMetadata, meta.RecorderMetadata]:
    """The log's metadata records: the scenario (with how it is recorded), each robot's
    camera model and the recorder (renderer, physics, package versions)."""
    scene = sc.params()
    field_name = scene.pop("field")
    recording = meta.RecordingMetadata(
        rate_hz=rate_hz, pose_rate_hz=2 * rate_hz, frames=frames, camera=options.camera,
        image_format=options.image_format, pose_noise_m=options.pose_noise_m,
        yaw_noise_deg=options.yaw_noise_deg, face_px=options.face_px, physics_hz=PHYSICS_HZ,
    )
    scenario = meta.ScenarioMetadata(sc.name, sc.seed, field_name, recording, scene)
    cameras = meta.CamerasMetadata(tuple(meta.CameraMetadata(tr.name, camera.to_dict())
                                      for tr in sc.robots))
    versions = {
        "dual_sight": _version("dual-sight"),
        "pybullet": _version("pybullet"),
        "numpy": _version("numpy"),
        "opencv": cv2.__version__,
        "mcap": _version("mcap"),
        "mcap_ros2": _version("mcap-ros2-support"),
        "python": platform.python_version(),
    }
    recorder = meta.RecorderMetadata(renderer, PHYSICS_HZ, options.face_px, versions)
    return scenario, cameras, recorder


def _encode(img: np.ndarray, fmt: str, jpeg_quality: int) -> bytes:
    if fmt == "png":
        ok, buf = cv2.imencode(".png", img, [cv2.IMWRITE_PNG_COMPRESSION, 3])
    else:
        ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, jpeg_quality])
    if not ok:  # pragma: no cover - OpenCV failure
        raise RecorderError(f"OpenCV could not encode a {fmt} image")
    return buf.tobytes()


class _Simulation:
    """The frame loop: steps the world and writes poses, /tf, truth and images."""

    def __init__(self, world: World, plan: _Plan, options: RecordOptions,
                 camera: CameraModel) -> None:
        self.world = world
        self.plan = plan
        self.options = options
        sc = plan.scenario
        for tr in (*sc.robots, *sc.opponents):
            world.add_robot(tr.name, opponent=tr.opponent)
            world.set_robot_pose(tr.name, *tr.pose_at(0.0))
        world.set_ball(*sc.ball_xy_m, *sc.ball_velocity_mps)
        self.moving = [tr for tr in (*sc.robots, *sc.opponents) if tr.moving]
        self.omni = OmniRenderer(camera, face_px=options.face_px, renderer=world.renderer)
        self.noise_rng = np.random.default_rng([options.seed, 1])
        self.steps_done = 0
        self.frames_done = 0

    def run(self, writer: LogWriter, bar: Any) -> None:
        """Two pose ticks per camera frame; images on the even ones."""
        for k in range(2 * self.plan.frames):
            t_ns = k * self.plan.pose_period_ns
            self._advance_to(t_ns)
            truth = {tr.name: tr.pose_at(t_ns / _NS) for tr in self.plan.scenario.robots}
            self._write_poses(writer, t_ns, truth)
            if k % 2 == 0:
                for robot, (x, y, yaw) in truth.items():
                    img = self.omni.render(self.world, robot, x, y, yaw)
                    fmt = self.options.image_format
                    writer.write_image(robot, t_ns, _encode(img, fmt, self.options.jpeg_quality),
                                       fmt)
                self.frames_done += 1
                bar.update(1)

    def _advance_to(self, t_ns: int) -> None:
        """Physics steps (moving the kinematic robots) up to the one nearest ``t_ns``."""
        target = (t_ns * PHYSICS_HZ + _NS // 2) // _NS
        while self.steps_done < target:
            self.steps_done += 1
            for tr in self.moving:
                self.world.set_robot_pose(tr.name, *tr.pose_at(self.steps_done / PHYSICS_HZ))
            self.world.step()

    def _believed(self, truth: dict[str, tuple[float, float, float]]
                  ) -> dict[str, tuple[float, float, float]]:
        """The truth plus the options' Gaussian noise (yaw wrapped to (-pi, pi])."""
        yaw_sigma = np.deg2rad(self.options.yaw_noise_deg)
        believed = {}
        for robot, (x, y, yaw) in truth.items():
            dx, dy = self.noise_rng.normal(0.0, 1.0, 2) * self.options.pose_noise_m
            dyaw = float(self.noise_rng.normal(0.0, 1.0)) * yaw_sigma
            yaw_b = float(np.arctan2(np.sin(yaw + dyaw), np.cos(yaw + dyaw)))
            believed[robot] = (x + float(dx), y + float(dy), yaw_b)
        return believed

    def _write_poses(self, writer: LogWriter, t_ns: int,
                     truth: dict[str, tuple[float, float, float]]) -> None:
        believed = self._believed(truth)
        for robot, (x, y, yaw) in truth.items():
            writer.write_pose(c.topic_for(c.GT_POSE_TOPIC, robot), t_ns, x, y, 0.0, yaw)
        for robot, (x, y, yaw) in believed.items():
            writer.write_pose(c.topic_for(c.POSE_TOPIC, robot), t_ns, x, y, 0.0, yaw)
        writer.write_tf(t_ns, believed)
        bx, by, bz = self.world.ball_position()
        writer.write_pose(c.GT_BALL_TOPIC, t_ns, bx, by, bz, 0.0)


PARTIAL = ".partial"
"""A log is written as ``NAME.partial.mcap`` (``NAME.partial-2.mcap``, ... when one exists)
beside ``NAME.mcap`` and renamed when done."""


def _write_log(path: Path, fill: Callable[[LogWriter], None],
               interrupted: Callable[[Path], Exception], *, force: bool) -> int:
    """Write the log through ``fill`` to a new visible ``NAME.partial.mcap`` beside ``path``
    (created exclusively, numbered so an earlier one is never replaced) and rename it into
    place, fsynced; return the message count. On Ctrl-C the log is finished (readable), kept
    under its partial name and ``interrupted(partial)`` raised. A killed recording leaves the
    partial file, readable up to its last whole sim second with ``dsp-replay --recover``. On
    any other failure the partial file is removed."""
    out = AtomicFile(path, force=force, partial=PARTIAL)
    try:
        with out.guard(), out.stream() as stream:  # guard: also a failing close
            writer = LogWriter(stream)
            try:
                fill(writer)
            except KeyboardInterrupt:
                writer.finish()
                stream.close()
                raise interrupted(out.keep()) from None
            writer.finish()
        out.commit()
        return writer.messages
    finally:
        out.discard()


def partial_logs(path: Path | str) -> list[Path]:
    """Partial logs beside ``path`` left by recordings to it that were interrupted or killed
    (or that are still running)."""
    return partial_paths(path, PARTIAL)


def record(path: str | Path, options: RecordOptions) -> RecordSummary:
    """Record ``options.scenario`` (or the one the file name names) to the MCAP log ``path``.

    Raises ``RecorderError`` subclasses for every known failure.
    """
    t_wall = time.perf_counter()
    path = Path(path)
    plan = _plan(path, options)
    camera = make_camera(options.camera)
    with World(field_spec(options.field), renderer=options.renderer) as world:
        sim = _Simulation(world, plan, options, camera)
        scenario, cameras, recorder = log_metadata(
            plan.scenario, options, rate_hz=plan.rate_hz, frames=plan.frames,
            renderer=world.renderer, camera=camera)

        def fill(writer: LogWriter) -> None:
            writer.metadata(c.SCENARIO_METADATA, scenario.to_metadata())
            writer.metadata(c.CAMERAS_METADATA, cameras.to_metadata())
            writer.metadata(c.RECORDER_METADATA, recorder.to_metadata())
            writer.flush()  # the metadata reach the disk before the first frame
            with progress_bar(plan.frames, path.name, options.progress, unit="frame") as bar:
                sim.run(writer, bar)

        messages = _write_log(path, fill,
                              lambda partial: RecordingInterrupted(partial, sim.frames_done),
                              force=options.force)
        used_renderer = world.renderer
    return RecordSummary(
        path=path,
        scenario=plan.scenario.name,
        seed=options.seed,
        frames=plan.frames,
        robots=len(plan.scenario.robots),
        camera=options.camera,
        image_format=options.image_format,
        rate_hz=plan.rate_hz,
        sim_duration_ns=(2 * plan.frames - 1) * plan.pose_period_ns,
        messages=messages,
        file_size_bytes=path.stat().st_size,
        renderer=used_renderer,
        wall_time_s=time.perf_counter() - t_wall,
    )
