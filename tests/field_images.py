"""Omni images of the bare carpet drawn without pybullet, for the field-line tests.

Every pixel's ray (the camera model) meets the floor at a point whose colour is read from
the recorder's own carpet texture (:func:`recorder.field.field_texture`: the lines exactly
where :mod:`dsp.field` puts them); above the horizon the hall is grey. No robots or goals
stand on it, so these images test the geometry and the failure logic; the recorded logs of
docs/method.md test the rest.
"""

from __future__ import annotations

import math
from functools import cache

import cv2
import numpy as np

from dsp.field import FIELDS, Circle, FieldSpec, Rect, Segment, markings
from estimator.camera import CameraModel
from estimator.geometry import RobotPose
from estimator.localisation import FieldLines
from recorder.field import TEXTURE_PX_PER_M, field_texture

__all__ = ["field_lines", "render_carpet"]


def field_lines(spec: FieldSpec) -> FieldLines:
    """The localisation's model of ``spec`` (as replay builds it)."""
    rects, segs, circles, marks = [], [], [], []
    for m in markings(spec):
        if isinstance(m, Rect):
            rects.append((m.x0, m.y0, m.x1, m.y1))
        elif isinstance(m, Segment):
            segs.append((m.x0, m.y0, m.x1, m.y1))
        elif isinstance(m, Circle):
            (marks if m.filled else circles).append((m.x, m.y, m.radius_m))
    return FieldLines.from_shapes(half_length_m=spec.half_length_m,
                                  half_width_m=spec.half_width_m, rects=rects, segments=segs,
                                  circles=circles, marks=marks, line_width_m=spec.line_width_m)


@cache
def _texture(name: str) -> np.ndarray:
    return field_texture(FIELDS[name])


def render_carpet(camera: CameraModel, pose: RobotPose, *, field: str = "18x12",
                  noise: float = 3.0, seed: int = 0) -> np.ndarray:
    """The omni image of the bare carpet from ``pose`` (BGR), with Gaussian pixel noise."""
    spec = FIELDS[field]
    v, u = np.mgrid[0:camera.height_px, 0:camera.width_px].astype(np.float64)
    rays = camera.pixel_to_ray(u, v)
    down = rays[..., 2] < -1e-6
    t = np.where(down, camera.height_m / np.maximum(-rays[..., 2], 1e-6), 0.0)
    gx, gy = rays[..., 0] * t, rays[..., 1] * t
    c, s = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
    fx, fy = pose.x_m + c * gx - s * gy, pose.y_m + s * gx + c * gy
    full_l = spec.length_m + 2 * spec.border_m
    full_w = spec.width_m + 2 * spec.border_m
    mx = ((fx + full_l / 2) * TEXTURE_PX_PER_M - 0.5).astype(np.float32)
    my = ((full_w / 2 - fy) * TEXTURE_PX_PER_M - 0.5).astype(np.float32)
    img = cv2.remap(_texture(field), mx, my, cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_CONSTANT, borderValue=(100, 95, 95)).astype(np.float64)
    img[~down] = (90, 90, 90)
    if noise:
        img += np.random.default_rng(seed).normal(0.0, noise, img.shape)
    r = np.hypot(u - camera.centre_px[0], v - camera.centre_px[1])
    img[r > camera.max_radius_px] = 0
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)
