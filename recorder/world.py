"""The simulated RoboCup MSL world in pybullet: field, goals, ball, robots.

DIRECT mode, fixed time step, no randomness of its own (scenarios are seeded elsewhere), so
the same inputs step to the same states. Robots are kinematic (mass 0, posed every step);
the ball is a real rigid body that rolls and bounces off them. What the ball looks like,
people beside the field, robot covers and uneven light are the dressing
(:mod:`recorder.dressing`; off unless asked, and then the world is built as before).
"""

from __future__ import annotations

import importlib.util
import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import cv2
import numpy as np

from dsp.contract import RENDERERS
from dsp.errors import UsageError
from recorder import dressing
from recorder.ball import BallLook, ball_look
from recorder.errors import RendererError
from recorder.field import FIELDS, FieldSpec, field_spec, field_texture
from recorder.flight import GROUND_DAMPING
from recorder.scenery import LightPool, Person
from recorder.silence import silenced

with silenced():
    import pybullet as p


__all__ = [
    "BALL_MASS_KG",
    "BALL_RADIUS_M",
    "BALL_RGB",
    "FIELDS",
    "PHYSICS_HZ",
    "ROBOT_HEIGHT_M",
    "ROBOT_SIZE_M",
    "FieldSpec",
    "World",
    "field_spec",
]

PHYSICS_HZ = 240
"""Physics steps per second (fixed time step 1/240 s)."""
BALL_RADIUS_M = 0.11
BALL_MASS_KG = 0.41
BALL_RGB = (255, 110, 0)
"""Strong orange, so a colour threshold finds it (the default look's colour)."""
BALL_DAMPING = GROUND_DAMPING
"""The ball's linear damping d: pybullet's multibody slows it by d (1 + |v|) v [m/s^2]."""
ROBOT_SIZE_M = 0.49
"""Footprint side of a robot (square)."""
ROBOT_HEIGHT_M = 0.80
ROBOT_RGB = (22, 22, 22)
TEAM_BAND_RGB = (0, 170, 220)
"""Cyan band on our robots (MSL team marker)."""
OPPONENT_BAND_RGB = (200, 0, 160)
"""Magenta band on opponents."""
FLOOR_RGB = (95, 95, 100)


def _rgba(rgb: tuple[int, int, int]) -> list[float]:
    return [rgb[0] / 255.0, rgb[1] / 255.0, rgb[2] / 255.0, 1.0]


_FAR_M = 1e3
"""A point far from every light pool: where the base light alone shines (the hall floor)."""


class World:
    """One pybullet DIRECT client holding the field, goals, ball and robots.

    ``renderer`` is "auto" (EGL if its plugin loads, else TinyRenderer), "egl" or "tiny";
    the environment variable ``DSP_RENDERER`` overrides "auto". ``self.renderer`` says
    which one is in use. ``ball``: the ball's look (default plain orange); ``light``: the
    light pools (default none: the even light).
    """

    def __init__(self, field: FieldSpec, *, renderer: str = "auto",
                 ball: BallLook | None = None, light: tuple[LightPool, ...] = ()) -> None:
        self.field = field
        self.look = ball_look() if ball is None else ball
        self.light = light
        self._covers: dict[str, int] = {}
        self._lights = dressing.Lights(light)
        with silenced():
            self._client = p.connect(p.DIRECT)
        self._plugin = -1
        self._tmp = tempfile.TemporaryDirectory(prefix="dsp-world-")
        try:
            self.renderer = self._setup_renderer(renderer)
            self._build()
        except BaseException:
            self.close()
            raise
        self._robots: dict[str, int] = {}

    # --- setup -------------------------------------------------------------------------------
    def _setup_renderer(self, renderer: str) -> str:
        if renderer == "auto":
            renderer = os.environ.get("DSP_RENDERER", "auto").strip().lower() or "auto"
        if renderer not in RENDERERS:
            raise UsageError(f"unknown renderer {renderer!r}; choose one of {', '.join(RENDERERS)}")
        if renderer == "tiny":
            return "tiny"
        spec = importlib.util.find_spec("eglRenderer")
        plugin = -1
        if spec is not None and spec.origin:
            try:
                with silenced():
                    plugin = p.loadPlugin(
                        spec.origin,
                        "_eglRendererPlugin",
                        physicsClientId=self._client,
                    )
            except Exception:
                plugin = -1
        if plugin < 0:
            if renderer == "egl":
                raise RendererError(
                    "the EGL renderer plugin did not load; install Mesa EGL or use "
                    "--renderer tiny"
                )
            return "tiny"
        self._plugin = plugin
        return "egl"

    @property
    def render_mode(self) -> int:
        return int(p.ER_BULLET_HARDWARE_OPENGL if self.renderer == "egl" else p.ER_TINY_RENDERER)

    def _build(self) -> None:
        c = self._client
        p.setGravity(0, 0, -9.81, physicsClientId=c)
        p.setPhysicsEngineParameter(
            fixedTimeStep=1.0 / PHYSICS_HZ,
            numSolverIterations=50,
            deterministicOverlappingPairs=1,
            physicsClientId=c,
        )
        spec = self.field
        full_l = spec.length_m + 2 * spec.border_m
        full_w = spec.width_m + 2 * spec.border_m
        # carpet: a textured quad (OBJ with UVs; both renderers load it)
        tex_path = Path(self._tmp.name) / "field.png"
        carpet = field_texture(spec)
        if self.light:
            carpet = dressing.light_texture(carpet, self.light, full_l, full_w)
        cv2.imwrite(str(tex_path), carpet)
        obj_path = Path(self._tmp.name) / "field.obj"
        hl, hw = full_l / 2, full_w / 2
        obj_path.write_text(
            f"v {-hl} {-hw} 0\nv {hl} {-hw} 0\nv {hl} {hw} 0\nv {-hl} {hw} 0\n"
            "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n"
            "f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n"
        )
        # the hall's floor around the carpet (a frame of four quads, grey, no texture)
        big = 60.0
        floor_path = Path(self._tmp.name) / "floor.obj"
        floor_path.write_text(
            f"v {-hl} {-hw} 0\nv {hl} {-hw} 0\nv {hl} {hw} 0\nv {-hl} {hw} 0\n"
            f"v {-big} {-big} 0\nv {big} {-big} 0\nv {big} {big} 0\nv {-big} {big} 0\n"
            "vn 0 0 1\n"
            "f 5//1 6//1 2//1\nf 5//1 2//1 1//1\nf 6//1 7//1 3//1\nf 6//1 3//1 2//1\n"
            "f 7//1 8//1 4//1\nf 7//1 4//1 3//1\nf 8//1 5//1 1//1\nf 8//1 1//1 4//1\n"
        )
        floor_vis = p.createVisualShape(p.GEOM_MESH, fileName=str(floor_path),
                                        rgbaColor=self._lit(FLOOR_RGB, _FAR_M, _FAR_M),
                                        specularColor=[0, 0, 0],
                                        physicsClientId=c)
        p.createMultiBody(0, -1, floor_vis, physicsClientId=c)
        ground_col = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=c)
        ground_vis = p.createVisualShape(p.GEOM_MESH, fileName=str(obj_path), physicsClientId=c)
        self.ground = p.createMultiBody(0, ground_col, ground_vis, physicsClientId=c)
        tex = p.loadTexture(str(tex_path), physicsClientId=c)
        p.changeVisualShape(self.ground, -1, textureUniqueId=tex, rgbaColor=[1, 1, 1, 1],
                            physicsClientId=c)
        p.changeDynamics(self.ground, -1, restitution=0.5, lateralFriction=0.6,
                         physicsClientId=c)
        for s in (-1.0, 1.0):
            self._add_goal(s)
        # the ball
        col = p.createCollisionShape(p.GEOM_SPHERE, radius=BALL_RADIUS_M, physicsClientId=c)
        # a finer sphere mesh than pybullet's own (whose facets move a near ball's blob
        # centroid by half a pixel), but not so fine that TinyRenderer drops its sub-pixel
        # triangles when the ball is only a few pixels wide
        folder = Path(self._tmp.name)
        vis = dressing.ball_visual(c, folder, self.look, BALL_RADIUS_M)
        self.ball = p.createMultiBody(BALL_MASS_KG, col, vis, [0, 0, BALL_RADIUS_M],
                                      physicsClientId=c)
        if self.look.textured:
            dressing.texture_ball(c, self.ball, folder, self.look, BALL_RADIUS_M)
        p.changeDynamics(self.ball, -1, restitution=0.6, lateralFriction=0.6,
                         rollingFriction=0.0005, spinningFriction=0.0005,
                         linearDamping=BALL_DAMPING, angularDamping=0.05, physicsClientId=c)

    def _add_goal(self, side: float) -> None:
        """A goal behind the line x = side * half length: white posts, crossbar, net frame."""
        c = self._client
        spec = self.field
        x0 = side * spec.half_length_m
        post, gw, gh, gd = 0.0625, spec.goal_half_width_m, spec.goal_height_m, spec.goal_depth_m
        white = (250, 250, 250)
        bar = 0.02  # the net's ground frame; the net itself is left out (see-through)
        parts = [  # (half extents, centre, colour)
            ((post, post, gh / 2), (x0 + side * post, gw + post, gh / 2), white),
            ((post, post, gh / 2), (x0 + side * post, -gw - post, gh / 2), white),
            ((post, gw + 2 * post, post), (x0 + side * post, 0.0, gh + post), white),
            ((bar, gw, bar), (x0 + side * gd, 0.0, bar), white),
            ((gd / 2, bar, bar), (x0 + side * gd / 2, gw, bar), white),
            ((gd / 2, bar, bar), (x0 + side * gd / 2, -gw, bar), white),
        ]
        for half, centre, rgb in parts:
            vis = p.createVisualShape(p.GEOM_BOX, halfExtents=half,
                                      rgbaColor=self._lit(rgb, centre[0], centre[1]),
                                      specularColor=[0, 0, 0], physicsClientId=c)
            col = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=c)
            p.createMultiBody(0, col, vis, centre, physicsClientId=c)

    def add_robot(self, name: str, *, opponent: bool = False) -> int:
        """A dark 0.49 x 0.49 x 0.8 m robot with a team band and a camera on top."""
        c = self._client
        h = ROBOT_SIZE_M / 2
        band = OPPONENT_BAND_RGB if opponent else TEAM_BAND_RGB
        vis = p.createVisualShapeArray(
            shapeTypes=[p.GEOM_BOX, p.GEOM_BOX, p.GEOM_BOX, p.GEOM_CYLINDER],
            halfExtents=[[h, h, ROBOT_HEIGHT_M / 2], [h + 0.005, h + 0.005, 0.04],
                         [0.03, 0.12, 0.03], [0, 0, 0]],
            radii=[0, 0, 0, 0.05],
            lengths=[0, 0, 0, 0.1],
            rgbaColors=[_rgba(ROBOT_RGB), _rgba(band), _rgba((90, 90, 90)),
                        _rgba((60, 60, 60))],
            visualFramePositions=[[0, 0, ROBOT_HEIGHT_M / 2], [0, 0, 0.62],
                                  [h - 0.02, 0, 0.1], [0, 0, ROBOT_HEIGHT_M + 0.05]],
            physicsClientId=c,
        )
        col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[h, h, ROBOT_HEIGHT_M / 2],
                                     collisionFramePosition=[0, 0, ROBOT_HEIGHT_M / 2],
                                     physicsClientId=c)
        body = p.createMultiBody(0, col, vis, [0, 0, 0], physicsClientId=c)
        p.changeDynamics(body, -1, restitution=0.5, lateralFriction=0.5, physicsClientId=c)
        self._robots[name] = body
        return int(body)

    def _lit(self, rgb: tuple[int, int, int], x_m: float, y_m: float) -> list[float]:
        """A colour as pybullet takes it, lit by the light pools at (x, y) if there are any."""
        return self._lights.rgba(rgb, x_m, y_m) if self.light else _rgba(rgb)

    def add_cover(self, name: str) -> None:
        """Dress robot ``name`` in a skirt of the ball's colour (it moves and hides with it)."""
        c = self._client
        pos, orn = p.getBasePositionAndOrientation(self._robots[name], physicsClientId=c)
        body = dressing.add_cover(c, ROBOT_SIZE_M / 2, self._lit(self.look.rgb, pos[0], pos[1]))
        p.resetBasePositionAndOrientation(body, pos, orn, physicsClientId=c)
        self._covers[name] = body

    def add_person(self, person: Person) -> None:
        """A figure in a shirt of the ball's colour (:mod:`recorder.scenery`)."""
        dressing.add_person(self._client, person, self.look.rgb, self.light)

    def relight(self) -> None:
        """Light the ball and the covers where they are now (with light pools): their colour
        times the light there. The frame loop calls it before every image it renders."""
        if self.light:
            bodies = {self.ball: (255, 255, 255) if self.look.textured else self.look.rgb}
            bodies.update(dict.fromkeys(self._covers.values(), self.look.rgb))
            self._lights.relight(self._client, bodies)

    # --- state -------------------------------------------------------------------------------
    def set_robot_pose(self, name: str, x_m: float, y_m: float, yaw_rad: float) -> None:
        q = p.getQuaternionFromEuler([0, 0, yaw_rad])
        p.resetBasePositionAndOrientation(self._robots[name], [x_m, y_m, 0.0], q,
                                          physicsClientId=self._client)
        if name in self._covers:
            p.resetBasePositionAndOrientation(self._covers[name], [x_m, y_m, 0.0], q,
                                              physicsClientId=self._client)

    def set_ball(self, x_m: float, y_m: float, vx_mps: float = 0.0, vy_mps: float = 0.0) -> None:
        """Put the ball on the ground at (x, y), rolling with (vx, vy) without slipping."""
        c = self._client
        p.resetBasePositionAndOrientation(self.ball, [x_m, y_m, BALL_RADIUS_M], [0, 0, 0, 1],
                                          physicsClientId=c)
        w = [-vy_mps / BALL_RADIUS_M, vx_mps / BALL_RADIUS_M, 0.0]
        p.resetBaseVelocity(self.ball, [vx_mps, vy_mps, 0.0], w, physicsClientId=c)

    def kick_ball(self, vx_mps: float, vy_mps: float) -> None:
        """Strike the ball where it is: it rolls off with (vx, vy) without slipping."""
        c = self._client
        w = [-vy_mps / BALL_RADIUS_M, vx_mps / BALL_RADIUS_M, 0.0]
        p.resetBaseVelocity(self.ball, [vx_mps, vy_mps, 0.0], w, physicsClientId=c)

    def place_ball(self, x_m: float, y_m: float, z_m: float,
                   quaternion: tuple[float, float, float, float] = (0, 0, 0, 1)) -> None:
        """Put the ball's centre at (x, y, z) at rest, turned by ``quaternion`` (x, y, z, w)."""
        c = self._client
        p.resetBasePositionAndOrientation(self.ball, [x_m, y_m, z_m], quaternion,
                                          physicsClientId=c)
        p.resetBaseVelocity(self.ball, [0, 0, 0], [0, 0, 0], physicsClientId=c)

    def ball_orientation(self) -> tuple[float, float, float, float]:
        """The ball body's orientation quaternion (x, y, z, w): its pattern turns with it."""
        _, q = p.getBasePositionAndOrientation(self.ball, physicsClientId=self._client)
        return (float(q[0]), float(q[1]), float(q[2]), float(q[3]))

    def launch_ball(self, vx_mps: float, vy_mps: float, vz_mps: float) -> None:
        """Strike the ball where it is into the air with (vx, vy, vz), without spin."""
        p.resetBaseVelocity(self.ball, [vx_mps, vy_mps, vz_mps], [0.0, 0.0, 0.0],
                            physicsClientId=self._client)

    def set_ball_damping(self, linear: float) -> None:
        """The ball's linear damping (:data:`BALL_DAMPING` by default)."""
        p.changeDynamics(self.ball, -1, linearDamping=linear, physicsClientId=self._client)

    def set_bounce(self, ground_restitution: float, contact_threshold_m: float) -> None:
        """The carpet's restitution (pybullet multiplies it by the ball's, 0.6) and the
        ball's contact processing threshold (pybullet's default resolves a contact up to
        a step early, which makes one bounce in three lose a quarter of its speed)."""
        c = self._client
        p.changeDynamics(self.ground, -1, restitution=ground_restitution, physicsClientId=c)
        p.changeDynamics(self.ball, -1, contactProcessingThreshold=contact_threshold_m,
                         physicsClientId=c)

    def ball_velocity(self) -> tuple[float, float, float]:
        """The ball centre's linear velocity [m/s] (field frame)."""
        v, _ = p.getBaseVelocity(self.ball, physicsClientId=self._client)
        return (float(v[0]), float(v[1]), float(v[2]))

    def add_walls(self, height_m: float = 0.5, *, hidden: bool = False) -> None:
        """Walls along the carpet's edge (collision only), so a ball kicked out bounces back
        into play. pybullet draws a body without a visual shape by its collision shape, so
        these walls show as a band at the carpet's edge (as in every earlier match log);
        ``hidden`` gives each a visual shape far below the floor instead, so none shows."""
        c = self._client
        vis = -1
        if hidden:
            vis = p.createVisualShape(p.GEOM_BOX, halfExtents=[0.01] * 3,
                                      visualFramePosition=[0, 0, -100.0], physicsClientId=c)
        hl = self.field.half_length_m + self.field.border_m
        hw = self.field.half_width_m + self.field.border_m
        t = 0.1
        for half, centre in (((t, hw + t, height_m / 2), (hl + t, 0.0, height_m / 2)),
                             ((t, hw + t, height_m / 2), (-hl - t, 0.0, height_m / 2)),
                             ((hl + t, t, height_m / 2), (0.0, hw + t, height_m / 2)),
                             ((hl + t, t, height_m / 2), (0.0, -hw - t, height_m / 2))):
            col = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=c)
            body = p.createMultiBody(0, col, vis, centre, physicsClientId=c)
            p.changeDynamics(body, -1, restitution=0.6, lateralFriction=0.3, physicsClientId=c)

    def add_distractor(self, x_m: float, y_m: float, size_m: float, yaw_rad: float = 0.0
                       ) -> None:
        """A box of the ball's colour (side ``size_m``) standing on the floor, turned by
        ``yaw_rad``: seen from above at an angle, a colour threshold may take it for the
        ball (square-on, its fill ratio gives it away)."""
        c = self._client
        half = [size_m / 2] * 3
        vis = p.createVisualShape(p.GEOM_BOX, halfExtents=half,
                                  rgbaColor=self._lit(self.look.rgb, x_m, y_m),
                                  specularColor=[0, 0, 0], physicsClientId=c)
        col = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=c)
        p.createMultiBody(0, col, vis, [x_m, y_m, size_m / 2],
                          p.getQuaternionFromEuler([0, 0, yaw_rad]), physicsClientId=c)

    def ball_position(self) -> tuple[float, float, float]:
        pos, _ = p.getBasePositionAndOrientation(self.ball, physicsClientId=self._client)
        return (float(pos[0]), float(pos[1]), float(pos[2]))

    def step(self, n: int = 1) -> None:
        for _ in range(n):
            p.stepSimulation(physicsClientId=self._client)

    @contextmanager
    def hidden(self, name: str) -> Iterator[None]:
        """Temporarily park a robot (and its cover) far below the field, so its own camera
        sees past it."""
        bodies = [self._robots[name]] + ([self._covers[name]] if name in self._covers else [])
        c = self._client
        saved = [p.getBasePositionAndOrientation(body, physicsClientId=c) for body in bodies]
        for body, (pos, orn) in zip(bodies, saved, strict=True):
            p.resetBasePositionAndOrientation(body, [pos[0], pos[1], -50.0], orn,
                                              physicsClientId=c)
        try:
            yield
        finally:
            for body, (pos, orn) in zip(bodies, saved, strict=True):
                p.resetBasePositionAndOrientation(body, pos, orn, physicsClientId=c)

    # --- rendering ---------------------------------------------------------------------------
    def render(self, width: int, height: int, view: list[float] | tuple[float, ...],
               proj: list[float] | tuple[float, ...]) -> np.ndarray:
        """One RGB image (height x width x 3, uint8, row 0 = top) from a view/projection."""
        return np.ascontiguousarray(self._render_rgba(width, height, view, proj)[:, :, :3])

    def render_into(self, out: np.ndarray, view: list[float] | tuple[float, ...],
                    proj: list[float] | tuple[float, ...]) -> None:
        """Render ``out``'s width x height from a view/projection into ``out`` as BGR
        (uint8, height x width x 3; a view into a larger image will do)."""
        rgba = self._render_rgba(out.shape[1], out.shape[0], view, proj)
        if cv2.cvtColor(rgba, cv2.COLOR_RGBA2BGR, dst=out) is not out:  # pragma: no cover
            out[...] = rgba[:, :, 2::-1]  # OpenCV could not write into this view

    def _render_rgba(self, width: int, height: int, view: list[float] | tuple[float, ...],
                     proj: list[float] | tuple[float, ...]) -> np.ndarray:
        with silenced():
            _, _, rgba, _, _ = p.getCameraImage(
                width, height, view, proj,
                renderer=self.render_mode,
                flags=p.ER_NO_SEGMENTATION_MASK,
                shadow=0,
                lightDirection=[0.3, 0.2, 1.0],
                lightColor=[1, 1, 1],
                lightAmbientCoeff=0.65,
                lightDiffuseCoeff=0.45,
                lightSpecularCoeff=0.0,
                physicsClientId=self._client,
            )
        return np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)

    def close(self) -> None:
        if self._client >= 0:
            try:
                with silenced():
                    if self._plugin >= 0:
                        p.unloadPlugin(self._plugin, physicsClientId=self._client)
                    p.disconnect(physicsClientId=self._client)
            finally:
                self._client = -1
                self._tmp.cleanup()

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

