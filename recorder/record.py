"""Record a scenario to a log: the one typed function the CLI (and others) call.

Timeline (integer sim nanoseconds from 0): camera frames every ``T = 1 / rate`` and poses,
``/tf`` and ground truth every ``T / 2`` (twice the camera rate, so replay can interpolate
a pose at any image stamp; a match writes them at the physics rate, 240 Hz). Physics steps
at 240 Hz in between. Each camera fires at its own phase (``camera_phase`` "random": no two
robots' images share a stamp) or all together ("sync"). Images are rendered from each
robot's true pose; ``/robotN/pose`` and ``/tf`` carry what the robot believes (the truth plus
an optional drifting bias and Gaussian noise); ``/ground_truth/...`` carry the truth.

:func:`record` resolves a :class:`RecordOptions` against the scenario, writes the metadata
records (:func:`log_metadata`) and runs the frame loop
(:class:`recorder.simulation.Simulation`).

The log is written as ``<name>.partial.mcap`` in the output's folder (numbered,
``<name>.partial-2.mcap``, when one exists: an earlier partial log is never replaced) and
renamed when done. On Ctrl-C the MCAP is finished (so it is readable), kept there and
``RecordingInterrupted`` says where; a killed recording leaves it too, readable with
``dsp-replay --recover`` up to its last whole sim second (``recorder.writer``).
:func:`partial_logs` lists such files, so the next recording to the same path names them.
"""

from __future__ import annotations

import dataclasses
import platform
import time
from collections.abc import Callable
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

import cv2
import numpy as np

from dsp import checks
from dsp import contract as c
from dsp import metadata as meta
from dsp.atomic import AtomicFile, check_output_path, partial_paths
from dsp.checks import MAX_FACE_PX, MAX_RATE_HZ, MIN_RATE_HZ, check_int, check_number, check_suffix
from dsp.errors import UsageError
from dsp.progress import progress_bar
from dsp.realism import Realism
from estimator.camera import CAMERA_MODELS, CameraModel, make_camera
from estimator.constants import NS_PER_S
from recorder.ball import BALL_COLOURS, BALL_PATTERNS, ball_look
from recorder.errors import RecorderError, UnknownScenarioError
from recorder.field import field_spec
from recorder.omni import DEFAULT_FACE_PX
from recorder.scenarios import (
    MAX_LIGHT_POOLS,
    MAX_PEOPLE,
    SCENARIOS,
    Scenario,
    make_scenario,
    scenario_from_path,
)
from recorder.simulation import CAMERA_PHASES, Plan, Simulation
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
MAX_SEED = 2**63 - 1
MAX_DURATION_S = 3600.0
"""The longest recording [sim s], a match with its breaks; a longer run is several logs."""
MAX_FRAMES = 72_000
"""The most camera frames a recording takes: an hour at a match's 20 Hz."""
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

    Match play and less-than-ideal cameras (every one off unless set; see
    :mod:`recorder.effects`): ``pose_rate_hz`` (poses, /tf and truth per second, a whole
    multiple of the camera rate; default twice it, a match's 240), ``camera_phase`` "sync" or
    "random" (default random for match, sync elsewhere), ``pose_bias_m`` / ``yaw_bias_deg``
    (a drifting localisation bias with time constant ``pose_bias_tau_s``), ``exposure_ms``,
    ``image_noise`` [grey levels], ``gain_jitter``, ``distractors`` (orange boxes beside the
    field, match only) and ``ball_odometry`` (the ball's true velocity on
    /ground_truth/ball/odometry; default on for match).

    The venue's trouble (:mod:`recorder.ball`, :mod:`recorder.scenery`; the defaults are
    the ball and world of every earlier log): ``ball_colour`` and ``ball_pattern``,
    ``people`` in the ball's colour beside the field, ``covers`` (robots dressed in it),
    ``light_pools``; and ``lob_fraction``, the share of a match's kicks that are lobs.
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
    """True a bar, False none, None plain lines (:func:`dsp.progress.progress_bar`)."""
    pose_rate_hz: float | None = None
    camera_phase: str | None = None
    pose_bias_m: float = 0.0
    yaw_bias_deg: float = 0.0
    pose_bias_tau_s: float = 5.0
    exposure_ms: float = 0.0
    image_noise: float = 0.0
    gain_jitter: float = 0.0
    distractors: int = 0
    ball_odometry: bool | None = None
    ball_colour: str = "orange"
    ball_pattern: str = "plain"
    people: int = 0
    covers: int = 0
    light_pools: int = 0
    lob_fraction: float = 0.0

    def __post_init__(self) -> None:
        self._check_recording()
        self._check_effects()
        self._check_venue()

    def _check_venue(self) -> None:
        if self.ball_colour not in BALL_COLOURS:
            raise UsageError(f"--ball-colour {self.ball_colour!r}: choose one of "
                             f"{', '.join(BALL_COLOURS)}")
        if self.ball_pattern not in BALL_PATTERNS:
            raise UsageError(f"--ball-pattern {self.ball_pattern!r}: choose one of "
                             f"{', '.join(BALL_PATTERNS)}")
        check_int("--people", self.people, low=0, high=MAX_PEOPLE)
        check_int("--covers", self.covers, low=0, high=16)
        check_int("--light-pools", self.light_pools, low=0, high=MAX_LIGHT_POOLS)
        check_number("--lob-fraction", self.lob_fraction, low=0, high=1)

    def with_realism(self, r: Realism) -> RecordOptions:
        """These options with the effects of a preset (:mod:`dsp.realism`), as given:
        :meth:`dsp.realism.Realism.for_scenario` first for a scenario without match play."""
        return dataclasses.replace(
            self, pose_bias_m=r.pose_bias_m, yaw_bias_deg=r.yaw_bias_deg,
            pose_bias_tau_s=r.pose_bias_tau_s, pose_noise_m=r.pose_noise_m,
            yaw_noise_deg=r.yaw_noise_deg, exposure_ms=r.exposure_ms, image_noise=r.image_noise,
            gain_jitter=r.gain_jitter, distractors=r.distractors)

    def _check_effects(self) -> None:
        if self.camera_phase not in (None, *CAMERA_PHASES):
            raise UsageError(f"unknown camera phase {self.camera_phase!r}; choose "
                             f"{' or '.join(CAMERA_PHASES)}")
        check_number("--pose-rate", self.pose_rate_hz, low=MIN_RATE_HZ, high=PHYSICS_HZ, unit="Hz")
        for flag, value, high, unit in (
                ("--pose-bias", self.pose_bias_m, MAX_POSE_NOISE_M, "m"),
                ("--yaw-bias", self.yaw_bias_deg, 180.0, "deg"),
                ("--exposure", self.exposure_ms, 100.0, "ms"),
                ("--image-noise", self.image_noise, 255.0, "grey levels"),
                ("--gain-jitter", self.gain_jitter, 5.0, "")):
            check_number(flag, value, low=0, high=high, unit=unit)
        check_number("--pose-bias-tau", self.pose_bias_tau_s, low=0, high=1e6, low_open=True)

    def _check_recording(self) -> None:
        if self.camera not in CAMERA_MODELS:
            raise UsageError(
                f"unknown camera {self.camera!r}; choose one of {', '.join(CAMERA_MODELS)}")
        if self.image_format not in IMAGE_FORMATS:
            raise UsageError(f"unknown image format {self.image_format!r}; choose png or jpeg")
        check_int("--seed", self.seed, low=0, high=MAX_SEED)
        check_int("--jpeg-quality", self.jpeg_quality, low=1, high=100)
        check_number("--pose-noise", self.pose_noise_m, low=0, high=MAX_POSE_NOISE_M, unit="m")
        check_number("--yaw-noise", self.yaw_noise_deg, low=0, high=180, unit="deg")
        check_int("--face-px", self.face_px, low=checks.MIN_FACE_PX, high=MAX_FACE_PX)
        field_spec(self.field)
        if self.renderer not in c.RENDERERS:
            raise UsageError(
                f"unknown renderer {self.renderer!r}; choose one of {', '.join(c.RENDERERS)}")
        if self.frames is not None and self.duration_s is not None:
            raise UsageError("give --frames or --duration, not both")
        check_int("--frames", self.frames, low=1, high=MAX_FRAMES)
        check_number("--duration", self.duration_s, low=0, high=MAX_DURATION_S, low_open=True,
                     unit="s")
        check_number("--rate", self.rate_hz, low=MIN_RATE_HZ, high=MAX_RATE_HZ, unit="Hz")
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


def _plan(path: Path, options: RecordOptions) -> Plan:
    """The scenario, rates, frame count and camera phases; refuses a missing folder or an
    existing log."""
    check_suffix("output", path, (".mcap",))  # first: "/" is a folder, not a scenario name
    name = _resolve_scenario(path, options.scenario)
    sc = make_scenario(name, options.seed, robots=options.robots, field=options.field,
                       distractors=options.distractors, lob_fraction=options.lob_fraction,
                       people=options.people, covers=options.covers,
                       light_pools=options.light_pools)
    rate = sc.default_rate_hz if options.rate_hz is None else options.rate_hz
    duration = sc.default_duration_s if options.duration_s is None else options.duration_s
    frames = options.frames if options.frames is not None else max(1, round(duration * rate))
    if frames / rate > MAX_DURATION_S:
        raise UsageError(f"--frames {frames} at {rate:g} Hz is {frames / rate:g} s of simulated "
                         f"time; record at most {MAX_DURATION_S:g} s")
    if frames > MAX_FRAMES:
        raise UsageError(f"{frames / rate:g} s at {rate:g} Hz is {frames} frames; record at "
                         f"most {MAX_FRAMES} (a longer run is several logs)")
    pose_rate = options.pose_rate_hz or sc.default_pose_rate_hz
    if pose_rate is None:  # twice the camera rate, as the logs before match play
        tick_ns, per_frame = max(1, round(NS_PER_S / rate / 2)), 2
    else:
        per_frame = round(pose_rate / rate)
        if per_frame < 1 or abs(per_frame * rate - pose_rate) > 1e-6 * pose_rate:
            raise UsageError(f"the pose rate {pose_rate:g} Hz must be a whole multiple of the "
                             f"camera rate {rate:g} Hz")
        tick_ns = max(1, round(NS_PER_S / pose_rate))
    robots = [tr.name for tr in sc.robots]
    phase = options.camera_phase or ("random" if sc.play is not None else "sync")
    phases = dict.fromkeys(robots, 0)
    if phase == "random":
        if per_frame < len(robots):
            raise UsageError(f"random camera phases need at least {len(robots)} pose ticks "
                             f"per frame; raise --pose-rate to {len(robots) * rate:g} Hz or more")
        rng = np.random.default_rng([options.seed, 4])
        draw = rng.choice(per_frame, size=len(robots), replace=False)
        phases = {r: int(k) for r, k in zip(robots, draw, strict=True)}
    check_suffix("output", path, (".mcap",))
    check_output_path(path, force=options.force)
    return Plan(sc, rate, frames, tick_ns, per_frame, phases)


def _extended(plan: Plan, options: RecordOptions) -> bool:
    """True when the recording uses anything the logs before match play did not have (then
    the metadata states every new parameter; otherwise it stays as it was)."""
    return (plan.scenario.play is not None or options.pose_rate_hz is not None
            or any(plan.phase_ticks.values()) or options.camera_phase is not None
            or bool(options.ball_odometry) or any((
                options.pose_bias_m, options.yaw_bias_deg, options.exposure_ms,
                options.image_noise, options.gain_jitter)))


def _recording(plan: Plan, options: RecordOptions) -> meta.RecordingMetadata:
    """How the scenario is recorded; the match-play parameters only when used."""
    rec = meta.RecordingMetadata(
        rate_hz=plan.rate_hz, pose_rate_hz=plan.pose_rate_hz, frames=plan.frames,
        camera=options.camera, image_format=options.image_format,
        pose_noise_m=options.pose_noise_m, yaw_noise_deg=options.yaw_noise_deg,
        face_px=options.face_px, physics_hz=PHYSICS_HZ,
        ball_colour=options.ball_colour, ball_pattern=options.ball_pattern,
        people=options.people, covers=options.covers, light_pools=options.light_pools,
        lob_fraction=1.0 if plan.scenario.name == "lobs" else options.lob_fraction,
    )
    if not _extended(plan, options):
        return rec
    return dataclasses.replace(
        rec, camera_phase="random" if any(plan.phase_ticks.values()) else "sync",
        camera_offsets_ns=plan.phase_ns(), pose_bias_m=options.pose_bias_m,
        yaw_bias_deg=options.yaw_bias_deg, pose_bias_tau_s=options.pose_bias_tau_s,
        exposure_ms=options.exposure_ms, image_noise=options.image_noise,
        gain_jitter=options.gain_jitter, ball_odometry=_ball_odometry(plan, options))


def _ball_odometry(plan: Plan, options: RecordOptions) -> bool:
    if options.ball_odometry is not None:
        return options.ball_odometry
    return plan.scenario.play is not None


def log_metadata(
    sc: Scenario, options: RecordOptions, *, rate_hz: float, frames: int, renderer: str,
    camera: CameraModel, plan: Plan | None = None,
) -> tuple[meta.ScenarioMetadata, meta.CamerasMetadata, meta.RecorderMetadata]:
    """The log's metadata records: the scenario (with how it is recorded), each robot's
    camera model and the recorder (renderer, physics, package versions). ``plan``: the
    resolved timing (default: poses at twice ``rate_hz``, cameras in sync)."""
    if plan is None:
        plan = Plan(sc, rate_hz, frames, max(1, round(NS_PER_S / rate_hz / 2)), 2,
                    {tr.name: 0 for tr in sc.robots})
    scene = sc.params()
    field_name = scene.pop("field")
    recording = _recording(plan, options)
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
    scenery = plan.scenario.scenery
    with World(field_spec(options.field), renderer=options.renderer,
               ball=ball_look(options.ball_colour, options.ball_pattern),
               light=scenery.light_pools if scenery is not None else ()) as world:
        sim = Simulation(world, plan, options, camera,
                         ball_odometry=_ball_odometry(plan, options))
        scenario, cameras, recorder = log_metadata(
            plan.scenario, options, rate_hz=plan.rate_hz, frames=plan.frames,
            renderer=world.renderer, camera=camera, plan=plan)

        def fill(writer: LogWriter) -> None:
            writer.metadata(c.SCENARIO_METADATA, scenario.to_metadata())
            writer.metadata(c.CAMERAS_METADATA, cameras.to_metadata())
            writer.metadata(c.RECORDER_METADATA, recorder.to_metadata())
            writer.flush()  # the metadata reach the disk before the first frame
            with progress_bar(plan.frames * len(plan.scenario.robots), path.name,
                              options.progress, unit="image") as bar:
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
        sim_duration_ns=plan.sim_duration_ns,
        messages=messages,
        file_size_bytes=path.stat().st_size,
        renderer=used_renderer,
        wall_time_s=time.perf_counter() - t_wall,
    )
