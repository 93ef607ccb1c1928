"""The images of a foreign log (:mod:`replay.evaluate.foreign`): an omnidirectional camera
of its own, numpy + OpenCV only.

The camera (:class:`OmniModel`) is a single-viewpoint catadioptric camera: the mirror's
viewpoint is ``height_m`` above the floor on the robot's axis, and a ray at the nadir angle
phi (0 straight down) shows at the pixel radius ``r = radius_px * (phi / phi_max) ** gamma``
from the image centre; with gamma > 1 the far field gets more pixels per degree, as a
hyperbolic mirror's does. The bearing follows the project's convention (image up = robot
forward, image left = robot left: ``theta = atan2(-du, -dv)``). None of the project's camera
models is this one, so its camera file describes it by a ``lookup`` calibration:
:func:`lookup_table` renders the ball at a ladder of ranges and writes down where its
centroid lands, as a team measuring its camera would, without the measuring errors. A
lookup camera names no height, so the replay has no rays to cross in 3-D; the ``mirror``
profile (NuBot's, the project's ``mirror`` model) is the camera a file can describe with its
height, for logs that test the 3-D track.

An image (:class:`Renderer`) is drawn per pixel ray:

- the carpet and the field's lines: a top-down texture of the field (:mod:`dsp.field`'s
  markings, lines 0.125 m wide, anti-aliased; a green carpet with a mild gradient and
  mottling; a grey floor beyond the carpet) sampled by ``cv2.remap`` at each pixel's
  ground point, which is an affine function of the robot's pose;
- the ball (orange, 0.22 m, Lambert-shaded) by intersecting each ray with the sphere, so a
  ball in the air shows where the mirror would show it (farther out and larger);
- the other robots as dark cylinders (0.26 m radius, 0.7 m tall) the rays pass through,
  radially long blobs as in a real omnidirectional image; nearer things over farther ones;
- the robot's own body (a dark disc in the middle), black beyond the mirror's rim, and a
  small sensor noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from dsp.field import Circle, FieldSpec, Rect, markings

__all__ = ["BALL_BGR", "OmniModel", "Renderer", "lookup_table"]

BALL_BGR = (0.0, 110.0, 255.0)
"""The ball's lit colour: hue 13 of OpenCV's 180, inside the paper's colour box (H 5-25)."""
CARPET_BGR = (50.0, 135.0, 45.0)
LINE_BGR = (228, 232, 230)
FLOOR_BGR = (92, 92, 96)
BODY_BGR = (28, 28, 30)
ROBOT_BGR = np.array([34.0, 32.0, 30.0], np.float32)
ROBOT_RADIUS_M = 0.26
ROBOT_HEIGHT_M = 0.7
TEXTURE_M_PER_PX = 0.015625
"""1/64 m: a line of 0.125 m is 8 texels."""
NOISE_SIGMA = 2.5
_LIGHT = np.array([0.3, -0.2, 1.0]) / math.sqrt(0.09 + 0.04 + 1.0)


@dataclass(frozen=True)
class OmniModel:
    """The camera (see the module docstring): pixels, mirror height, radial profile."""

    width_px: int = 640
    height_px: int = 640
    cu_px: float = 319.5
    cv_px: float = 319.5
    height_m: float = 0.8
    radius_px: float = 307.0
    """The mirror's rim: nothing shows beyond it."""
    phi_max_deg: float = 87.0
    gamma: float = 1.25
    self_radius_px: float = 58.0
    """The robot's own body hides the middle of the image."""
    profile: str = "own"
    """"own": ``r = radius_px * (phi / phi_max) ** gamma``; "mirror": NuBot's profile, the
    ground a_m * tan(b r) away (the project's ``mirror`` camera model, which a camera file
    can name with its height)."""
    a_m: float = 1.2
    b_rad_per_px: float = 0.005

    @staticmethod
    def for_size(width_px: int, height_px: int, offset_px: tuple[float, float] = (0.0, 0.0),
                 profile: str = "own") -> OmniModel:
        side = min(width_px, height_px)
        radius = 0.48 * side
        return OmniModel(width_px, height_px, (width_px - 1) / 2.0 + offset_px[0],
                         (height_px - 1) / 2.0 + offset_px[1], radius_px=radius,
                         self_radius_px=0.09 * side, profile=profile,
                         b_rad_per_px=math.pi / (2.0 * 1.03 * radius))  # horizon past the rim

    def r_px(self, phi_rad: npt.ArrayLike) -> npt.NDArray[np.float64]:
        phi = np.asarray(phi_rad, np.float64)
        if self.profile == "mirror":
            ground = self.height_m * np.tan(phi)
            return np.asarray(np.arctan(ground / self.a_m) / self.b_rad_per_px)
        return np.asarray(self.radius_px * (phi / math.radians(self.phi_max_deg)) ** self.gamma)

    def phi_rad(self, r_px: npt.ArrayLike) -> npt.NDArray[np.float64]:
        r = np.asarray(r_px, np.float64)
        if self.profile == "mirror":
            b_r = np.minimum(self.b_rad_per_px * r, 0.5 * math.pi - 1e-6)
            return np.asarray(np.arctan2(self.a_m * np.tan(b_r), self.height_m))
        return np.asarray(math.radians(self.phi_max_deg) * (r / self.radius_px) ** (
            1.0 / self.gamma))

    def rad_per_px(self, r_px: float) -> float:
        """The nadir angle one pixel spans radially at ``r_px`` (a central difference)."""
        r = max(r_px, 1.0)
        return float(self.phi_rad(r + 0.5) - self.phi_rad(r - 0.5))


class _Rays:
    """Every pixel's ray, in the robot frame: azimuth, nadir angle, ground point."""

    def __init__(self, model: OmniModel) -> None:
        v, u = np.mgrid[0:model.height_px, 0:model.width_px].astype(np.float64)
        du, dv = u - model.cu_px, v - model.cv_px
        r = np.hypot(du, dv)
        theta = np.arctan2(-du, -dv)
        phi = np.minimum(model.phi_rad(r), math.radians(89.0))
        self.cos_t, self.sin_t = np.cos(theta), np.sin(theta)
        self.cos_p, self.sin_p = np.cos(phi), np.sin(phi)
        self.tan_p = np.tan(phi)
        ground = model.height_m * self.tan_p
        self.gx = (ground * self.cos_t).astype(np.float32)
        self.gy = (ground * self.sin_t).astype(np.float32)
        self.hidden = ((r < model.self_radius_px) | (r > model.radius_px)).astype(np.uint8)
        overlay = np.zeros((model.height_px, model.width_px, 3), np.uint8)
        overlay[r < model.self_radius_px] = BODY_BGR
        self.overlay = overlay


def field_texture(field: FieldSpec, rng: np.random.Generator) -> npt.NDArray[np.uint8]:
    """The carpet (to the border) with its lines, top-down, :data:`TEXTURE_M_PER_PX` a texel;
    x to the right, y up; the carpet's corner (-hl - border, hw + border) at texel (0, 0)."""
    res = TEXTURE_M_PER_PX
    half_x, half_y = field.half_length_m + field.border_m, field.half_width_m + field.border_m
    w, h = round(2 * half_x / res), round(2 * half_y / res)
    mottle = cv2.resize(rng.normal(0.0, 1.0, (h // 64 + 2, w // 64 + 2)).astype(np.float32),
                        (w, h), interpolation=cv2.INTER_CUBIC)
    gradient = np.linspace(0.93, 1.07, w, dtype=np.float32)[None, :]
    shade = (gradient * (1.0 + 0.04 * mottle))[..., None]
    grain = rng.normal(0.0, 3.0, (h, w, 1)).astype(np.float32)
    img = np.clip(np.array(CARPET_BGR, np.float32) * shade + grain, 0, 255).astype(np.uint8)

    def px(x: float, y: float) -> tuple[int, int]:  # field metres -> texel, 1/16 px
        return round(((x + half_x) / res - 0.5) * 16), round(((half_y - y) / res - 0.5) * 16)

    width = round(field.line_width_m / res)
    for m in markings(field):
        if isinstance(m, Circle):
            cv2.circle(img, px(m.x, m.y), round(m.radius_m / res * 16), LINE_BGR,
                       -1 if m.filled else width, cv2.LINE_AA, 4)
        else:
            corners = ([(m.x0, m.y0), (m.x1, m.y0), (m.x1, m.y1), (m.x0, m.y1)]
                       if isinstance(m, Rect) else [(m.x0, m.y0), (m.x1, m.y1)])
            pts = np.array([px(x, y) for x, y in corners], np.int32)
            cv2.polylines(img, [pts], isinstance(m, Rect), LINE_BGR, width, cv2.LINE_AA, 4)
    return np.asarray(img, np.uint8)


def _box(model: OmniModel, points: list[tuple[float, float]], margin: int = 2
         ) -> tuple[int, int, int, int] | None:
    """The pixel box (u0, v0, u1, v1) holding the image points (radius, azimuth), or None
    when it leaves no pixel in the image."""
    r = np.array([p[0] for p in points])
    t = np.array([p[1] for p in points])
    u, v = model.cu_px - r * np.sin(t), model.cv_px - r * np.cos(t)
    u0, v0 = max(int(u.min()) - margin, 0), max(int(v.min()) - margin, 0)
    u1 = min(int(u.max()) + margin + 1, model.width_px)
    v1 = min(int(v.max()) + margin + 1, model.height_px)
    return None if u0 >= u1 or v0 >= v1 else (u0, v0, u1, v1)


def _sector(model: OmniModel, bearing: float, half: float, r0: float, r1: float
            ) -> list[tuple[float, float]]:
    return [(r, bearing + a) for a in np.linspace(-half, half, 9) for r in (r0, r1)]


def ball_alpha(model: OmniModel, rays: _Rays, ball: tuple[float, float, float],
               radius_m: float) -> tuple[tuple[int, int, int, int], npt.NDArray[np.float32],
                                         npt.NDArray[np.float32]] | None:
    """Where the ball (its centre in the robot frame) shows: its box, the coverage of each
    pixel of it (0-1, edges soft over a pixel) and the Lambert shade there; None if unseen."""
    bx, by, bz = ball
    rho, depth = math.hypot(bx, by), model.height_m - bz
    if rho <= radius_m or depth <= radius_m:
        return None
    dist = math.hypot(rho, depth)
    phi_c, ang = math.atan2(rho, depth), math.asin(radius_m / dist)
    r_in, r_out = model.r_px(max(phi_c - ang, 0.0)), model.r_px(phi_c + ang)
    if r_in > model.radius_px:
        return None
    box = _box(model, _sector(model, math.atan2(by, bx), math.asin(radius_m / rho),
                              float(r_in), float(r_out)))
    if box is None:
        return None
    u0, v0, u1, v1 = box
    sl = np.s_[v0:v1, u0:u1]
    dx = rays.sin_p[sl] * rays.cos_t[sl]
    dy = rays.sin_p[sl] * rays.sin_t[sl]
    dz = -rays.cos_p[sl]
    wz = bz - model.height_m
    t = bx * dx + by * dy + wz * dz
    d2 = np.maximum(bx * bx + by * by + wz * wz - t * t, 0.0)
    footprint = dist * model.rad_per_px(float(model.r_px(phi_c)))
    alpha = np.clip(0.5 + (radius_m - np.sqrt(d2)) / footprint, 0.0, 1.0) * (t > 0)
    t_hit = t - np.sqrt(np.maximum(radius_m * radius_m - d2, 0.0))
    nx = (t_hit * dx - bx) / radius_m
    ny = (t_hit * dy - by) / radius_m
    nz = (model.height_m + t_hit * dz - bz) / radius_m
    lit = np.clip(nx * _LIGHT[0] + ny * _LIGHT[1] + nz * _LIGHT[2], 0.0, 1.0)
    return box, alpha.astype(np.float32), (0.55 + 0.45 * lit).astype(np.float32)


def robot_mask(model: OmniModel, rays: _Rays, x: float, y: float
               ) -> tuple[tuple[int, int, int, int], npt.NDArray[np.bool_]] | None:
    """The pixels whose rays pass through a robot standing at (x, y) (robot frame)."""
    d = math.hypot(x, y)
    if d <= ROBOT_RADIUS_M + 0.3:
        return None
    near = max(d - ROBOT_RADIUS_M, 0.05)
    r0 = float(model.r_px(math.atan2(near, model.height_m)))
    if r0 > model.radius_px:
        return None
    beta = math.atan2(y, x)
    box = _box(model, _sector(model, beta, math.asin(ROBOT_RADIUS_M / d) + 0.01, r0,
                              model.radius_px))
    if box is None:
        return None
    u0, v0, u1, v1 = box
    sl = np.s_[v0:v1, u0:u1]
    cos_q = rays.cos_t[sl] * math.cos(beta) + rays.sin_t[sl] * math.sin(beta)
    sin_q = rays.sin_t[sl] * math.cos(beta) - rays.cos_t[sl] * math.sin(beta)
    perp, along = d * sin_q, d * cos_q
    half = np.sqrt(np.maximum(ROBOT_RADIUS_M ** 2 - perp * perp, 0.0))
    tan_p = rays.tan_p[sl]
    hit = ((np.abs(perp) < ROBOT_RADIUS_M) & (along > 0)
           & (along - half <= model.height_m * tan_p)
           & (along + half >= (model.height_m - ROBOT_HEIGHT_M) * tan_p))
    return box, hit


def lookup_table(model: OmniModel, radius_m: float, step_px: float = 2.0
                 ) -> tuple[list[float], list[float]]:
    """The camera's calibration as a team would measure it: (centroid radius [px], range of
    the ball's centre [m]) of a ball on the floor at a ladder of ranges, each centroid the
    coverage-weighted mean of its pixels over four bearings."""
    rays = _Rays(model)
    r_px: list[float] = []
    d_m: list[float] = []
    for r in np.arange(model.self_radius_px + 6.0, model.radius_px - 4.0, step_px):
        rng_m = (model.height_m - radius_m) * math.tan(float(model.phi_rad(r)))
        radii = []
        for bearing in (0.0, 0.5 * math.pi, math.pi, -0.5 * math.pi):
            seen = ball_alpha(model, rays, (rng_m * math.cos(bearing),
                                            rng_m * math.sin(bearing), radius_m), radius_m)
            if seen is None:
                break
            (u0, v0, u1, v1), alpha, _ = seen
            v, u = np.mgrid[v0:v1, u0:u1]
            total = float(alpha.sum())
            radii.append(math.hypot(float((alpha * u).sum()) / total - model.cu_px,
                                    float((alpha * v).sum()) / total - model.cv_px))
        if len(radii) == 4 and (not r_px or np.mean(radii) > r_px[-1] + 1e-6):
            r_px.append(round(float(np.mean(radii)), 4))
            d_m.append(round(rng_m, 5))
    return r_px, d_m


class Renderer:
    """Draws one robot's image from the scene at one instant (see the module docstring)."""

    def __init__(self, model: OmniModel, field: FieldSpec, rng: np.random.Generator) -> None:
        self.model = model
        self.rays = _Rays(model)
        self.field = field
        self.texture = field_texture(field, rng)
        side = (model.height_px + 16, model.width_px + 16, 3)
        self.noise = np.clip(rng.normal(0.0, NOISE_SIGMA, side), -60, 60).astype(np.int16)
        self._half = (field.half_length_m + field.border_m, field.half_width_m + field.border_m)

    def _ground(self, x: float, y: float, yaw: float) -> npt.NDArray[np.uint8]:
        """The carpet, lines and floor under every ray of a robot at (x, y, yaw)."""
        res, (hx, hy) = TEXTURE_M_PER_PX, self._half
        c, s = math.cos(yaw), math.sin(yaw)
        map_x = cv2.addWeighted(self.rays.gx, c / res, self.rays.gy, -s / res,
                                (x + hx) / res - 0.5)
        map_y = cv2.addWeighted(self.rays.gx, -s / res, self.rays.gy, -c / res,
                                (hy - y) / res - 0.5)
        return np.asarray(cv2.remap(self.texture, map_x, map_y, cv2.INTER_LINEAR,
                                    borderMode=cv2.BORDER_CONSTANT, borderValue=FLOOR_BGR),
                          np.uint8)

    def render(self, pose: tuple[float, float, float], ball: tuple[float, float, float],
               others: list[tuple[float, float]], rng: np.random.Generator,
               radius_m: float) -> npt.NDArray[np.uint8]:
        """The BGR image of a robot at ``pose`` (x, y, yaw) seeing the ball's centre ``ball``
        and the robots at ``others`` (field frame)."""
        x, y, yaw = pose
        img = self._ground(x, y, yaw)
        c, s = math.cos(yaw), math.sin(yaw)

        def local(px: float, py: float) -> tuple[float, float]:
            return c * (px - x) + s * (py - y), -s * (px - x) + c * (py - y)

        bl = (*local(ball[0], ball[1]), ball[2])
        things = [(math.hypot(*local(ox, oy)), 0, local(ox, oy)) for ox, oy in others]
        things.append((math.hypot(bl[0], bl[1]), 1, bl[:2]))
        for _, kind, (lx, ly) in sorted(things, reverse=True):  # farthest first
            if kind == 1:
                self._draw_ball(img, bl, radius_m)
            elif (hit := robot_mask(self.model, self.rays, lx, ly)) is not None:
                (u0, v0, u1, v1), mask = hit
                img[v0:v1, u0:u1][mask] = ROBOT_BGR.astype(np.uint8)
        oy, ox = (int(k) for k in rng.integers(0, 16, 2))
        window = self.noise[oy:oy + self.model.height_px, ox:ox + self.model.width_px]
        img = np.asarray(cv2.add(img, window, dtype=cv2.CV_8U), np.uint8)
        return np.asarray(cv2.copyTo(self.rays.overlay, self.rays.hidden, img), np.uint8)

    def _draw_ball(self, img: npt.NDArray[np.uint8], ball: tuple[float, float, float],
                   radius_m: float) -> None:
        seen = ball_alpha(self.model, self.rays, ball, radius_m)
        if seen is None:
            return
        (u0, v0, u1, v1), alpha, shade = seen
        patch = img[v0:v1, u0:u1].astype(np.float32)
        colour = shade[..., None] * np.array(BALL_BGR, np.float32)
        a = alpha[..., None]
        img[v0:v1, u0:u1] = np.clip(patch * (1.0 - a) + colour * a + 0.5, 0, 255).astype(
            np.uint8)
