"""The world's dressing in pybullet: the ball's look, people, robot covers and the light.

:class:`recorder.world.World` calls these when a recording asks for a ball colour or
pattern, people, covers or light pools (:mod:`recorder.ball`, :mod:`recorder.scenery`
describe them); a recording that asks for none never calls them, so its world is built by
the same pybullet calls as before, in the same order.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from recorder.ball import BallLook, ball_texture, sphere_obj, sphere_obj_uv
from recorder.scenery import LightPool, Person, light_at
from recorder.silence import silenced

with silenced():
    import pybullet as p

__all__ = [
    "COVER_HEIGHT_M",
    "PERSON_SKIN_RGB",
    "PERSON_TROUSERS_RGB",
    "Lights",
    "add_cover",
    "add_person",
    "ball_visual",
    "light_texture",
    "lit_rgba",
    "person_parts",
    "texture_ball",
]

PERSON_SKIN_RGB = (205, 160, 130)
PERSON_TROUSERS_RGB = (45, 50, 70)
COVER_HEIGHT_M = (0.05, 0.25)
"""A cover's skirt spans these heights above the ground."""
_COVER_MARGIN_M = 0.012
"""The skirt stands this far out of the robot's body on each side."""

Box = tuple[tuple[float, float, float], tuple[float, float, float], tuple[int, int, int]]
"""(half extents, centre in the body frame, RGB) of a box."""


def lit_rgba(rgb: Sequence[float], pools: tuple[LightPool, ...], x_m: float, y_m: float
             ) -> list[float]:
    """``rgb`` (0-255) as a pybullet colour lit by the light at (x, y), alpha 1."""
    light = light_at(pools, x_m, y_m)
    return [float(rgb[i]) / 255.0 * float(light[i]) for i in range(3)] + [1.0]


class Lights:
    """Colours lit by the light pools, and bodies re-tinted where they are now."""

    def __init__(self, pools: tuple[LightPool, ...]) -> None:
        self.pools = pools
        self._tints: dict[int, list[float]] = {}

    def rgba(self, rgb: Sequence[float], x_m: float, y_m: float) -> list[float]:
        return lit_rgba(rgb, self.pools, x_m, y_m)

    def relight(self, client: int, bodies: dict[int, tuple[int, int, int]]) -> None:
        """Tint each body (-> its colour) by the light at its place, if that changed."""
        for body, rgb in bodies.items():
            pos, _ = p.getBasePositionAndOrientation(body, physicsClientId=client)
            rgba = self.rgba(rgb, pos[0], pos[1])
            if self._tints.get(body) != rgba:
                p.changeVisualShape(body, -1, rgbaColor=rgba, physicsClientId=client)
                self._tints[body] = rgba


def light_texture(texture_bgr: np.ndarray, pools: tuple[LightPool, ...], full_l_m: float,
                  full_w_m: float) -> np.ndarray:
    """The carpet's texture (row 0 = +y edge, column 0 = -x edge) lit texel by texel."""
    h, w = texture_bgr.shape[:2]
    x = -full_l_m / 2 + (np.arange(w) + 0.5) * full_l_m / w
    y = full_w_m / 2 - (np.arange(h) + 0.5) * full_w_m / h
    light = light_at(pools, x[None, :], y[:, None])[..., ::-1]
    return np.asarray(np.clip(np.rint(texture_bgr * light), 0, 255), dtype=np.uint8)


def ball_visual(client: int, folder: Path, look: BallLook, radius_m: float) -> int:
    """The ball's visual shape: the plain look exactly as before (the same mesh, its
    colour), a pattern on a UV sphere of the same facets (white; the texture colours it)."""
    path = folder / "ball.obj"
    if not look.textured:
        path.write_text(sphere_obj(radius_m, 24, 48))
        return int(p.createVisualShape(p.GEOM_MESH, fileName=str(path),
                                       rgbaColor=[c / 255.0 for c in look.rgb] + [1.0],
                                       specularColor=[0, 0, 0], physicsClientId=client))
    path.write_text(sphere_obj_uv(radius_m, 24, 48))
    return int(p.createVisualShape(p.GEOM_MESH, fileName=str(path), rgbaColor=[1, 1, 1, 1],
                                   specularColor=[0, 0, 0], physicsClientId=client))


def texture_ball(client: int, body: int, folder: Path, look: BallLook, radius_m: float) -> None:
    """Give the ball body its pattern's texture (a textured look only)."""
    path = folder / "ball.png"
    cv2.imwrite(str(path), ball_texture(look, radius_m))
    tex = p.loadTexture(str(path), physicsClientId=client)
    p.changeVisualShape(body, -1, textureUniqueId=tex, physicsClientId=client)


def person_parts(person: Person, shirt_rgb: tuple[int, int, int]) -> list[Box]:
    """A figure as boxes in its body frame (x the way it faces, z up from its feet): legs
    (trousers), torso and arms (shirt); the head is a sphere apart (see add_person)."""
    h = person.height_m
    tr, sk = PERSON_TROUSERS_RGB, shirt_rgb
    if person.crouching:  # squatting: thighs forward, the torso on them, arms on the knees
        hip = 0.26 * h
        legs = [((0.2, 0.08, hip / 2), (0.06, s * 0.1, hip / 2), tr) for s in (-1, 1)]
        arm_x, arm_half = 0.08, 0.14 * h
    else:
        hip = 0.47 * h
        legs = [((0.07, 0.07, hip / 2), (0.0, s * 0.1, hip / 2), tr) for s in (-1, 1)]
        arm_x, arm_half = 0.0, 0.16 * h
    torso_half = 0.165 * h
    torso = ((0.12, 0.2, torso_half), (0.0, 0.0, hip + torso_half), sk)
    arms = [((0.05, 0.05, arm_half), (arm_x, s * 0.26, hip + 2 * torso_half - arm_half), sk)
            for s in (-1, 1)]
    return [*legs, torso, *arms]


def add_person(client: int, person: Person, shirt_rgb: tuple[int, int, int],
               pools: tuple[LightPool, ...]) -> int:
    """A standing or crouching figure (static; it collides as one box), lit where it stands."""
    boxes = person_parts(person, shirt_rgb)
    top = max(c[2] + half[2] for half, c, _ in boxes)
    head_r = 0.065 * person.height_m
    head_z = top + 0.02 * person.height_m + head_r
    x, y = person.x_m, person.y_m
    vis = p.createVisualShapeArray(
        shapeTypes=[p.GEOM_BOX] * len(boxes) + [p.GEOM_SPHERE],
        halfExtents=[list(half) for half, _, _ in boxes] + [[0, 0, 0]],
        radii=[0.0] * len(boxes) + [head_r],
        rgbaColors=[lit_rgba(rgb, pools, x, y) for _, _, rgb in boxes]
        + [lit_rgba(PERSON_SKIN_RGB, pools, x, y)],
        visualFramePositions=[list(c) for _, c, _ in boxes] + [[0, 0, head_z]],
        physicsClientId=client,
    )
    tall = head_z + head_r
    col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.2, 0.3, tall / 2],
                                 collisionFramePosition=[0, 0, tall / 2],
                                 physicsClientId=client)
    return int(p.createMultiBody(0, col, vis, [x, y, 0.0],
                                 p.getQuaternionFromEuler([0, 0, person.yaw_rad]),
                                 physicsClientId=client))


def add_cover(client: int, robot_half_m: float, rgba: list[float]) -> int:
    """A ball-coloured skirt around a robot's base (visual only: the robot's box collides);
    a body of its own, posed with the robot."""
    lo, hi = COVER_HEIGHT_M
    half = robot_half_m + _COVER_MARGIN_M
    vis = p.createVisualShape(p.GEOM_BOX, halfExtents=[half, half, (hi - lo) / 2],
                              visualFramePosition=[0, 0, (hi + lo) / 2], rgbaColor=rgba,
                              specularColor=[0, 0, 0], physicsClientId=client)
    return int(p.createMultiBody(0, -1, vis, [0, 0, 0], physicsClientId=client))
