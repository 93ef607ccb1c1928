"""Omni images of the bare carpet drawn without pybullet, for the field-line tests.

Every pixel's ray (the camera model) meets the floor at a point whose colour is read from
the recorder's own carpet texture (:func:`recorder.field.field_texture`: the lines exactly
where :mod:`dsp.field` puts them); above the horizon the hall is grey. No robots or goals
stand on it, so these images test the geometry and the failure logic; the recorded logs of
docs/method.md test the rest.
"""

from __future__ import annotations

import json
import math
from functools import cache

import cv2
import numpy as np

from dsp.field import FIELDS
from estimator.camera import CameraModel, camera_from_dict
from estimator.geometry import RobotPose
from recorder.field import TEXTURE_PX_PER_M, field_texture
from replay.localise import field_lines_for as field_lines

__all__ = ["field_lines", "render_carpet"]


@cache
def _texture(name: str) -> np.ndarray:
    return field_texture(FIELDS[name])


@cache
def _ground(camera_json: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each pixel's ground point in the robot frame (gx, gy), whether its ray points down,
    and its radius from the image centre [px]."""
    camera = camera_from_dict(json.loads(camera_json))
    v, u = np.mgrid[0:camera.height_px, 0:camera.width_px].astype(np.float64)
    rays = camera.pixel_to_ray(u, v)
    down = rays[..., 2] < -1e-6
    t = np.where(down, camera.height_m / np.maximum(-rays[..., 2], 1e-6), 0.0)
    r = np.hypot(u - camera.centre_px[0], v - camera.centre_px[1])
    return rays[..., 0] * t, rays[..., 1] * t, down, r


def render_carpet(camera: CameraModel, pose: RobotPose, *, field: str = "18x12",
                  noise: float = 3.0, seed: int = 0) -> np.ndarray:
    """The omni image of the bare carpet from ``pose`` (BGR), with Gaussian pixel noise."""
    spec = FIELDS[field]
    gx, gy, down, r = _ground(json.dumps(camera.to_dict(), sort_keys=True))
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
    img[r > camera.max_radius_px] = 0
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)
