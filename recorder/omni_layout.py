"""Where an omni image's rays are rendered: the views, the part of each that is drawn, its size.

:class:`recorder.omni.OmniRenderer` renders a handful of perspective *views* from the
optical centre and remaps them into the omni image. This module plans them once per camera
model: which view serves each omni pixel, the rectangle of each view that the pixels read
(a *piece*), the piece's size in pixels and where each omni pixel reads it.

A view is a square window of its tangent plane, ``[-half_tan, half_tan]`` both ways about
its forward axis, drawn at its own resolution across and up (the pixels need not be square).
A piece is the window's rows and columns that bilinear interpolation reads, plus a margin.

Layouts:

- a camera that sees everything through the down face of a cube (the ideal camera's
  virtual view from high above) gets that one face, narrowed to its widest ray, square
  pixels, ``face_px`` across;
- any other gets a down view and four side views (forward, left, back, right) tilted down
  by up to 30 degrees, each ray served by the view it is nearest to (the down view's claim
  weighted, which moves the seam up or down). Each is one render of at most EGL's
  1024 x 768: a render has a fixed cost (about what 0.25 Mpx of drawing costs, on Mesa's
  llvmpipe) so fewer, larger pieces beat more, smaller ones. The tilt and the weight are
  picked from a small grid by that cost, on a coarse sample of the image.

Sizes: each piece is sized so that, at its coarsest omni pixel, one omni pixel spans at
least as many piece pixels, in every direction, as on the coarsest face of a cube of
``face_px`` faces; across and up are sized apart (a lens looking down compresses the
horizon radially, so a side view needs fewer rows than columns per unit of its plane).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from estimator.camera import CameraModel

__all__ = ["FACES", "MARGIN_PX", "Piece", "View", "plan"]

# name -> (view direction, up vector) in the robot frame (x forward, y left, z up)
FACES: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    "front": ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    "left": ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
    "back": ((-1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    "right": ((0.0, -1.0, 0.0), (0.0, 0.0, 1.0)),
    "down": ((0.0, 0.0, -1.0), (1.0, 0.0, 0.0)),
}
MARGIN_PX = 1
"""Pixels around a view's window (a slightly wider field of view)."""
CALL_PX = 250_000
"""What one render costs beyond its pixels, in pixels: pybullet's EGL renderer on llvmpipe
takes ~6 ms per call plus ~25 ms per Mpx of textured ground (measured on 2 cores)."""
FIT_SLACK = 1.01
"""A piece at most 1 % wider or taller than the largest exact render is shrunk to fit it:
one render instead of two, for a resolution at most 1 % lower."""
_TILTS_DEG = (0.0, 10.0, 20.0, 30.0)
_WEIGHTS = (1.0, 1.2, 1.4, 1.6, 1.8, 2.0)
_ASPECTS = tuple(float(x) for x in np.geomspace(0.3, 1.5, 33))
_SEARCH_STEP = 6
"""The layout search looks at every 6th omni pixel each way."""


@dataclass(frozen=True)
class View:
    """A perspective view from the optical centre, in the robot frame: its axis, its up
    and its right (image columns grow to the right, rows downward)."""

    name: str
    forward: np.ndarray
    up: np.ndarray
    right: np.ndarray


def _view(name: str, forward: tuple[float, ...], up: tuple[float, ...]) -> View:
    f, u = np.array(forward, float), np.array(up, float)
    return View(name, f, u, np.cross(f, u))


def _cube() -> list[View]:
    return [_view(name, f, u) for name, (f, u) in FACES.items()]


def _tilted(tilt_deg: float) -> list[View]:
    """The down view, then the four side views tilted down by ``tilt_deg``."""
    t = math.radians(tilt_deg)
    views = [_view("down", *FACES["down"])]
    for name in ("front", "left", "back", "right"):
        (fx, fy, _), _ = FACES[name]
        views.append(_view(name, (math.cos(t) * fx, math.cos(t) * fy, -math.sin(t)),
                           (math.sin(t) * fx, math.sin(t) * fy, math.cos(t))))
    return views


@dataclass(frozen=True)
class Piece:
    """The part of one view that is rendered: the view, its window (``half_tan`` = tan of
    half its field of view, both ways) drawn ``size`` = (across, up) pixels plus the
    margins, the window's rows [r0, r1) and columns [c0, c1) that the omni image reads,
    at column ``x0`` of the atlas."""

    view: View
    size: tuple[int, int]
    half_tan: float
    rows: tuple[int, int]
    cols: tuple[int, int]
    x0: int

    @property
    def tile(self) -> tuple[int, int]:
        """The whole window in pixels (across, up), margins included."""
        return self.size[0] + 2 * MARGIN_PX, self.size[1] + 2 * MARGIN_PX

    @property
    def whole(self) -> bool:
        """The whole window is rendered."""
        nx, ny = self.tile
        return self.rows == (0, ny) and self.cols == (0, nx)

    @property
    def shape(self) -> tuple[int, int]:
        """(columns, rows) rendered."""
        return self.cols[1] - self.cols[0], self.rows[1] - self.rows[0]


def _rays(cam: CameraModel, step: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rays of the omni pixels (every ``step``-th each way), their radii and validity."""
    v, u = np.mgrid[0:cam.height_px:step, 0:cam.width_px:step].astype(np.float64)
    rays = cam.pixel_to_ray(u, v)
    cu, cv_ = cam.centre_px
    r = np.hypot(u - cu, v - cv_)
    valid = (r <= cam.max_radius_px) & np.all(np.isfinite(rays), axis=-1)
    rays = np.where(valid[..., None], rays, np.array([0.0, 0.0, -1.0]))
    return rays, r, valid


def _plane(rays: np.ndarray, view: View, sel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tangent-plane coordinates (a right, b up) of the rays (0 off the selection)."""
    depth = np.where(sel, rays @ view.forward, 1.0)
    return (np.where(sel, rays @ view.right / depth, 0.0),
            np.where(sel, rays @ view.up / depth, 0.0))


def _jacobian(a: np.ndarray, b: np.ndarray, sel: np.ndarray, step: int) -> np.ndarray:
    """d(a, b) / d(u, v) per omni pixel, (4, n) = (au, av, bu, bv), over the selection
    without its edge (so seams and the image circle's rim do not count)."""
    inner = cv2.erode(sel.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    return np.stack([np.gradient(a, axis=1)[inner], np.gradient(a, axis=0)[inner],
                     np.gradient(b, axis=1)[inner], np.gradient(b, axis=0)[inner]]) / step


def _smin(jac: np.ndarray, aspect: float) -> float:
    """The smallest singular value of diag(1, aspect) @ d(a, b) / d(u, v) over the pixels:
    plane units across per omni pixel at the coarsest pixel, rows scaled by ``aspect``."""
    if jac.shape[1] == 0:
        return 0.0
    au, av, bu, bv = jac[0], jac[1], aspect * jac[2], aspect * jac[3]
    s1 = np.hypot(au + bv, av - bu) / 2
    s2 = np.hypot(au - bv, av + bu) / 2
    return float(np.min(np.abs(s1 - s2)))


def _span(lo: float, hi: float, n: int) -> tuple[int, int]:
    """Pixels [first, last + 1) that bilinear reads between coordinates lo and hi, with a
    pixel more each side for a renderer's half-pixel offset; whole if nearly all."""
    first, last = max(math.floor(lo) - 2, 0), min(math.ceil(hi) + 3, n)
    return (0, n) if last - first > 0.9 * n else (first, last)




@dataclass(frozen=True)
class Plan:
    """The pieces in atlas order, and where each omni pixel reads the atlas (``map_x``,
    ``map_y``: meaningful where ``valid``); the omni pixels' rays and radii."""

    pieces: list[Piece]
    map_x: np.ndarray
    map_y: np.ndarray
    rays: np.ndarray
    r: np.ndarray
    valid: np.ndarray


def plan(cam: CameraModel, face_px: int, limit: tuple[int, int] | None) -> Plan:
    """The views, pieces and remap tables for ``cam`` (``limit``: the largest exact render,
    (width, height), or None)."""
    rays, r, valid = _rays(cam)
    cube = _cube()
    best = _nearest(rays, cube, 1.0)
    used = sorted({int(k) for k in np.unique(best[valid])})
    if [cube[k].name for k in used] == ["down"]:
        piece, xs, ys = _one_down_face(rays, valid, cube[used[0]], face_px)
        map_x, map_y = np.zeros(valid.shape, np.float32), np.zeros(valid.shape, np.float32)
        map_x[valid], map_y[valid] = xs, ys
        return Plan([piece], map_x, map_y, rays, r, valid)
    # the bar: face pixels per omni pixel at the coarsest pixel of a face_px cube
    smin = []
    for k in used:
        sel = valid & (best == k)
        smin.append(_smin(_jacobian(*_plane(rays, cube[k], sel), sel, 1), 1.0))
    bar = face_px / 2.0 * min((m for m in smin if m > 0), default=2.0 / face_px)
    rim = valid & (cv2.erode(valid.astype(np.uint8), np.ones((3, 3), np.uint8)) == 0)
    views, weight, aspects = _search(cam, rays[rim], bar, limit)
    best = _nearest(rays, views, weight)
    map_x = np.zeros(valid.shape, np.float32)
    map_y = np.zeros(valid.shape, np.float32)
    pieces: list[Piece] = []
    x0 = 0
    for k, view in enumerate(views):
        sel = valid & (best == k)
        if not sel.any():
            continue
        a, b = _plane(rays, view, sel)
        m = _smin(_jacobian(a, b, sel, 1), aspects[k])
        piece, xs, ys = _sized(view, a[sel], b[sel], bar / m if m > 0 else face_px / 2.0,
                               aspects[k], x0, limit)
        pieces.append(piece)
        map_x[sel], map_y[sel] = xs, ys
        x0 += piece.shape[0]
    return Plan(pieces, map_x, map_y, rays, r, valid)


def _nearest(rays: np.ndarray, views: list[View], down_weight: float) -> np.ndarray:
    """Index of the view each ray is nearest to, the down view's claim weighted."""
    dots = np.stack([(rays @ v.forward) * (down_weight if v.name == "down" else 1.0)
                     for v in views], axis=-1)
    return np.asarray(np.argmax(dots, axis=-1))


def _one_down_face(rays: np.ndarray, valid: np.ndarray, face: View,
                   face_px: int) -> tuple[Piece, np.ndarray, np.ndarray]:
    """The whole down face, narrowed to the widest ray, ``face_px`` across, square pixels."""
    d = rays[valid]
    half_tan = float(np.max(np.abs(d[:, :2]) / -d[:, 2:3]))
    depth = np.where(valid, rays @ face.forward, 1.0)
    a, b = (rays @ face.right) / depth, (rays @ face.up) / depth
    scale = face_px / 2.0 / half_tan
    centre = (face_px + 2 * MARGIN_PX) / 2.0 - 0.5  # pixel i has coordinate i
    xs = (centre + a[valid] * scale).astype(np.float32)
    ys = (centre - b[valid] * scale).astype(np.float32)
    n = face_px + 2 * MARGIN_PX
    rows = _span(float(ys.min()), float(ys.max()), n)
    cols = _span(float(xs.min()), float(xs.max()), n)
    xs, ys = xs - np.float32(cols[0]), ys - np.float32(rows[0])
    return Piece(face, (face_px, face_px), half_tan, rows, cols, 0), xs, ys


def _sized(view: View, a: np.ndarray, b: np.ndarray, across: float, aspect: float, x0: int,
           limit: tuple[int, int] | None) -> tuple[Piece, np.ndarray, np.ndarray]:
    """A piece of ``view`` for the plane points (a, b) at ``across`` pixels per plane unit
    across and ``aspect`` times that up, shrunk to one render if just too big; the points'
    atlas coordinates."""
    half_tan = float(max(np.abs(a).max(), np.abs(b).max())) * 1.001
    scale = [across, across * aspect]
    while True:
        size = (max(16, math.ceil(2 * half_tan * scale[0])),
                max(16, math.ceil(2 * half_tan * scale[1])))
        nx, ny = size[0] + 2 * MARGIN_PX, size[1] + 2 * MARGIN_PX
        xs = (nx / 2.0 - 0.5 + a * (size[0] / 2.0 / half_tan)).astype(np.float32)
        ys = (ny / 2.0 - 0.5 - b * (size[1] / 2.0 / half_tan)).astype(np.float32)
        cols = _span(float(xs.min()), float(xs.max()), nx)
        rows = _span(float(ys.min()), float(ys.max()), ny)
        over = [] if limit is None else [
            (i, extent / lim) for i, (extent, lim) in
            enumerate(((cols[1] - cols[0], limit[0]), (rows[1] - rows[0], limit[1])))
            if lim < extent <= FIT_SLACK * lim]
        if not over:
            break
        for i, ratio in over:  # just too big: shrink to fit (a pixel more each round)
            scale[i] = scale[i] / ratio - 1.0 / (2 * half_tan)
    piece = Piece(view, size, half_tan, rows, cols, x0)
    return piece, xs + np.float32(x0 - cols[0]), ys - np.float32(rows[0])


def _search(cam: CameraModel, rim: np.ndarray, bar: float,
            limit: tuple[int, int] | None) -> tuple[list[View], float, list[float]]:
    """The tilt and down weight (from a small grid) and each view's aspect whose pieces
    cost least to render, counting each render as CALL_PX pixels more. The omni image is
    sampled on a coarse grid, and along its rim (the ``rim`` rays: a side view's widest
    rays are there)."""
    rays, _, valid = _rays(cam, _SEARCH_STEP)
    best_cost, choice = math.inf, None
    for tilt in _TILTS_DEG:
        views = _tilted(tilt)
        for weight in _WEIGHTS:
            nearest = _nearest(rays, views, weight)
            rim_nearest = _nearest(rim, views, weight)
            cost, aspects = 0.0, []
            for k, view in enumerate(views):
                sel = valid & (nearest == k)
                view_cost, aspect = _cheapest(view, rays, sel, rim[rim_nearest == k], bar,
                                              limit)
                cost += view_cost
                aspects.append(aspect)
            if cost < best_cost:
                best_cost, choice = cost, (views, weight, aspects)
    assert choice is not None
    return choice


def _cheapest(view: View, rays: np.ndarray, sel: np.ndarray, rim: np.ndarray, bar: float,
              limit: tuple[int, int] | None) -> tuple[float, float]:
    """The cost of the view's cheapest piece (0 if it serves nothing) and its aspect: the
    Jacobian from the grid's rays ``rays[sel]``, the extent from those and ``rim``."""
    if not sel.any():
        return 0.0, 1.0
    a, b = _plane(rays, view, sel)
    jac = _jacobian(a, b, sel, _SEARCH_STEP)
    depth = rim @ view.forward
    a = np.concatenate([a[sel], rim @ view.right / depth])
    b = np.concatenate([b[sel], rim @ view.up / depth])
    best = (math.inf, 1.0)
    for aspect in _ASPECTS:
        m = _smin(jac, aspect)
        if m <= 0:
            continue
        piece, _, _ = _sized(view, a, b, bar / m, aspect, 0, limit)
        cols, rows = piece.shape
        renders = 1 if limit is None else -(-cols // limit[0]) * -(-rows // limit[1])
        best = min(best, (cols * rows + CALL_PX * renders, aspect))
    return best
