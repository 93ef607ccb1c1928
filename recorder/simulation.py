"""The frame loop: steps the world, kicks the ball and writes poses, /tf, truth and images.

Time runs in pose ticks of ``tick_ns`` (integer sim nanoseconds from 0). Every tick writes
each robot's true and believed pose, ``/tf`` and the ball's truth (and, when asked, its
odometry with the true velocity). Each robot's camera is free-running: it takes an image
every ``ticks_per_frame`` ticks, starting at its own phase (a whole number of ticks), so
with random phases no two robots' images share a stamp; with ``sync`` phases all are 0.
Physics steps at 240 Hz in between; images are rendered from each robot's true pose at the
physics step nearest the stamp (a match's ticks *are* physics steps, so the two coincide).

What a robot believes is the truth plus a slowly drifting bias (:class:`PoseDrift`) plus
white noise; images may get exposure blur, gain changes and noise (:mod:`recorder.effects`).
A lob is launched into the air and flown by :class:`recorder.flight.Flight`; people and robot
covers are set up from the scenario's scenery (:mod:`recorder.scenery`).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from dsp import contract as c
from estimator.camera import CameraModel
from estimator.constants import NS_PER_S
from recorder.effects import ImageEffects, PoseDrift
from recorder.errors import RecorderError
from recorder.flight import Flight
from recorder.match import Kick, LobKick
from recorder.omni import OmniRenderer
from recorder.scenarios import Scenario
from recorder.world import PHYSICS_HZ, World
from recorder.writer import LogWriter

__all__ = ["CAMERA_PHASES", "Plan", "Simulation", "encode_image"]

CAMERA_PHASES = ("sync", "random")


@dataclass(frozen=True)
class Plan:
    """Options resolved against the scenario: what the frame loop runs."""

    scenario: Scenario
    rate_hz: float
    frames: int
    """Images per robot."""
    tick_ns: int
    """Period of poses, /tf and truth [ns]."""
    ticks_per_frame: int
    """A camera's period in ticks."""
    phase_ticks: dict[str, int]
    """Robot -> the tick of its first image (0 for all when the cameras are in sync)."""

    @property
    def pose_rate_hz(self) -> float:
        return self.rate_hz * self.ticks_per_frame

    @property
    def ticks(self) -> int:
        return self.frames * self.ticks_per_frame

    @property
    def sim_duration_ns(self) -> int:
        """Stamp of the last message."""
        return (self.ticks - 1) * self.tick_ns

    def phase_ns(self) -> dict[str, int]:
        return {robot: k * self.tick_ns for robot, k in self.phase_ticks.items()}


def encode_image(img: np.ndarray, fmt: str, jpeg_quality: int) -> bytes:
    if fmt == "png":
        ok, buf = cv2.imencode(".png", img, [cv2.IMWRITE_PNG_COMPRESSION, 3])
    else:
        ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, jpeg_quality])
    if not ok:  # pragma: no cover - OpenCV failure
        raise RecorderError(f"OpenCV could not encode a {fmt} image")
    return buf.tobytes()


def _step_of(t_ns: int) -> int:
    """The physics step nearest ``t_ns``."""
    return (t_ns * PHYSICS_HZ + NS_PER_S // 2) // NS_PER_S


class Simulation:
    """The world set up for a scenario, stepped tick by tick into a log writer.

    ``options`` is a :class:`recorder.record.RecordOptions` (image format, noise, effects).
    """

    def __init__(self, world: World, plan: Plan, options: Any, camera: CameraModel,
                 *, ball_odometry: bool = False) -> None:
        self.world = world
        self.plan = plan
        self.options = options
        self.ball_odometry = ball_odometry
        sc = plan.scenario
        for tr in (*sc.robots, *sc.opponents):
            world.add_robot(tr.name, opponent=tr.opponent)
            world.set_robot_pose(tr.name, *tr.pose_at(0.0))
        if sc.play is not None:
            if sc.play.walls and sc.flight is not None:
                world.add_walls(sc.flight.wall_height_m, hidden=True)
            elif sc.play.walls:
                world.add_walls()
            for d in sc.play.distractors:
                world.add_distractor(d.x_m, d.y_m, d.size_m, d.yaw_rad)
        if sc.scenery is not None:
            for person in sc.scenery.people:
                world.add_person(person)
            for name in sc.scenery.covers:
                world.add_cover(name)
        self.flight = Flight(world, sc.flight) if sc.flight is not None else None
        world.set_ball(*sc.ball_xy_m, *sc.ball_velocity_mps)
        self.kicks: list[Kick] = list(sc.play.kicks) if sc.play is not None else []
        self.moving = [tr for tr in (*sc.robots, *sc.opponents) if tr.moving]
        self.omni = OmniRenderer(camera, face_px=options.face_px, renderer=world.renderer)
        self.noise_rng = np.random.default_rng([options.seed, 1])
        robots = [tr.name for tr in sc.robots]
        self.drift = PoseDrift(robots, options.seed, pose_bias_m=options.pose_bias_m,
                               yaw_bias_deg=options.yaw_bias_deg,
                               tau_s=options.pose_bias_tau_s, dt_s=plan.tick_ns / NS_PER_S)
        self.effects = ImageEffects(robots, options.seed, image_noise=options.image_noise,
                                    gain_jitter=options.gain_jitter,
                                    exposure_steps=round(options.exposure_ms * PHYSICS_HZ / 1000),
                                    frame_dt_s=1.0 / plan.rate_hz)
        self.steps_done = 0
        self.images_done = 0
        self._due: dict[str, deque[int]] = {}
        if self.effects.exposure_steps:
            for robot in robots:
                ticks = range(plan.phase_ticks[robot], plan.ticks, plan.ticks_per_frame)
                self._due[robot] = deque(_step_of(k * plan.tick_ns) for k in ticks)
        self._apply_kicks()

    @property
    def frames_done(self) -> int:
        """Whole frames (an image from every robot) written."""
        return self.images_done // max(1, len(self.plan.scenario.robots))

    def _takes_image(self, robot: str, tick: int) -> bool:
        k = tick - self.plan.phase_ticks[robot]
        return k >= 0 and k % self.plan.ticks_per_frame == 0

    def run(self, writer: LogWriter, bar: Any) -> None:
        """Every tick: poses and truth, then the images of the robots whose camera fires."""
        plan = self.plan
        truth_of = {tr.name: tr for tr in plan.scenario.robots}
        for k in range(plan.ticks):
            t_ns = k * plan.tick_ns
            self._advance_to(t_ns)
            truth = {name: tr.pose_at(t_ns / NS_PER_S) for name, tr in truth_of.items()}
            self._write_poses(writer, t_ns, truth)
            for robot, (x, y, yaw) in truth.items():
                if not self._takes_image(robot, k):
                    continue
                self.world.relight()  # uneven light: the ball and covers lit where they are
                img = self.effects.finish(robot, self.omni.render(self.world, robot, x, y, yaw))
                fmt = self.options.image_format
                writer.write_image(robot, t_ns,
                                   encode_image(img, fmt, self.options.jpeg_quality), fmt)
                self.images_done += 1
                bar.update(1)

    def _apply_kicks(self) -> None:
        """Strike the ball for every kick due by the current physics step."""
        now_s = self.steps_done / PHYSICS_HZ
        while self.kicks and self.kicks[0].t_s <= now_s + 1e-9:
            if self.flight is not None and self.flight.airborne():
                return  # in the air: the kick waits until the ball is down
            kick = self.kicks.pop(0)
            bx, by, _ = self.world.ball_position()
            if kick.target_robot is not None:
                track = next(tr for tr in self.plan.scenario.robots
                             if tr.name == kick.target_robot)
                tx, ty, _ = track.pose_at(now_s)
            else:
                assert kick.target_xy_m is not None
                tx, ty = kick.target_xy_m
            dx, dy = tx - bx, ty - by
            if math.hypot(dx, dy) < 0.3:  # at the target already: play it to the centre
                dx, dy = -bx or 1.0, -by
            if isinstance(kick, LobKick) and self.flight is not None:
                self.flight.launch(kick, dx, dy)
                continue
            n = math.hypot(dx, dy)
            self.world.kick_ball(kick.speed_mps * dx / n, kick.speed_mps * dy / n)

    def _exposures(self) -> None:
        """Render the blur sub-frames due at the current step: an image stamped at step
        ``s`` is exposed over steps ``s - n .. s`` (the stamp marks the exposure's end)."""
        n = self.effects.exposure_steps
        for tr in self.plan.scenario.robots:
            dues = self._due.get(tr.name)
            while dues and dues[0] <= self.steps_done:
                dues.popleft()
            if dues and dues[0] - n <= self.steps_done:
                x, y, yaw = tr.pose_at(self.steps_done / PHYSICS_HZ)
                self.world.relight()
                self.effects.add_subframe(tr.name,
                                          self.omni.render(self.world, tr.name, x, y, yaw))

    def _advance_to(self, t_ns: int) -> None:
        """Physics steps (moving the kinematic robots, kicking the ball) up to the one
        nearest ``t_ns``."""
        target = _step_of(t_ns)
        while self.steps_done < target:
            if self._due:
                self._exposures()
            self.steps_done += 1
            for tr in self.moving:
                self.world.set_robot_pose(tr.name, *tr.pose_at(self.steps_done / PHYSICS_HZ))
            self.world.step()
            if self.flight is not None:
                self.flight.step()
            self._apply_kicks()

    def _believed(self, truth: dict[str, tuple[float, float, float]]
                  ) -> dict[str, tuple[float, float, float]]:
        """The truth plus the drifting bias and the options' Gaussian noise (yaw wrapped to
        (-pi, pi])."""
        yaw_sigma = np.deg2rad(self.options.yaw_noise_deg)
        bias = self.drift.step()
        believed = {}
        for robot, (x, y, yaw) in truth.items():
            dx, dy = self.noise_rng.normal(0.0, 1.0, 2) * self.options.pose_noise_m
            dyaw = float(self.noise_rng.normal(0.0, 1.0)) * yaw_sigma
            bx, by = x + float(dx), y + float(dy)
            if robot in bias:  # a drifting bias only when asked (else the bytes of old logs)
                ex, ey, eyaw = bias[robot]
                bx, by, dyaw = bx + ex, by + ey, dyaw + eyaw
            yaw_b = float(np.arctan2(np.sin(yaw + dyaw), np.cos(yaw + dyaw)))
            believed[robot] = (bx, by, yaw_b)
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
        if self.ball_odometry:
            vx, vy, vz = self.world.ball_velocity()
            writer.write_odometry(c.GT_BALL_ODOMETRY_TOPIC, t_ns, "ball", bx, by, bz,
                                  vx, vy, vz)
