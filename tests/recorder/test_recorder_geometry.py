"""Rendered omni images agree with the camera models: a ball's blob lands where predicted.

The prediction is honest about the ball's size: the sphere's silhouette (the cone of rays
tangent to it from the optical centre) is projected through ``ray_to_pixel`` and the
centroid of that outline's area is compared with the blob's image-moment centroid.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import cv2
import numpy as np
import pytest

from estimator.camera import CAMERA_MODELS, CameraModel, make_camera
from recorder.omni import OmniRenderer
from recorder.world import BALL_RADIUS_M, World, field_spec

# (ball x, ball y) in the field frame, camera at the origin facing +x, then turned
BALL_POSITIONS = [(1.5, 0.5), (-1.0, -2.0), (3.0, -2.0), (-2.5, 3.5), (5.5, 1.0), (7.0, -1.0)]


def predicted_centroid(cam: CameraModel, ball_robot_xyz: np.ndarray) -> tuple[float, float]:
    """Area centroid of the projected sphere silhouette (robot frame, camera at height_m)."""
    c = ball_robot_xyz - np.array([0.0, 0.0, cam.height_m])
    dist = float(np.linalg.norm(c))
    axis = c / dist
    alpha = math.asin(BALL_RADIUS_M / dist)
    e1 = np.cross(axis, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    phi = np.linspace(0.0, 2 * math.pi, 2000, endpoint=False)[:, None]
    rays = math.cos(alpha) * axis + math.sin(alpha) * (np.cos(phi) * e1 + np.sin(phi) * e2)
    uv = cam.ray_to_pixel(rays)
    x, y = uv[:, 0], uv[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = cross.sum() / 2
    cx = ((x + xn) * cross).sum() / (6 * area)
    cy = ((y + yn) * cross).sum() / (6 * area)
    return float(cx), float(cy)


def blob_centroid(img_bgr: np.ndarray) -> tuple[float, float, float]:
    hsv = cv2.cvtColor(img_bgr, cv2.COLOR_BGR2HSV)
    mask = cv2.inRange(hsv, (4, 120, 60), (24, 255, 255))
    m = cv2.moments(mask, binaryImage=True)
    assert m["m00"] > 0, "no ball blob"
    return m["m10"] / m["m00"], m["m01"] / m["m00"], m["m00"]


@pytest.fixture(scope="module")
def world() -> Iterator[World]:
    """The available renderer (EGL here; DSP_RENDERER=tiny forces TinyRenderer)."""
    with World(field_spec("18x12")) as w:
        yield w


@pytest.mark.parametrize("name", CAMERA_MODELS)
def test_ball_blob_where_model_predicts(world: World, name: str) -> None:
    cam = make_camera(name)
    omni = OmniRenderer(cam, face_px=1024, renderer=world.renderer)
    yaw = 0.7
    cx, cy = 0.3, -0.4  # camera position in the field
    errors = []
    for bx, by in BALL_POSITIONS:
        world.set_ball(cx + bx, cy + by)
        img = omni.render(world, None, cx, cy, yaw)
        u, v, area = blob_centroid(img)
        # ball in the robot frame
        c, s = math.cos(yaw), math.sin(yaw)
        rel = np.array([c * bx + s * by, -s * bx + c * by, BALL_RADIUS_M])
        pu, pv = predicted_centroid(cam, rel)
        errors.append((bx, by, round(u - pu, 3), round(v - pv, 3), area))
        assert math.hypot(u - pu, v - pv) < 1.0, errors
