"""White field-line points from an omni image, on the ground in the robot frame.

The image is resampled once per frame onto a square grid of the ground around the robot
(robot frame: x forward, y left, metres), through the camera model: each cell reads the
pixel whose ray from the optical centre ``height_m`` up meets the floor z = 0 at a point of
the cell (:class:`GroundGrid`, built once per camera model; any
:class:`~estimator.camera.CameraModel` will do). That point is the cell's centre jittered
within the cell by a fixed, seeded offset: a regular lattice that a line runs along (the
robot's yaw a multiple of 45 degrees, the field's lines being axis-parallel) samples the
line at the same offsets all along it and shifts its centre by up to a third of a cell
(measured: 8 mm at 4 cm cells); jittered samples fall at every offset. On the grid a line
is ``line_width_m`` wide wherever it is, so one fixed filter finds lines near and far,
whatever the lens:

1. whiteness ``w = min(B, G, R)``: high on white, low on the green carpet and on every
   coloured thing (the orange ball and boxes, the robots' dark bodies and cyan or magenta
   bands);
2. a white top-hat ``w - open(w)`` with a square of side ``opening_m``: what is brighter
   than its surround and narrower than the square (a line) stands out, broad bright areas
   (the grey floor beyond the carpet, a goal post's wide image) and steps do not; the
   threshold ``min_contrast`` is in grey levels above the local background, so a gain
   change or uneven lighting moves line and carpet together;
3. grey, not tinted: ``max - min <= max_chroma * max`` over the channels (a blurred line's
   edge, white mixed with green, still passes);
4. only cells the camera resolves: inside the image circle, outside the robot's own
   footprint (and a mirror's own reflection) and where one pixel spans at most
   ``max_footprint_m`` of ground along the ray (beyond that a line is under two pixels
   wide and blurred into the carpet).

Each kept cell (of a checkerboard's black squares, by default: half the cells, evenly)
gives a point: the contrast-weighted centroid of the line cells' sample points in a
``centroid_cells`` square about it (on the line's centre to a fraction of a cell), with a
standard deviation ``sigma_m`` that grows with the ground one pixel covers there. What
stands above the floor is mapped as if it lay on it (a goal post becomes a streak pointing
away from the robot); the pose fit keeps only points that fall on the field under the prior
pose and weighs down what is far from every line, so such points and the lines hidden by
robots do no harm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from estimator.camera import CameraModel, ground_range_m
from estimator.errors import LocalisationError

__all__ = ["GroundGrid", "LinePointParams", "LinePoints", "detect_line_points"]

FloatArray = NDArray[np.float64]
JITTER_SEED = 20240


@dataclass(frozen=True)
class LinePointParams:
    """How line points are found (defaults chosen on the tuning logs, docs/method.md)."""

    cell_m: float = 0.04
    """Ground grid step [m]."""
    max_range_m: float = 9.0
    """Cells further than this from the robot are not used [m]."""
    max_footprint_m: float = 0.09
    """Largest ground length one pixel may span along the ray [m]."""
    body_half_size_m: float = 0.245
    """Half the side of the robot's square footprint [m]: its own body hides the ground."""
    body_margin_m: float = 0.06
    """Ground kept clear around the robot's footprint [m]."""
    rim_margin_px: float = 4.0
    """Pixels kept clear inside the image circle's rim."""
    opening_m: float = 0.32
    """Side of the top-hat's square [m]: wider than a line, narrower than a wide white area."""
    min_contrast: float = 40.0
    """Least whiteness above the local background [grey levels]."""
    max_chroma: float = 0.35
    """Largest (max - min) / max over the colour channels."""
    base_sigma_m: float = 0.04
    """A point's standard deviation from the line's width and the cell's size [m]."""
    jitter: bool = True
    """Each cell samples the ground at a point jittered within it (seeded, fixed): a
    regular lattice aligned with a line (the robot's yaw a multiple of 45 deg) samples
    it at the same offsets all along and biases its centre by up to a third of a cell;
    jittered samples fall at every offset."""
    centroid_cells: int = 5
    """Each point is put at the contrast-weighted centroid of the line cells in this many
    cells square about it (1: the cell's centre): on the line's centre, to a fraction of
    a cell."""
    checkerboard: bool = True
    """Keep only the cells with an even row + column: half the points (half the fit's
    cost), spread evenly, so every line keeps points across its whole width."""

    def __post_init__(self) -> None:
        if not (self.cell_m > 0 and self.max_range_m > 0 and self.max_footprint_m > 0
                and self.opening_m > 2 * self.cell_m and self.base_sigma_m > 0
                and self.centroid_cells >= 1):
            raise LocalisationError(f"bad line point parameters: {self}")


@dataclass(frozen=True, eq=False)
class GroundGrid:
    """The remap tables from the omni image onto the ground grid, built once per camera."""

    map1: NDArray[np.int16]
    map2: NDArray[np.uint16]
    """Fixed-point tables for ``cv2.remap`` (``cv2.convertMaps``)."""
    valid: NDArray[np.bool_]
    """(rows, cols): cells the camera resolves (see the module docstring)."""
    x_m: FloatArray
    """(rows, cols): the forward coordinate [m] of the ground point each cell samples (its
    centre, jittered within the cell)."""
    y_m: FloatArray
    """(rows, cols): the leftward coordinate [m] of that point."""
    sigma_m: FloatArray
    """(rows, cols): a point's standard deviation there [m]."""
    image_shape: tuple[int, int]
    """(height, width) of the images the tables read."""
    params: LinePointParams
    pointed: NDArray[np.bool_]
    """(rows, cols): the cells that give a point when they are line cells (of the
    checkerboard's black squares when ``checkerboard``, else all)."""
    chroma_limit: NDArray[np.uint8]
    """(256,): the most ``max - min`` a cell whose brightest channel is ``max`` may have,
    ``floor(max_chroma * max)`` (a lookup table: the same test in integers)."""
    padded_xy: tuple[FloatArray, FloatArray]
    """:attr:`x_m` and :attr:`y_m` grown by half a centroid window of zeros on every side,
    flattened: where each frame's centroids read their windows' positions."""

    @classmethod
    def build(cls, camera: CameraModel, params: LinePointParams | None = None) -> GroundGrid:
        """The grid of ``camera`` (with ``params``' step, range and resolution limits)."""
        p = params or LinePointParams()
        reach = _reach_m(camera, p)
        half = max(1, math.ceil(reach / p.cell_m))
        c = (np.arange(2 * half + 1) - half) * p.cell_m
        x = np.repeat(-c[:, None], len(c), axis=1)  # row 0 forward (image up)
        y = np.repeat(-c[None, :], len(c), axis=0)  # column 0 left (image left)
        if p.jitter:  # a fixed, seeded jitter: the same grid every time
            shake = np.random.default_rng(JITTER_SEED).uniform(-0.5, 0.5, (2, *x.shape))
            x, y = x + shake[0] * p.cell_m, y + shake[1] * p.cell_m
        rng = np.hypot(x, y)
        rays = np.stack([x, y, np.full_like(x, -camera.height_m)], axis=-1)
        uv = np.asarray(camera.ray_to_pixel(rays), dtype=np.float64)
        du, dv = uv[..., 0] - camera.centre_px[0], uv[..., 1] - camera.centre_px[1]
        r_px = np.hypot(du, dv)
        footprint = _footprint_m(camera, r_px)
        clear = p.body_half_size_m + p.body_margin_m
        valid = (np.isfinite(r_px) & (r_px <= camera.max_radius_px - p.rim_margin_px)
                 & (rng <= min(reach, p.max_range_m)) & (footprint <= p.max_footprint_m)
                 & ((np.abs(x) > clear) | (np.abs(y) > clear)))
        self_radius = float(getattr(camera, "self_radius_px", 0.0))
        valid &= r_px > self_radius + p.rim_margin_px
        map1, map2 = _point_maps(uv, valid)
        sigma = np.sqrt(p.base_sigma_m**2 + np.where(valid, footprint, 0.0) ** 2)
        pointed = np.ones_like(valid)
        if p.checkerboard:
            pointed[0::2, 1::2] = False
            pointed[1::2, 0::2] = False
        limit = np.floor(p.max_chroma * np.arange(256.0)).clip(0, 255).astype(np.uint8)
        half = p.centroid_cells // 2
        padded = (np.pad(x, half).ravel(), np.pad(y, half).ravel())
        return cls(map1, map2, valid, x, y, sigma, (camera.height_px, camera.width_px), p,
                   pointed, limit, padded)


def _point_maps(uv: FloatArray, valid: NDArray[np.bool_]) -> tuple[NDArray[np.int16],
                                                                   NDArray[np.uint16]]:
    """Remap tables reading each valid cell's pixel ``uv``; invalid cells read black."""
    mx = np.where(valid, uv[..., 0], -1000.0).astype(np.float32)
    my = np.where(valid, uv[..., 1], -1000.0).astype(np.float32)
    fixed, frac = cv2.convertMaps(mx, my, cv2.CV_16SC2)
    return np.asarray(fixed, np.int16), np.asarray(frac, np.uint16)


def _footprint_m(camera: CameraModel, r_px: FloatArray) -> FloatArray:
    """Ground length [m] one pixel spans along the ray at pixel radius ``r_px``."""
    lo = ground_range_m(camera, np.maximum(np.nan_to_num(r_px, nan=0.0) - 0.5, 0.0))
    hi = ground_range_m(camera, np.nan_to_num(r_px, nan=0.0) + 0.5)
    with np.errstate(invalid="ignore"):
        out = np.abs(hi - lo)
    return np.where(np.isfinite(out) & np.isfinite(r_px), out, np.inf)


def _reach_m(camera: CameraModel, p: LinePointParams) -> float:
    """The furthest range the camera resolves within the limits [m] (the grid's half side)."""
    r = np.linspace(0.0, camera.max_radius_px - p.rim_margin_px, 2048)
    d = ground_range_m(camera, r)
    ok = np.isfinite(d) & (_footprint_m(camera, r) <= p.max_footprint_m)
    if not ok.any():
        raise LocalisationError(f"camera {camera.name!r} resolves no ground within the limits")
    return float(min(d[ok].max(), p.max_range_m))


@dataclass(frozen=True, eq=False)
class LinePoints:
    """White line points on the ground in the robot frame (x forward, y left) [m]."""

    xy_m: FloatArray
    """(N, 2)."""
    sigma_m: FloatArray
    """(N,): each point's standard deviation [m]."""
    contrast: FloatArray
    """(N,): whiteness above the local background [grey levels]."""

    def __len__(self) -> int:
        return len(self.xy_m)


def line_mask(image_bgr: NDArray[np.uint8], grid: GroundGrid) -> tuple[
        NDArray[np.bool_], NDArray[np.uint8]]:
    """The line cells of the ground grid and their top-hat contrast (grey levels)."""
    if image_bgr.ndim != 3 or image_bgr.shape[:2] != grid.image_shape:
        raise LocalisationError(f"image of shape {image_bgr.shape}, the camera's is "
                         f"{grid.image_shape} x 3")
    p = grid.params
    ground = cv2.remap(image_bgr, grid.map1, grid.map2, cv2.INTER_LINEAR,
                       borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0))
    b, g, r = cv2.split(ground)
    lo = cv2.min(cv2.min(b, g), r)
    hi = cv2.max(cv2.max(b, g), r)
    side = max(3, 2 * round(p.opening_m / p.cell_m / 2) + 1)
    kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (side, side))
    tophat = np.asarray(cv2.morphologyEx(lo, cv2.MORPH_TOPHAT, kernel), np.uint8)
    grey = cv2.subtract(hi, lo) <= cv2.LUT(hi, grid.chroma_limit)
    mask = grid.valid & grey & (tophat >= p.min_contrast)
    return mask, tophat


def _centroids(mask: NDArray[np.bool_], tophat: NDArray[np.uint8], grid: GroundGrid,
               cells: NDArray[np.intp]) -> FloatArray:
    """(N, 2) [m]: the contrast-weighted centroid of the line cells' positions in a
    ``centroid_cells`` square window about each of ``cells`` (flat, row-major indices).
    Summed over each window's cells alone (read from the grid padded by the window's half
    side), not filtered over the whole grid: a frame has a few thousand points and a
    hundred thousand cells."""
    side = grid.params.centroid_cells
    half = side // 2
    rows, cols = mask.shape
    wide = cols + 2 * half
    t = np.zeros((rows + 2 * half, wide))
    np.multiply(tophat, mask, out=t[half:half + rows, half:half + cols], casting="unsafe")
    ring = (np.arange(-half, side - half)[:, None] * wide + np.arange(-half, side - half)).ravel()
    at = ((cells // cols + half) * wide + cells % cols + half)[:, None] + ring
    w = t.ravel().take(at)
    x, y = grid.padded_xy
    s0 = np.einsum("ij->i", w)
    return np.stack([np.einsum("ij,ij->i", w, x.take(at)) / s0,
                     np.einsum("ij,ij->i", w, y.take(at)) / s0], axis=1)


def detect_line_points(image_bgr: NDArray[np.uint8], grid: GroundGrid) -> LinePoints:
    """The white line points of one omni image (BGR, the camera's size), robot frame."""
    p = grid.params
    mask, tophat = line_mask(image_bgr, grid)
    keep = mask & grid.pointed
    # flat, row-major indices: a fixed order, whatever the threads (and several times
    # cheaper than np.nonzero's row and column arrays)
    cells = np.flatnonzero(keep)
    if p.centroid_cells > 1 and len(cells):
        xy = _centroids(mask, tophat, grid, cells)
    else:
        xy = np.stack([grid.x_m.ravel()[cells], grid.y_m.ravel()[cells]], axis=1)
    return LinePoints(xy, grid.sigma_m.ravel()[cells].astype(np.float64),
                      tophat.ravel()[cells].astype(np.float64))
