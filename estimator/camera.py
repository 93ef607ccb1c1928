"""Omnidirectional camera models: pixel <-> ray, behind the ``CameraModel`` protocol.

Conventions (docs/api.md, stated once here):

- Robot frame: x forward, y left, z up. A ray is a unit vector from the camera's optical
  centre, which sits ``height_m`` above the ground on the robot's vertical axis.
- Pixel (u, v) = (column, row), origin top-left, pixel index i has coordinate i.
  With du = u - cu, dv = v - cv: radius ``r = hypot(du, dv)`` and bearing in the robot
  frame ``theta = atan2(-du, -dv)`` (0 = forward = image up, +pi/2 = left = image left).
- Every model is radially symmetric: a pixel radius maps to a *nadir angle* (angle between
  the ray and straight down) and the bearing is kept, so

      ray = (sin(n) cos(theta), sin(n) sin(theta), -cos(n)),   n = nadir_angle_rad(r).

Models:

- ``ideal``: the paper's "ideal calibrated image": the ground distance of the point a ray
  hits on z = 0 is linear in r, d = k * r. k is chosen so that the ball's *centre* (0.11 m
  above the ground) 8.4 m away appears at r = 499 px, as in the paper's worked example:
  k = 8.4 m * h / (h - 0.11 m) / 499 px. A ground-linear mapping stretches anything above
  the ground radially by about h / (h - z): from a real robot's height (0.85 m) a ball 8 m
  away would be a streak 100 px long, half outside the image. So the ideal camera is an
  idealised top-down view from a virtual optical centre ``height_m`` = 12 m above the
  robot's centre, where the ball stays round (stretch 1.02) and the range is linear in r.
- ``fisheye``: equidistant lens looking down, n = r / f with f = r_max / (pi/2).
- ``mirror``: catadioptric (NuBot's form): ground distance d = a * tan(b * r); the horizon
  is at r = pi / (2 b). Pixels inside ``self_radius_px`` show the camera's own reflection.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from estimator.constants import BALL_RADIUS_M, PAPER_CENTRE_PX, PAPER_IMAGE_SIZE_PX

__all__ = [
    "CAMERA_MODELS",
    "CameraModel",
    "FisheyeCamera",
    "IdealCamera",
    "MirrorCamera",
    "ball_image_area_px",
    "ball_outline_px",
    "camera_from_dict",
    "ground_range_m",
    "make_camera",
]

CAMERA_MODELS = ("ideal", "fisheye", "mirror")
"""Names accepted by :func:`make_camera` and the ``model`` key of :func:`camera_from_dict`."""

FloatArray = NDArray[np.float64]


@runtime_checkable
class CameraModel(Protocol):
    """A radially symmetric omni camera: pixel <-> unit ray in the robot frame."""

    @property
    def name(self) -> str: ...
    @property
    def width_px(self) -> int: ...
    @property
    def height_px(self) -> int: ...
    @property
    def centre_px(self) -> tuple[float, float]: ...
    @property
    def height_m(self) -> float: ...
    @property
    def max_radius_px(self) -> float: ...

    def nadir_angle_rad(self, r_px: ArrayLike) -> FloatArray:
        """Angle between the ray of pixel radius ``r_px`` and straight down (NaN if none)."""
        ...

    def radius_px(self, nadir_angle_rad: ArrayLike) -> FloatArray:
        """Inverse of :meth:`nadir_angle_rad` (NaN where the model has no pixel)."""
        ...

    def pixel_to_ray(self, u: ArrayLike, v: ArrayLike) -> FloatArray:
        """Unit rays (..., 3) in the robot frame for pixels (u, v)."""
        ...

    def ray_to_pixel(self, rays: ArrayLike) -> FloatArray:
        """Pixels (..., 2) as (u, v) for rays (..., 3) in the robot frame (any length)."""
        ...

    def to_dict(self) -> dict[str, Any]:
        """Parameters as a JSON-able dict with a ``"model"`` key."""
        ...


@dataclass(frozen=True)
class _RadialCamera:
    """Shared image geometry and pixel <-> ray code; subclasses define the radial law
    (and their own ``height_m`` and ``name``)."""

    width_px: int = PAPER_IMAGE_SIZE_PX
    height_px: int = PAPER_IMAGE_SIZE_PX
    cu_px: float = PAPER_CENTRE_PX[0]
    cv_px: float = PAPER_CENTRE_PX[1]
    max_radius_px: float = PAPER_CENTRE_PX[0]
    """Radius of the image circle [px]; by default it touches the image's edges."""
    height_m: float = 0.85
    """Optical centre above the ground [m] (a subclass may set its own default)."""
    name: str = ""

    @property
    def centre_px(self) -> tuple[float, float]:
        return (self.cu_px, self.cv_px)

    def nadir_angle_rad(self, r_px: ArrayLike) -> FloatArray:  # pragma: no cover - abstract
        raise NotImplementedError

    def radius_px(self, nadir_angle_rad: ArrayLike) -> FloatArray:  # pragma: no cover
        raise NotImplementedError

    def to_dict(self) -> dict[str, Any]:
        """The model's fields (every subclass is a dataclass) and its ``"model"`` name."""
        d: dict[str, Any] = {"model": self.name}
        d.update({k: v for k, v in asdict(self).items() if k != "name"})
        return d

    def pixel_to_ray(self, u: ArrayLike, v: ArrayLike) -> FloatArray:
        du = np.asarray(u, dtype=np.float64) - self.cu_px
        dv = np.asarray(v, dtype=np.float64) - self.cv_px
        r = np.hypot(du, dv)
        theta = np.arctan2(-du, -dv)
        n = self.nadir_angle_rad(r)
        s = np.sin(n)
        return np.stack([s * np.cos(theta), s * np.sin(theta), -np.cos(n)], axis=-1)

    def ray_to_pixel(self, rays: ArrayLike) -> FloatArray:
        d = np.asarray(rays, dtype=np.float64)
        x, y, z = d[..., 0], d[..., 1], d[..., 2]
        n = np.arctan2(np.hypot(x, y), -z)
        theta = np.arctan2(y, x)
        r = self.radius_px(n)
        return np.stack([self.cu_px - r * np.sin(theta), self.cv_px - r * np.cos(theta)], axis=-1)


@dataclass(frozen=True)
class IdealCamera(_RadialCamera):
    """Ground distance linear in pixel radius: d = k * r (the paper's ideal image)."""

    k_m_per_px: float = 8.4 * 12.0 / (12.0 - BALL_RADIUS_M) / 499.0
    height_m: float = 12.0
    name: str = "ideal"

    def nadir_angle_rad(self, r_px: ArrayLike) -> FloatArray:
        r = np.asarray(r_px, dtype=np.float64)
        return np.arctan2(self.k_m_per_px * r, self.height_m)

    def radius_px(self, nadir_angle_rad: ArrayLike) -> FloatArray:
        n = np.asarray(nadir_angle_rad, dtype=np.float64)
        ok = (n >= 0) & (n < math.pi / 2)
        with np.errstate(invalid="ignore", divide="ignore"):
            r = self.height_m * np.tan(np.where(ok, n, 0.0)) / self.k_m_per_px
        return np.where(ok, r, np.nan)


@dataclass(frozen=True)
class FisheyeCamera(_RadialCamera):
    """Equidistant fisheye looking down: n = r / f, r = max_radius_px <-> 90 deg."""

    fov_deg: float = 180.0
    name: str = "fisheye"

    @property
    def f_px_per_rad(self) -> float:
        return self.max_radius_px / math.radians(self.fov_deg / 2.0)

    def nadir_angle_rad(self, r_px: ArrayLike) -> FloatArray:
        return np.asarray(r_px, dtype=np.float64) / self.f_px_per_rad

    def radius_px(self, nadir_angle_rad: ArrayLike) -> FloatArray:
        n = np.asarray(nadir_angle_rad, dtype=np.float64)
        return np.where(n >= 0, n * self.f_px_per_rad, np.nan)


@dataclass(frozen=True)
class MirrorCamera(_RadialCamera):
    """Catadioptric camera: ground distance d = a * tan(b * r) (NuBot's form).

    With a = 1.2 m and b = pi / 1100 rad/px the horizon is at r = 550 px (just outside the
    539 px image circle) and r = 500 px sees the ground 8.4 m away. Pixels with
    r < ``self_radius_px`` show the camera's own reflection (black in the rendered image).
    """

    a_m: float = 1.2
    b_rad_per_px: float = math.pi / 1100.0
    self_radius_px: float = 30.0
    name: str = "mirror"

    @property
    def horizon_px(self) -> float:
        return math.pi / (2.0 * self.b_rad_per_px)

    def nadir_angle_rad(self, r_px: ArrayLike) -> FloatArray:
        r = np.asarray(r_px, dtype=np.float64)
        ok = (r >= 0) & (r < self.horizon_px)
        d = self.a_m * np.tan(self.b_rad_per_px * np.where(ok, r, 0.0))
        return np.where(ok, np.arctan2(d, self.height_m), np.nan)

    def radius_px(self, nadir_angle_rad: ArrayLike) -> FloatArray:
        n = np.asarray(nadir_angle_rad, dtype=np.float64)
        ok = (n >= 0) & (n < math.pi / 2)
        d = self.height_m * np.tan(np.where(ok, n, 0.0))
        return np.where(ok, np.arctan(d / self.a_m) / self.b_rad_per_px, np.nan)


_CLASSES: dict[str, type[IdealCamera] | type[FisheyeCamera] | type[MirrorCamera]] = {
    "ideal": IdealCamera,
    "fisheye": FisheyeCamera,
    "mirror": MirrorCamera,
}


def make_camera(name: str, **params: Any) -> IdealCamera | FisheyeCamera | MirrorCamera:
    """A camera model by name (one of ``CAMERA_MODELS``) with optional parameter overrides."""
    try:
        cls = _CLASSES[name]
    except KeyError:
        raise ValueError(
            f"unknown camera model {name!r}; choose one of {', '.join(CAMERA_MODELS)}"
        ) from None
    try:
        return cls(**params)
    except TypeError as err:
        raise ValueError(f"bad parameters for camera model {name!r}: {err}") from err


def camera_from_dict(d: dict[str, Any]) -> IdealCamera | FisheyeCamera | MirrorCamera:
    """Inverse of ``to_dict()``: the ``"model"`` key names the class, the rest are fields."""
    if "model" not in d:
        raise ValueError(f"camera dict has no 'model' key: {sorted(d)}")
    params = {k: v for k, v in d.items() if k not in ("model", "name")}
    return make_camera(str(d["model"]), **params)


def ground_range_m(camera: CameraModel, r_px: ArrayLike) -> FloatArray:
    """Horizontal distance at which the ray of pixel radius ``r_px`` meets the ground z = 0."""
    n = camera.nadir_angle_rad(r_px)
    with np.errstate(invalid="ignore"):
        out = camera.height_m * np.tan(n)
    return np.where(n < math.pi / 2, out, np.inf)


_UNIT_CIRCLE: dict[int, tuple[FloatArray, FloatArray]] = {}
"""cos and sin of ``points`` angles evenly around the circle, a column each, by ``points``."""


def _unit_circle(points: int) -> tuple[FloatArray, FloatArray]:
    circle = _UNIT_CIRCLE.get(points)
    if circle is None:
        phi = np.linspace(0.0, 2.0 * math.pi, points, endpoint=False)[:, None]
        circle = _UNIT_CIRCLE[points] = (np.cos(phi), np.sin(phi))
    return circle


def ball_image_area_px(
    camera: CameraModel, range_m: float, ball_radius_m: float = BALL_RADIUS_M, *, points: int = 90
) -> float:
    """The area [px^2] of the image of a whole, unoccluded ball resting on the ground at a
    horizontal ``range_m`` from the robot: the polygon of its silhouette, the cone of rays
    tangent to the sphere, mapped through the model. NaN where the model cannot see it.

    Every model is radially symmetric, so the direction does not matter: the ball is put
    straight ahead. (Called for every estimate: the cross products are written out, the
    same float operations as ``np.cross`` without its overhead, and the circle's angles
    are kept; the bits are those of the plain numpy form.)
    """
    centre = np.array([range_m, 0.0, ball_radius_m - camera.height_m], dtype=np.float64)
    dist = float(np.linalg.norm(centre))
    if dist <= ball_radius_m:
        return math.nan
    axis = centre / dist
    x, y, z = axis.tolist()
    e1 = np.array([y * 0.0 - z * 1.0, z * 0.0 - x * 0.0, x * 1.0 - y * 0.0])  # axis x (0, 1, 0)
    e1 /= np.linalg.norm(e1)
    p, q, r = e1.tolist()
    e2 = np.array([y * r - z * q, z * p - x * r, x * q - y * p])  # axis x e1
    alpha = math.asin(ball_radius_m / dist)  # half-angle of the tangent cone
    cos_phi, sin_phi = _unit_circle(points)
    rays = math.cos(alpha) * axis + math.sin(alpha) * (cos_phi * e1 + sin_phi * e2)
    uv = np.asarray(camera.ray_to_pixel(rays), dtype=np.float64)
    if not np.all(np.isfinite(uv)):
        return math.nan
    u, v = uv[:, 0], uv[:, 1]
    u_prev, v_prev = np.concatenate((u[-1:], u[:-1])), np.concatenate((v[-1:], v[:-1]))
    return float(0.5 * abs(np.dot(u, v_prev) - np.dot(v, u_prev)))  # shoelace


def ball_outline_px(camera: CameraModel, centre_m: ArrayLike,
                    ball_radius_m: float = BALL_RADIUS_M, *, points: int = 64) -> FloatArray:
    """The outline of a ball's image: ``points`` (u, v) pixels of its silhouette, the cone
    of rays from the optical centre tangent to the sphere, mapped through the model.

    ``centre_m`` is the ball's centre (x, y, z) in the camera's frame on the ground: x
    along image up, y along image left, z up from the ground under the lens (the optical
    centre is ``height_m`` above it). Rows are NaN where the model places no pixel (above
    a lens's horizon); all NaN when the lens is inside the ball.
    """
    centre = np.asarray(centre_m, dtype=np.float64) - np.array([0.0, 0.0, camera.height_m])
    dist = float(np.linalg.norm(centre))
    if dist <= ball_radius_m:
        return np.full((points, 2), np.nan)
    axis = centre / dist
    helper = np.array([0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    alpha = math.asin(ball_radius_m / dist)
    phi = np.linspace(0.0, 2.0 * math.pi, points, endpoint=False)[:, None]
    rays = math.cos(alpha) * axis + math.sin(alpha) * (np.cos(phi) * e1 + np.sin(phi) * e2)
    return np.asarray(camera.ray_to_pixel(rays), dtype=np.float64)
