"""Omnidirectional images from pybullet: render cube-map faces, remap them through a camera model.

For each robot camera we render up to five 90 deg faces (forward, left, back, right, down) in the
*robot* frame from the optical centre, pack them into one atlas and ``cv2.remap`` the atlas
into the 1080 x 1080 omni image. Because the faces turn with the robot, the remap tables
depend only on the camera model and the face size: they are computed once per model and
reused every frame. Each face carries a one-pixel margin (a slightly wider field of view)
so bilinear interpolation never reads across a seam into the neighbouring face.

Only what the lens sees is rendered, at the resolution the omni image needs:

- only the faces a model needs; a model that sees everything through the down face (the
  ideal camera's virtual view from high above) gets one face narrowed to the widest ray;
- of each face only the rectangle its rays land in (a camera looking down sees the lower
  half of the side faces), drawn with an off-centre frustum;
- each face at its own size: the faces are sized so that, at the coarsest pixel of the
  omni image each one serves, one omni pixel spans at least as many face pixels as on the
  coarsest full-size (``face_px``) face. A fisheye's or a mirror's down face serves the
  image centre, where the lens magnifies least, so it shrinks to 500-700 px.

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
MAX_RENDER_PX: dict[str, tuple[int, int]] = {"egl": (1024, 768)}
"""Largest image (width, height) a renderer draws exactly (pybullet's EGL window is
1024 x 768; larger requests are resampled from it). Bigger faces are rendered in tiles."""
_FIT_PX = 1024
"""A cropped face whose tile is at most 1 % wider than this is shrunk to it: one EGL render
instead of two, for a resolution 0.2 % lower."""
_BAND_B = -0.5
"""A side face is sized in two bands, split where its rays are 26.6 deg below its centre
(tangent -1/2): a lens looking down magnifies the horizon most, the band below it less."""
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


@dataclass(frozen=True)
class _Piece:
    """The part of one face that is rendered: the face, its tile (``face_px`` + margins,
    square, at ``half_tan`` = tan of half the face's field of view) and the tile's rows
    [r0, r1) and columns [c0, c1) that the omni image reads, at column ``x0`` of the atlas."""

    face: _Face
    face_px: int
    half_tan: float
    rows: tuple[int, int]
    cols: tuple[int, int]
    x0: int

    @property
    def tile_px(self) -> int:
        return self.face_px + 2 * _MARGIN_PX

    @property
    def scale(self) -> float:
        """Tile pixels per unit of the face's tangent plane."""
        return self.face_px / 2.0 / self.half_tan

    @property
    def whole(self) -> bool:
        """The whole tile is rendered."""
        n = self.tile_px
        return self.rows == (0, n) and self.cols == (0, n)


def _smin(a: np.ndarray, b: np.ndarray, sel: np.ndarray) -> float:
    """The smallest singular value over the selected pixels of d(a, b) / d(u, v) (pixels on
    the selection's edge left out, so seams and the image circle's rim do not count)."""
    au, av = np.gradient(a, axis=1), np.gradient(a, axis=0)
    bu, bv = np.gradient(b, axis=1), np.gradient(b, axis=0)
    s1 = np.hypot(au + bv, av - bu) / 2
    s2 = np.hypot(au - bv, av + bu) / 2
    inner = cv2.erode(sel.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    return float(np.min(np.abs(s1 - s2)[inner])) if inner.any() else 0.0


def _span(lo: float, hi: float, n: int) -> tuple[int, int]:
    """Tile pixels [first, last + 1) that bilinear reads between coordinates lo and hi,
    with a pixel more each side for a renderer's half-pixel offset; whole if nearly all."""
    first, last = max(math.floor(lo) - 2, 0), min(math.ceil(hi) + 3, n)
    return (0, n) if last - first > 0.9 * n else (first, last)


class OmniRenderer:
    """Renders a camera model's omni image from a world, with remap tables built once.

    Only what the lens sees is rendered, each face at the size the omni image needs (see
    the module docstring); ``face_px`` is the largest face.
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

    @property
    def face_names(self) -> tuple[str, ...]:
        """The faces rendered per image, in atlas order."""
        return tuple(dict.fromkeys(piece.face.name for piece in self._pieces))

    @property
    def pieces(self) -> tuple[tuple[str, int], ...]:
        """(face, size [px]) of each rendered part, in atlas order (a side face's band near
        the horizon, then the band below it)."""
        return tuple((piece.face.name, piece.face_px) for piece in self._pieces)

    @property
    def rendered_px(self) -> int:
        """Pixels rendered per omni image."""
        return sum((p.rows[1] - p.rows[0]) * (p.cols[1] - p.cols[0]) for p in self._pieces)

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
        half_tan = 1.0
        if [faces[k].name for k in used] == ["down"]:
            d = rays[valid]
            half_tan = float(np.max(np.abs(d[:, :2]) / -d[:, 2:3]))
        # each face's tangent-plane coordinates (a right, b up) of the pixels it serves; a
        # side face in two bands (near the horizon / below), which may differ in size
        planes = []
        for k in used:
            face, sel = faces[k], valid & (best == k)
            depth = np.where(sel, rays @ face.forward, 1.0)
            a, b = (rays @ face.right) / depth, (rays @ face.up) / depth
            bands = [sel] if face.name == "down" else [sel & (b >= _BAND_B), sel & (b < _BAND_B)]
            planes += [(k, band, a, b) for band in bands if band.any()]
        # sizes: one omni pixel spans at least as many face pixels as on the coarsest
        # full-size face (smin: face-plane units per omni pixel, at the coarsest pixel)
        full = self.face_px / 2.0 / half_tan
        smin = [_smin(a, b, sel) for _, sel, a, b in planes]
        bar = min(full * m for m in smin if m > 0) if any(smin) else 0.0
        map_x = np.zeros((h, w), np.float32)
        map_y = np.zeros((h, w), np.float32)
        self._pieces: list[_Piece] = []
        x0 = 0
        for (k, sel, a, b), m in zip(planes, smin, strict=True):
            size = self.face_px
            if m > 0 and bar > 0:
                size = min(self.face_px, max(16, math.ceil(2.0 * half_tan * bar / m)))
            if len(used) > 1 and _FIT_PX < size + 2 * _MARGIN_PX <= 1.01 * _FIT_PX:
                size = _FIT_PX - 2 * _MARGIN_PX
            scale = size / 2.0 / half_tan
            centre = (size + 2 * _MARGIN_PX) / 2.0 - 0.5  # pixel i has coordinate i
            xs = (centre + a[sel] * scale).astype(np.float32)
            ys = (centre - b[sel] * scale).astype(np.float32)
            n = size + 2 * _MARGIN_PX
            rows = _span(float(ys.min()), float(ys.max()), n)
            cols = _span(float(xs.min()), float(xs.max()), n)
            self._pieces.append(_Piece(faces[k], size, half_tan, rows, cols, x0))
            map_x[sel] = xs + np.float32(x0 - cols[0])
            map_y[sel] = ys - np.float32(rows[0])
            x0 += cols[1] - cols[0]
        self._map_x, self._map_y = map_x, map_y
        self._masks(cam, rays, r, valid)

    def _masks(self, cam: CameraModel, rays: np.ndarray, r: np.ndarray,
               valid: np.ndarray) -> None:
        """Outside the image circle (black), own body footprint (dark), mirror self."""
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
        """The rendered parts of the faces side by side (RGB), top-aligned.

        A part larger than the renderer's largest exact image (EGL draws into a 1024 x 768
        window and resamples anything bigger) is rendered as a grid of sub-images with
        off-centre frustums and pasted together, so every pixel is rendered, not resampled.
        """
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        eye = np.array([x_m, y_m, self.camera.height_m])
        height = max(p.rows[1] - p.rows[0] for p in self._pieces)
        width = sum(p.cols[1] - p.cols[0] for p in self._pieces)
        atlas = np.zeros((height, width, 3), np.uint8)
        limit = MAX_RENDER_PX.get(world.renderer)
        for piece in self._pieces:
            view = _look_at(eye, rot @ piece.face.forward, rot @ piece.face.up)
            (r0, r1), (c0, c1) = piece.rows, piece.cols
            atlas[:r1 - r0, piece.x0:piece.x0 + c1 - c0] = _render_piece(
                world, piece, view, limit)
        return atlas

    def remap(self, atlas_rgb: np.ndarray, renderer: str) -> np.ndarray:
        """The omni image (BGR) from an atlas that ``renderer`` drew."""
        map1, map2 = self._maps_for(renderer)
        out = cv2.remap(atlas_rgb, map1, map2, cv2.INTER_LINEAR,
                        borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0))
        out = cv2.cvtColor(out, cv2.COLOR_RGB2BGR)
        out[self._body] = ROBOT_RGB[::-1]
        out[self._black] = 0
        return out


def _edges(lo: int, hi: int, limit: int | None) -> list[int]:
    """[lo, hi) cut into even parts of at most ``limit`` (one part: no limit)."""
    parts = 1 if limit is None else -(-(hi - lo) // limit)
    return [int(e) for e in np.linspace(lo, hi, parts + 1).round().astype(int)]


def _render_piece(world: World, piece: _Piece, view: list[float],
                  limit: tuple[int, int] | None) -> np.ndarray:
    """The piece's rows and columns of its face's tile, in as few exact renders as fit."""
    n = piece.tile_px
    t = piece.half_tan * n / piece.face_px  # tangent half-extent of the whole tile
    (r0, r1), (c0, c1) = piece.rows, piece.cols
    max_w, max_h = limit if limit is not None else (None, None)
    row_edges, col_edges = _edges(r0, r1, max_h), _edges(c0, c1, max_w)
    if piece.whole and len(row_edges) == len(col_edges) == 2:  # one symmetric render
        fov_deg = math.degrees(2.0 * math.atan(t))
        return world.render(n, n, view, _perspective(fov_deg, _NEAR_M, _FAR_M))
    out = np.empty((r1 - r0, c1 - c0, 3), np.uint8)
    for ra, rb in itertools.pairwise(row_edges):
        for ca, cb in itertools.pairwise(col_edges):
            proj = _frustum(
                _NEAR_M * t * (2 * ca / n - 1), _NEAR_M * t * (2 * cb / n - 1),
                _NEAR_M * t * (1 - 2 * rb / n), _NEAR_M * t * (1 - 2 * ra / n),
            )
            out[ra - r0:rb - r0, ca - c0:cb - c0] = world.render(cb - ca, rb - ra, view, proj)
    return out
