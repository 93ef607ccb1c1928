"""Record a scenario to a log: the one typed function the CLI (and others) call.

Timeline (integer sim nanoseconds from 0): camera frames every ``T = 1 / rate`` and poses,
``/tf`` and ground truth every ``T / 2`` (twice the camera rate, so replay can interpolate
a pose at any image stamp). Physics steps at 240 Hz in between. Images are rendered from
each robot's true pose; ``/robotN/pose`` and ``/tf`` carry what the robot believes (the
truth plus optional Gaussian noise); ``/ground_truth/...`` carry the truth.

The log is written to a hidden temporary name in the output's folder and renamed when done.
On Ctrl-C the MCAP is finished (so it is readable), kept as ``<name>.partial.mcap`` and
``RecordingInterrupted`` says where.
"""

from __future__ import annotations

import contextlib
import os
import platform
import time
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from dsp import contract as c
from estimator.camera import CAMERA_MODELS, make_camera
from recorder.errors import OutputExistsError, RecorderError, UnknownScenarioError, UsageError
from recorder.omni import DEFAULT_FACE_PX, OmniRenderer
from recorder.scenarios import SCENARIOS, Scenario, make_scenario, scenario_from_path
from recorder.world import PHYSICS_HZ, World, field_spec
from recorder.writer import LogWriter

__all__ = ["IMAGE_FORMATS", "RecordSummary", "RecordingInterrupted", "record"]

IMAGE_FORMATS = ("png", "jpeg")
_NS = 1_000_000_000


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


def _frame_count(sc: Scenario, rate_hz: float, duration_s: float | None,
                 frames: int | None) -> int:
    if frames is not None and duration_s is not None:
        raise UsageError("give --frames or --duration, not both")
    if frames is not None:
        if frames < 1:
            raise UsageError(f"--frames must be >= 1, got {frames}")
        return frames
    dur = sc.default_duration_s if duration_s is None else duration_s
    if not dur > 0:
        raise UsageError(f"--duration must be > 0 s, got {dur}")
    return max(1, round(dur * rate_hz))


def _encode(img: np.ndarray, fmt: str, jpeg_quality: int) -> bytes:
    if fmt == "png":
        ok, buf = cv2.imencode(".png", img, [cv2.IMWRITE_PNG_COMPRESSION, 3])
    else:
        ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, jpeg_quality])
    if not ok:  # pragma: no cover - OpenCV failure
        raise RecorderError(f"OpenCV could not encode a {fmt} image")
    return buf.tobytes()


def record(
    path: str | Path,
    *,
    scenario: str | None = None,
    seed: int = 0,
    duration_s: float | None = None,
    frames: int | None = None,
    rate_hz: float | None = None,
    camera: str = "ideal",
    image_format: str = "png",
    jpeg_quality: int = 90,
    pose_noise_m: float = 0.0,
    yaw_noise_deg: float = 0.0,
    robots: int | None = None,
    field: str = "18x12",
    face_px: int = DEFAULT_FACE_PX,
    renderer: str = "auto",
    force: bool = False,
    progress: bool = False,
) -> RecordSummary:
    """Record ``scenario`` (or the one the file name names) to the MCAP log ``path``.

    ``duration_s`` or ``frames`` (default: the scenario's, 1 s for static scenes) at
    ``rate_hz`` camera frames per second (default: the scenario's, 5 Hz for static scenes).
    ``pose_noise_m`` / ``yaw_noise_deg``: standard deviations of the believed pose's noise.
    ``renderer``: "auto" (EGL if it loads, else TinyRenderer; env DSP_RENDERER overrides),
    "egl" or "tiny". Raises ``RecorderError`` subclasses for every known failure.
    """
    t_wall = time.perf_counter()
    path = Path(path)
    name = _resolve_scenario(path, scenario)
    if camera not in CAMERA_MODELS:
        raise UsageError(f"unknown camera {camera!r}; choose one of {', '.join(CAMERA_MODELS)}")
    if image_format not in IMAGE_FORMATS:
        raise UsageError(f"unknown image format {image_format!r}; choose png or jpeg")
    if not 1 <= jpeg_quality <= 100:
        raise UsageError(f"JPEG quality must be 1..100, got {jpeg_quality}")
    if pose_noise_m < 0 or yaw_noise_deg < 0:
        raise UsageError("pose noise must be >= 0")
    if face_px < 256:
        raise UsageError(f"--face-px must be >= 256 (smaller loses far balls), got {face_px}")
    sc = make_scenario(name, seed, robots=robots, field=field)
    rate = sc.default_rate_hz if rate_hz is None else rate_hz
    if not 0 < rate <= 1000:
        raise UsageError(f"--rate must be in (0, 1000] Hz, got {rate}")
    n_frames = _frame_count(sc, rate, duration_s, frames)
    if not path.parent.is_dir():
        raise UsageError(f"folder {str(path.parent)!r} does not exist; create it first")
    if path.exists() and not force:
        raise OutputExistsError(f"{path} exists; pass --force to overwrite it")

    pose_period_ns = max(1, round(_NS / rate / 2))  # poses at twice the camera rate
    cam_model = make_camera(camera)
    noise_rng = np.random.default_rng([seed, 1])
    yaw_sigma = np.deg2rad(yaw_noise_deg)

    tmp = path.with_name(f".{path.name}.tmp")
    with World(field_spec(field), renderer=renderer) as world:
        for tr in (*sc.robots, *sc.opponents):
            world.add_robot(tr.name, opponent=tr.opponent)
            world.set_robot_pose(tr.name, *tr.pose_at(0.0))
        world.set_ball(*sc.ball_xy_m, *sc.ball_velocity_mps)
        moving = [tr for tr in (*sc.robots, *sc.opponents) if tr.moving]
        omni = OmniRenderer(cam_model, face_px=face_px, renderer=world.renderer)

        frames_done = 0
        steps_done = 0
        stream = open(tmp, "wb")
        try:
            writer = LogWriter(stream)
            params = sc.params()
            params["recording"] = {
                "rate_hz": rate, "pose_rate_hz": 2 * rate, "frames": n_frames,
                "camera": camera, "image_format": image_format,
                "pose_noise_m": pose_noise_m, "yaw_noise_deg": yaw_noise_deg,
                "face_px": face_px, "physics_hz": PHYSICS_HZ,
            }
            writer.metadata(c.SCENARIO_METADATA, {
                "name": name, "seed": str(seed), "params": c.json_text(params)})
            writer.metadata(c.CAMERAS_METADATA, {
                tr.name: c.json_text(cam_model.to_dict()) for tr in sc.robots})
            writer.metadata(c.RECORDER_METADATA, {
                "renderer": world.renderer,
                "dual_sight": _version("dual-sight"),
                "pybullet": _version("pybullet"),
                "numpy": _version("numpy"),
                "opencv": cv2.__version__,
                "mcap": _version("mcap"),
                "mcap_ros2": _version("mcap-ros2-support"),
                "python": platform.python_version(),
                "physics_hz": str(PHYSICS_HZ),
                "face_px": str(face_px),
            })
            bar = tqdm(total=n_frames, unit="frame", disable=not progress, leave=False,
                       desc=path.name)
            try:
                for k in range(2 * n_frames):
                    t_ns = k * pose_period_ns
                    target = (t_ns * PHYSICS_HZ + _NS // 2) // _NS
                    while steps_done < target:
                        steps_done += 1
                        for tr in moving:
                            world.set_robot_pose(tr.name, *tr.pose_at(steps_done / PHYSICS_HZ))
                        world.step()
                    t_s = t_ns / _NS
                    truth = {tr.name: tr.pose_at(t_s) for tr in sc.robots}
                    believed = {}
                    for robot, (x, y, yaw) in truth.items():
                        dx, dy = noise_rng.normal(0.0, 1.0, 2) * pose_noise_m
                        dyaw = float(noise_rng.normal(0.0, 1.0)) * yaw_sigma
                        yaw_b = float(np.arctan2(np.sin(yaw + dyaw), np.cos(yaw + dyaw)))
                        believed[robot] = (x + float(dx), y + float(dy), yaw_b)
                    for robot, (x, y, yaw) in truth.items():
                        writer.write_pose(c.topic_for(c.GT_POSE_TOPIC, robot), t_ns, x, y, 0.0,
                                          yaw)
                    for robot, (x, y, yaw) in believed.items():
                        writer.write_pose(c.topic_for(c.POSE_TOPIC, robot), t_ns, x, y, 0.0,
                                          yaw)
                    writer.write_tf(t_ns, believed)
                    bx, by, bz = world.ball_position()
                    writer.write_pose(c.GT_BALL_TOPIC, t_ns, bx, by, bz, 0.0)
                    if k % 2 == 0:
                        for robot, (x, y, yaw) in truth.items():
                            img = omni.render(world, robot, x, y, yaw)
                            writer.write_image(robot, t_ns,
                                               _encode(img, image_format, jpeg_quality),
                                               image_format)
                        frames_done += 1
                        bar.update(1)
            except KeyboardInterrupt:
                bar.close()
                writer.finish()
                stream.close()
                partial = path.with_name(
                    (path.name[:-5] if path.name.endswith(".mcap") else path.name)
                    + ".partial.mcap"
                )
                os.replace(tmp, partial)
                raise RecordingInterrupted(partial, frames_done) from None
            bar.close()
            writer.finish()
            messages = writer.messages
            stream.close()
            os.replace(tmp, path)
        finally:
            if not stream.closed:
                stream.close()
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
        used_renderer = world.renderer

    return RecordSummary(
        path=path,
        scenario=name,
        seed=seed,
        frames=n_frames,
        robots=len(sc.robots),
        camera=camera,
        image_format=image_format,
        rate_hz=rate,
        sim_duration_ns=(2 * n_frames - 1) * pose_period_ns,
        messages=messages,
        file_size_bytes=path.stat().st_size,
        renderer=used_renderer,
        wall_time_s=time.perf_counter() - t_wall,
    )
