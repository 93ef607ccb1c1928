"""Partly hidden balls: the expected image area of a whole ball, visibility, and fusion."""

from __future__ import annotations

import math

import numpy as np
import pytest

from estimator.camera import CAMERA_MODELS, ball_image_area_px, make_camera
from estimator.corrected import ball_visibility
from estimator.detection import detect_ball
from estimator.estimates import BallEstimate
from estimator.fusion import get_fusion
from estimator.noise import NoiseModel


@pytest.mark.parametrize(("area", "expected", "visibility"), [
    (50.0, 100.0, 0.5), (120.0, 100.0, 1.0), (-1.0, 100.0, 0.0),
    (50.0, math.nan, 1.0), (50.0, 0.0, 1.0),
])
def test_visibility_is_the_clipped_area_ratio(area: float, expected: float,
                                              visibility: float) -> None:
    assert ball_visibility(area, expected) == visibility


def test_expected_area_follows_each_model() -> None:
    ideal, fisheye, mirror = (make_camera(n) for n in ("ideal", "fisheye", "mirror"))
    # the ideal top-down view keeps the ball about the same size: pi (R / k)^2 near by
    assert ball_image_area_px(ideal, 1.0) == pytest.approx(
        math.pi * (0.11 / ideal.k_m_per_px) ** 2, rel=0.05)
    # real lenses see a ball shrink with range
    for cam in (fisheye, mirror):
        areas = [ball_image_area_px(cam, d) for d in (0.5, 1.0, 2.0, 4.0, 8.0)]
        assert areas == sorted(areas, reverse=True)
    assert math.isnan(ball_image_area_px(ideal, 0.05, ball_radius_m=12.5))


def _area_plain(camera: object, range_m: float, ball_radius_m: float, points: int = 90
                ) -> float:
    """The expected area in plain numpy (np.cross, np.roll, a fresh linspace), the form
    ball_image_area_px writes out for speed."""
    centre = np.array([range_m, 0.0, ball_radius_m - camera.height_m])  # type: ignore[attr-defined]
    dist = float(np.linalg.norm(centre))
    if dist <= ball_radius_m:
        return math.nan
    axis = centre / dist
    e1 = np.cross(axis, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    alpha = math.asin(ball_radius_m / dist)
    phi = np.linspace(0.0, 2.0 * math.pi, points, endpoint=False)[:, None]
    rays = math.cos(alpha) * axis + math.sin(alpha) * (np.cos(phi) * e1 + np.sin(phi) * e2)
    uv = np.asarray(camera.ray_to_pixel(rays), dtype=np.float64)  # type: ignore[attr-defined]
    if not np.all(np.isfinite(uv)):
        return math.nan
    u, v = uv[:, 0], uv[:, 1]
    return float(0.5 * abs(np.dot(u, np.roll(v, 1)) - np.dot(v, np.roll(u, 1))))


@pytest.mark.parametrize("camera", CAMERA_MODELS)
def test_expected_area_has_the_bits_of_the_plain_numpy_form(camera: str) -> None:
    """Results files carry each estimate's visibility: the written-out cross products and
    the kept circle must not move a bit."""
    cam = make_camera(camera)
    ranges = np.concatenate([np.random.default_rng(3).uniform(0.0, 14.0, 400),
                             [0.0, 0.05, 0.11, 1.0, 8.4, 9.07, 12.0, 30.0]])
    for radius in (0.11, 0.2, 12.5):
        for points in (90, 64):
            for d in ranges.tolist():
                got = ball_image_area_px(cam, d, radius, points=points)
                want = _area_plain(cam, d, radius, points)
                assert got == want or (math.isnan(got) and math.isnan(want)), (d, radius)


@pytest.mark.parametrize("camera", CAMERA_MODELS)
def test_expected_area_matches_a_rendered_ball(camera: str) -> None:
    from recorder.omni import OmniRenderer
    from recorder.world import World, field_spec

    cam = make_camera(camera)
    omni = OmniRenderer(cam, face_px=512)
    with World(field_spec("18x12")) as world:
        for d in (1.5, 5.0):
            world.set_ball(d, 0.0)
            det = detect_ball(omni.render(world, None, 0.0, 0.0, 0.0))
            assert det is not None
            assert ball_visibility(det.area_px, ball_image_area_px(cam, d)) > 0.85, (camera, d)
            assert det.area_px == pytest.approx(ball_image_area_px(cam, d), rel=0.15)


def _estimate(robot: str, rx: float, ry: float, bx: float, by: float,
              visibility: float = 1.0) -> BallEstimate:
    return BallEstimate(robot=robot, robot_x_m=rx, robot_y_m=ry,
                        range_m=math.hypot(bx - rx, by - ry),
                        bearing_rad=math.atan2(by - ry, bx - rx), x_m=bx, y_m=by,
                        visibility=visibility)


def test_covariance_grows_as_visibility_shrinks() -> None:
    noise = NoiseModel()
    full = noise.covariance(_estimate("a", 0.0, 0.0, 4.0, 0.0))
    tenth = noise.covariance(_estimate("a", 0.0, 0.0, 4.0, 0.0, visibility=0.1))
    assert np.allclose(tenth, 100.0 * full)
    floor = noise.covariance(_estimate("a", 0.0, 0.0, 4.0, 0.0, visibility=0.0))
    assert np.allclose(floor, full / noise.min_visibility**2)


@pytest.mark.parametrize("name", ["weighted", "robust"])
def test_a_mostly_hidden_ball_barely_moves_the_fused_estimate(name: str) -> None:
    seen = _estimate("a", -4.0, 0.0, 0.0, 0.0)
    hidden = _estimate("b", 0.0, -4.0, 0.09, 0.0, visibility=0.1)  # centroid pulled 9 cm
    fused = get_fusion(name).fuse([seen, hidden])
    trusting = get_fusion(name).fuse([seen, _estimate("b", 0.0, -4.0, 0.09, 0.0)])
    assert fused is not None and trusting is not None
    # b measures x by its bearing (tangential sigma 4 cm), a by its range (CAMBADA's sigma
    # 0.2 m at 4 m): trusted, b's centroid drags the fused ball ~8.7 cm; at visibility 0.1
    # its sigmas are 10x and the drag is a fifth of that or less
    assert trusting.x_m > 0.08
    assert 0.0 < fused.x_m < trusting.x_m / 5
    assert abs(fused.y_m) < 1e-3
