"""Omnidirectional images from pybullet: render cube-map faces, remap them through a camera model.

For each robot camera we render up to five 90 deg faces (forward, left, back, right, down) in the
*robot* frame from the optical centre, tile them into one atlas and ``cv2.remap`` the atlas
into the 1080 x 1080 omni image. Because the faces turn with the robot, the remap tables
depend only on the camera model and the face size: they are computed once per model and
reused every frame. Each face carries a one-pixel margin (a slightly wider field of view)
so bilinear interpolation never reads across a seam into the neighbouring face.

Only the faces a model needs are rendered; a model that sees everything through the down
face (the ideal camera's virtual view from high above) gets one narrowed face.

The robot's own body is taken out of the scene while its camera renders (it would sit a few
centimetres below the lens and fill the view); the image shows instead a dark square where
the robot's footprint is, and the mirror model's own reflection as a black disc.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import cv2
import numpy as np

from estimator.camera import CameraModel, MirrorCamera
from recorder.world import ROBOT_RGB, ROBOT_SIZE_M, World

__all__ = ["DEFAULT_FACE_PX", "FACES", "OmniRenderer"]

DEFAULT_FACE_PX = 1024
"""Cube face side in pixels. 1024 gives ~512 px/rad at a face centre, about the omni image's
tangential resolution at 8 m range (r ~ 500 px), so far balls stay sharp."""

# name -> (view direction, up vector) in the robot frame (x forward, y left, z up)
FACES: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    "front": ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    "left": ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
    "back": ((-1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    "right": ((0.0, -1.0, 0.0), (0.0, 0.0, 1.0)),
    "down": ((0.0, 0.0, -1.0), (1.0, 0.0, 0.0)),
}
_MARGIN_PX = 1
RENDER_OFFSET_PX: dict[str, tuple[float, float]] = {"egl": (0.0, 0.0), "tiny": (0.5, -0.5)}
MAX_RENDER_PX: dict[str, int] = {"egl": 768}
"""Largest image side a renderer draws exactly (pybullet's EGL window is 1024 x 768; larger
requests are resampled from it). Bigger faces are rendered in tiles."""
"""Where each renderer draws a point that projects to a face's exact centre, relative to the
OpenGL convention (pixel i covers [i - 0.5, i + 0.5] about coordinate i): TinyRenderer's
image is shifted half a pixel right and up (measured; see tests/test_recorder_geometry.py)."""
_NEAR_M = 0.02
_FAR_M = 80.0


@dataclass(frozen=True)
class _Face:
    name: str
    forward: np.ndarray
    up: np.ndarray
    right: np.ndarray


def _faces() -> list[_Face]:
    out = []
    for name, (f, u) in FACES.items():
        fa, ua = np.array(f, float), np.array(u, float)
        out.append(_Face(name, fa, ua, np.cross(fa, ua)))
    return out


def _perspective(fov_deg: float, near: float, far: float) -> list[float]:
    """OpenGL projection (column-major), as pybullet's computeProjectionMatrixFOV, aspect 1."""
    f = 1.0 / math.tan(math.radians(fov_deg) / 2.0)
    return [f, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) / (near - far), -1,
            0, 0, 2 * far * near / (near - far), 0]


def _frustum(left: float, right: float, bottom: float, top: float) -> list[float]:
    """OpenGL off-centre projection (glFrustum, column-major) at the near plane _NEAR_M."""
    n, f = _NEAR_M, _FAR_M
    return [2 * n / (right - left), 0, 0, 0, 0, 2 * n / (top - bottom), 0, 0,
            (right + left) / (right - left), (top + bottom) / (top - bottom),
            -(f + n) / (f - n), -1, 0, 0, -2 * f * n / (f - n), 0]


def _look_at(eye: np.ndarray, forward: np.ndarray, up: np.ndarray) -> list[float]:
    """OpenGL view matrix (column-major) looking along ``forward`` with ``up``."""
    f = forward / np.linalg.norm(forward)
    s = np.cross(f, up)
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    return [float(x) for x in m.T.reshape(-1)]


class OmniRenderer:
    """Renders a camera model's omni image from a world, with remap tables built once.

    Only the faces the model's image circle needs are rendered. When that is the down face
    alone (a view from high above, like the ideal camera), its field of view is narrowed to
    the widest ray used, so all ``face_px`` pixels cover the image circle.
    """

    def __init__(self, camera: CameraModel, *, face_px: int = DEFAULT_FACE_PX,
                 renderer: str | None = None) -> None:
        """``renderer`` ("egl" or "tiny") only builds its tables now; ``render`` builds the
        tables of the world's renderer on first use anyway."""
        if face_px < 16:
            raise ValueError(f"face size must be >= 16 px, got {face_px}")
        if renderer is not None and renderer not in RENDER_OFFSET_PX:
            raise ValueError(f"unknown renderer {renderer!r}")
        self.camera = camera
        self.face_px = int(face_px)
        self.tile_px = self.face_px + 2 * _MARGIN_PX
        self._build_maps()
        # tan(half fov) of a tile: the face's extent plus the margin at the same pixel pitch
        self.tile_fov_deg = math.degrees(
            2.0 * math.atan(self._half_tan * self.tile_px / self.face_px)
        )
        self._proj = _perspective(self.tile_fov_deg, _NEAR_M, _FAR_M)
        self._maps: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        if renderer is not None:
            self._maps_for(renderer)

    def _maps_for(self, renderer: str) -> tuple[np.ndarray, np.ndarray]:
        """Fixed-point remap tables with the renderer's pixel offset, built once each."""
        if renderer not in self._maps:
            off_u, off_v = RENDER_OFFSET_PX[renderer]
            self._maps[renderer] = cv2.convertMaps(self._map_x + np.float32(off_u),
                                                   self._map_y + np.float32(off_v),
                                                   cv2.CV_16SC2)
        return self._maps[renderer]

    def _splits(self, renderer: str) -> int:
        limit = MAX_RENDER_PX.get(renderer)
        return 1 if limit is None else -(-self.tile_px // limit)

    @property
    def face_names(self) -> tuple[str, ...]:
        """The faces rendered per image, in atlas order."""
        return tuple(f.name for f in self._faces)

    def _build_maps(self) -> None:
        cam = self.camera
        h, w = cam.height_px, cam.width_px
        v, u = np.mgrid[0:h, 0:w].astype(np.float64)
        rays = cam.pixel_to_ray(u, v)
        cu, cv_ = cam.centre_px
        r = np.hypot(u - cu, v - cv_)
        valid = (r <= cam.max_radius_px) & np.all(np.isfinite(rays), axis=-1)
        rays = np.where(valid[..., None], rays, np.array([0.0, 0.0, -1.0]))
        faces = _faces()
        best = np.argmax(np.stack([rays @ f.forward for f in faces], axis=-1), axis=-1)
        used = sorted({int(k) for k in np.unique(best[valid])})
        self._faces = [faces[k] for k in used]
        self._half_tan = 1.0
        if [f.name for f in self._faces] == ["down"]:
            d = rays[valid]
            self._half_tan = float(np.max(np.abs(d[:, :2]) / -d[:, 2:3]))
        map_x = np.zeros((h, w), np.float32)
        map_y = np.zeros((h, w), np.float32)
        scale = self.face_px / 2.0 / self._half_tan
        centre = self.tile_px / 2.0 - 0.5  # pixel i has coordinate i, its centre at i
        for slot, k in enumerate(used):
            face = faces[k]
            sel = best == k
            d = rays[sel]
            depth = d @ face.forward
            a = (d @ face.right) / depth
            b = (d @ face.up) / depth
            map_x[sel] = (slot * self.tile_px + centre + a * scale).astype(np.float32)
            map_y[sel] = (centre - b * scale).astype(np.float32)
        self._map_x, self._map_y = map_x, map_y
        # masks: outside the image circle (black), own body footprint (dark), mirror self
        black = ~valid
        if isinstance(cam, MirrorCamera):
            black |= r < cam.self_radius_px
        with np.errstate(invalid="ignore", divide="ignore"):
            t = cam.height_m / -rays[..., 2]
            gx, gy = rays[..., 0] * t, rays[..., 1] * t
        body = valid & (rays[..., 2] < 0) & (np.abs(gx) <= ROBOT_SIZE_M / 2) & (
            np.abs(gy) <= ROBOT_SIZE_M / 2
        )
        self._black = black
        self._body = body & ~black

    def render(self, world: World, robot: str | None, x_m: float, y_m: float,
               yaw_rad: float) -> np.ndarray:
        """The omni image (BGR uint8, height x width x 3) of a camera at (x, y, yaw).

        ``robot`` names the world's robot that carries the camera; it is hidden while
        rendering. ``None`` renders from a bare camera (e.g. tests).
        """
        if robot is None:
            atlas = self.render_atlas(world, x_m, y_m, yaw_rad)
        else:
            with world.hidden(robot):
                atlas = self.render_atlas(world, x_m, y_m, yaw_rad)
        return self.remap(atlas, world.renderer)

    def render_atlas(self, world: World, x_m: float, y_m: float, yaw_rad: float) -> np.ndarray:
        """The needed faces side by side (RGB), each ``tile_px`` square.

        A face larger than the renderer's largest exact image (EGL draws into a 1024 x 768
        window and resamples anything bigger) is rendered as a grid of sub-images with
        off-centre frustums and pasted together, so every pixel is rendered, not resampled.
        """
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        eye = np.array([x_m, y_m, self.camera.height_m])
        n = self.tile_px
        splits = self._splits(world.renderer)
        edges = np.linspace(0, n, splits + 1).round().astype(int)
        t = self._half_tan * n / self.face_px  # tangent half-extent of a whole tile
        tiles = []
        for face in self._faces:
            view = _look_at(eye, rot @ face.forward, rot @ face.up)
            if splits == 1:
                tiles.append(world.render(n, n, view, self._proj))
                continue
            tile = np.empty((n, n, 3), np.uint8)
            for r0, r1 in itertools.pairwise(edges):
                for c0, c1 in itertools.pairwise(edges):
                    proj = _frustum(
                        _NEAR_M * t * (2 * c0 / n - 1), _NEAR_M * t * (2 * c1 / n - 1),
                        _NEAR_M * t * (1 - 2 * r1 / n), _NEAR_M * t * (1 - 2 * r0 / n),
                    )
                    tile[r0:r1, c0:c1] = world.render(int(c1 - c0), int(r1 - r0), view, proj)
            tiles.append(tile)
        return np.hstack(tiles)

    def remap(self, atlas_rgb: np.ndarray, renderer: str) -> np.ndarray:
        """The omni image (BGR) from an atlas that ``renderer`` drew."""
        map1, map2 = self._maps_for(renderer)
        out = cv2.remap(atlas_rgb, map1, map2, cv2.INTER_LINEAR,
                        borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0))
        out = cv2.cvtColor(out, cv2.COLOR_RGB2BGR)
        out[self._body] = ROBOT_RGB[::-1]
        out[self._black] = 0
        return out
