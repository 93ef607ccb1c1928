"""Omnidirectional images from pybullet: a few perspective views remapped through a camera model.

For each robot camera we render a handful of views in the *robot* frame from the optical
centre, pack them into one atlas and ``cv2.remap`` the atlas into the 1080 x 1080 omni
image. Because the views turn with the robot, the remap tables depend only on the camera
model and the views' sizes: they are computed once per model (:mod:`recorder.omni_layout`
plans them) and reused every frame. Each view carries a one-pixel margin (a slightly wider
field of view) so bilinear interpolation never reads across a seam into the next view.

Only what the lens sees is rendered, at the resolution the omni image needs:

- a model that sees everything through a cube's down face (the ideal camera's virtual view
  from high above) gets that one face, narrowed to the widest ray;
- any other (the fisheye, the mirror) gets a down view and four side views tilted down
  (20-30 deg, picked per model and face size), each cropped to the rectangle its rays
  land in (from the horizon down) and sized across and up apart to the sampling the omni
  image needs there: at 1024 px faces, five renders that each fit EGL's 1024 x 768 (a
  render has a fixed cost: fewer is faster).

The robot's own body is taken out of the scene while its camera renders (it would sit a few
centimetres below the lens and fill the view); the image shows instead a dark square where
the robot's footprint is, and the mirror model's own reflection as a black disc. Both are
drawn by the remap itself: their pixels read a patch of the robot's colour at the atlas's
end, or a point outside the atlas (black).
"""

from __future__ import annotations

import itertools
import math

import cv2
import numpy as np

from estimator.camera import CameraModel, MirrorCamera
from recorder.omni_layout import FACES, Piece, plan
from recorder.world import ROBOT_RGB, ROBOT_SIZE_M, World

__all__ = ["DEFAULT_FACE_PX", "FACES", "OmniRenderer"]

DEFAULT_FACE_PX = 1024
"""Cube face side in pixels. 1024 gives ~512 px/rad at a face centre, about the omni image's
tangential resolution at 8 m range (r ~ 500 px), so far balls stay sharp. The views are
sized to sample the omni image at least as finely as a cube of such faces at its coarsest."""

RENDER_OFFSET_PX: dict[str, tuple[float, float]] = {"egl": (0.0, 0.0), "tiny": (0.5, -0.5)}
"""Where each renderer draws a point that projects to a view's exact centre, relative to the
OpenGL convention (pixel i covers [i - 0.5, i + 0.5] about coordinate i): TinyRenderer's
image is shifted half a pixel right and up (measured; see tests/test_recorder_geometry.py)."""
MAX_RENDER_PX: dict[str, tuple[int, int]] = {"egl": (1024, 768)}
"""Largest image (width, height) a renderer draws exactly (pybullet's EGL window is
1024 x 768; larger requests are resampled from it). Bigger pieces are rendered in tiles;
the views are planned to fit EGL's (the remap tables serve every renderer)."""
_NEAR_M = 0.02
_FAR_M = 80.0
_PATCH_PX = 4
"""The robot-coloured patch at the atlas's right end (body pixels read its middle)."""
_OUTSIDE_PX = -1000.0
"""Where pixels outside the image circle read: off the atlas (the border, black)."""


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

    Only what the lens sees is rendered, each piece at the size the omni image needs (see
    the module docstring); ``face_px`` sets the sampling: that of a cube of such faces.
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
        self._build_maps()
        self._maps: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        self._atlas: np.ndarray | None = None
        if renderer is not None:
            self._maps_for(renderer)

    def _maps_for(self, renderer: str) -> tuple[np.ndarray, np.ndarray]:
        """Fixed-point remap tables with the renderer's pixel offset, built once each."""
        if renderer not in self._maps:
            off_u, off_v = RENDER_OFFSET_PX[renderer]
            map_x = self._map_x + np.float32(off_u)
            map_y = self._map_y + np.float32(off_v)
            map_x[self._black], map_y[self._black] = _OUTSIDE_PX, _OUTSIDE_PX
            patch = self._atlas_shape[1] - _PATCH_PX / 2.0  # the middle of the patch
            map_x[self._body], map_y[self._body] = patch, _PATCH_PX / 2.0
            self._maps[renderer] = cv2.convertMaps(map_x, map_y, cv2.CV_16SC2)
        return self._maps[renderer]

    @property
    def face_names(self) -> tuple[str, ...]:
        """The views rendered per image, in atlas order."""
        return tuple(piece.view.name for piece in self._pieces)

    @property
    def pieces(self) -> tuple[tuple[str, int, int], ...]:
        """(view, columns, rows) of each rendered part, in atlas order."""
        return tuple((piece.view.name, *piece.shape) for piece in self._pieces)

    @property
    def rendered_px(self) -> int:
        """Pixels rendered per omni image."""
        return sum(p.shape[0] * p.shape[1] for p in self._pieces)

    def _build_maps(self) -> None:
        cam = self.camera
        layout = plan(cam, self.face_px, MAX_RENDER_PX["egl"])
        self._pieces: list[Piece] = layout.pieces
        self._map_x, self._map_y = layout.map_x, layout.map_y
        self._atlas_shape = (max(_PATCH_PX, *(p.shape[1] for p in self._pieces)),
                             sum(p.shape[0] for p in self._pieces) + _PATCH_PX, 3)
        rays, r, valid = layout.rays, layout.r, layout.valid
        black = ~valid  # outside the image circle (black), own body footprint, mirror self
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
        if self._atlas is None:  # drawn into anew each frame: every piece is rendered
            self._atlas = self._new_atlas()
        if robot is None:
            atlas = self.render_atlas(world, x_m, y_m, yaw_rad, out=self._atlas)
        else:
            with world.hidden(robot):
                atlas = self.render_atlas(world, x_m, y_m, yaw_rad, out=self._atlas)
        return self.remap(atlas, world.renderer)

    def _new_atlas(self) -> np.ndarray:
        atlas = np.zeros(self._atlas_shape, np.uint8)
        atlas[:_PATCH_PX, -_PATCH_PX:] = ROBOT_RGB[::-1]
        return atlas

    def render_atlas(self, world: World, x_m: float, y_m: float, yaw_rad: float, *,
                     out: np.ndarray | None = None) -> np.ndarray:
        """The rendered pieces side by side (BGR), top-aligned, then the body's patch; in
        ``out`` (an atlas of an earlier call) if given.

        A piece larger than the renderer's largest exact image (EGL draws into a 1024 x 768
        window and resamples anything bigger) is rendered as a grid of sub-images with
        off-centre frustums, so every pixel is rendered, not resampled.
        """
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        eye = np.array([x_m, y_m, self.camera.height_m])
        atlas = self._new_atlas() if out is None else out
        limit = MAX_RENDER_PX.get(world.renderer)
        for piece in self._pieces:
            view = _look_at(eye, rot @ piece.view.forward, rot @ piece.view.up)
            cols, rows = piece.shape
            _render_piece(world, piece, view, limit,
                          atlas[:rows, piece.x0:piece.x0 + cols])
        return atlas

    def remap(self, atlas_bgr: np.ndarray, renderer: str) -> np.ndarray:
        """The omni image (BGR) from an atlas that ``renderer`` drew."""
        map1, map2 = self._maps_for(renderer)
        return cv2.remap(atlas_bgr, map1, map2, cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0))


def _edges(lo: int, hi: int, limit: int | None) -> list[int]:
    """[lo, hi) cut into even parts of at most ``limit`` (one part: no limit)."""
    parts = 1 if limit is None else -(-(hi - lo) // limit)
    return [int(e) for e in np.linspace(lo, hi, parts + 1).round().astype(int)]


def _render_piece(world: World, piece: Piece, view: list[float],
                  limit: tuple[int, int] | None, out: np.ndarray) -> None:
    """The piece's rows and columns of its view's window, in as few exact renders as fit,
    drawn into ``out`` (BGR)."""
    nx, ny = piece.tile
    tx = piece.half_tan * nx / piece.size[0]  # tangent half-extents of the whole window
    ty = piece.half_tan * ny / piece.size[1]
    (r0, r1), (c0, c1) = piece.rows, piece.cols
    max_w, max_h = limit if limit is not None else (None, None)
    row_edges, col_edges = _edges(r0, r1, max_h), _edges(c0, c1, max_w)
    if piece.whole and nx == ny and len(row_edges) == len(col_edges) == 2:
        fov_deg = math.degrees(2.0 * math.atan(tx))  # one symmetric render
        world.render_into(out, view, _perspective(fov_deg, _NEAR_M, _FAR_M))
        return
    for ra, rb in itertools.pairwise(row_edges):
        for ca, cb in itertools.pairwise(col_edges):
            proj = _frustum(
                _NEAR_M * tx * (2 * ca / nx - 1), _NEAR_M * tx * (2 * cb / nx - 1),
                _NEAR_M * ty * (1 - 2 * rb / ny), _NEAR_M * ty * (1 - 2 * ra / ny),
            )
            world.render_into(out[ra - r0:rb - r0, ca - c0:cb - c0], view, proj)
