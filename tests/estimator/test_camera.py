"""Camera models: pixel <-> ray round trips, the models' defining laws, dict round trips."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from estimator.camera import (
    CAMERA_MODELS,
    CameraModel,
    camera_from_dict,
    ground_range_m,
    make_camera,
)


@pytest.mark.parametrize("name", CAMERA_MODELS)
def test_protocol_and_basics(name: str) -> None:
    cam = make_camera(name)
    assert isinstance(cam, CameraModel)
    assert cam.name == name
    assert (cam.width_px, cam.height_px) == (1080, 1080)
    assert cam.centre_px == (539.0, 539.0)
    # real lenses sit on top of the 0.8 m robot; the ideal view is a virtual top-down one
    assert cam.height_m == (12.0 if name == "ideal" else 0.85)
    assert cam.max_radius_px == 539.0


@pytest.mark.parametrize("name", CAMERA_MODELS)
def test_dict_round_trip(name: str) -> None:
    cam = make_camera(name, height_m=0.9)
    d = json.loads(json.dumps(cam.to_dict()))
    assert d["model"] == name
    assert camera_from_dict(d) == cam


def test_unknown_model_and_bad_dict() -> None:
    with pytest.raises(ValueError, match="unknown camera model 'pinhole'"):
        make_camera("pinhole")
    with pytest.raises(ValueError, match="no 'model' key"):
        camera_from_dict({"height_m": 0.85})
    with pytest.raises(ValueError, match="bad parameters"):
        make_camera("ideal", focal=3.0)


@pytest.mark.parametrize("name", CAMERA_MODELS)
@settings(max_examples=200, deadline=None)
@given(
    r=st.floats(0.0, 538.0),
    phi=st.floats(-math.pi, math.pi),
)
def test_pixel_ray_pixel(name: str, r: float, phi: float) -> None:
    cam = make_camera(name)
    u = 539.0 + r * math.cos(phi)
    v = 539.0 + r * math.sin(phi)
    ray = cam.pixel_to_ray(u, v)
    assert abs(float(np.linalg.norm(ray)) - 1.0) < 1e-12
    uv = cam.ray_to_pixel(ray)
    assert np.allclose(uv, [u, v], atol=1e-6)
    # rays need not be unit length
    assert np.allclose(cam.ray_to_pixel(3.0 * ray), [u, v], atol=1e-6)


@pytest.mark.parametrize("name", CAMERA_MODELS)
def test_directions(name: str) -> None:
    """Image up = robot forward (+x), image left = robot left (+y), centre = straight down."""
    cam = make_camera(name)
    assert np.allclose(cam.pixel_to_ray(539.0, 539.0), [0, 0, -1])
    fwd = cam.pixel_to_ray(539.0, 300.0)
    left = cam.pixel_to_ray(300.0, 539.0)
    assert fwd[0] > 0 and abs(fwd[1]) < 1e-12
    assert left[1] > 0 and abs(left[0]) < 1e-12
    uv = cam.ray_to_pixel(np.array([[1.0, 0, -1], [0, -1.0, -1]]))
    assert uv[0, 1] < 539 and abs(uv[0, 0] - 539) < 1e-9  # forward -> up
    assert uv[1, 0] > 539 and abs(uv[1, 1] - 539) < 1e-9  # right -> right


def test_ideal_is_linear_on_the_ground() -> None:
    cam = make_camera("ideal")
    r = np.array([0.0, 100.0, 250.0, 499.0])
    assert np.allclose(ground_range_m(cam, r), cam.k_m_per_px * r)
    # the ball's centre (0.11 m up) 8.4 m away appears at r = 499 px (the paper's example)
    tan_n = np.tan(cam.nadir_angle_rad(499.0))
    assert (cam.height_m - 0.11) * tan_n == pytest.approx(8.4)


def test_fisheye_is_equidistant() -> None:
    cam = make_camera("fisheye")
    assert cam.nadir_angle_rad(539.0) == pytest.approx(math.pi / 2)
    assert cam.nadir_angle_rad(269.5) == pytest.approx(math.pi / 4)
    assert cam.radius_px(math.pi / 2) == pytest.approx(539.0)


def test_mirror_law_and_horizon() -> None:
    cam = make_camera("mirror")
    r = np.array([50.0, 200.0, 500.0])
    assert np.allclose(ground_range_m(cam, r), cam.a_m * np.tan(cam.b_rad_per_px * r))
    assert 539.0 < cam.horizon_px < 560.0
    assert 8.0 <= float(ground_range_m(cam, 500.0)) <= 9.0
    assert np.isnan(cam.nadir_angle_rad(600.0))
    assert np.isnan(cam.radius_px(math.pi / 2 + 0.1))
