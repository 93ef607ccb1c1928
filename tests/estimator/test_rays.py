"""Rays to the ball and their triangulation: exact rays meet at the ball, noise gives the
covariance it claims, one robot or near-parallel rays give no height (and say so)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from estimator.constants import BALL_RADIUS_M
from estimator.estimates import BallEstimate
from estimator.fusion import TriangulateFusion, get_fusion
from estimator.noise import NoiseModel
from estimator.rays import ball_ray, height_unknown_covariance, on_the_ray, ray_of, triangulate

R = BALL_RADIUS_M


def seen(robot: str, rx: float, ry: float, h: float, ball: tuple[float, float, float],
         noise_m: tuple[float, float] = (0.0, 0.0)) -> BallEstimate:
    """What a robot at (rx, ry) with its camera h up reports of a ball at ``ball``: the
    ground point of its ray (through the ball's centre, met with z = R), moved by
    ``noise_m`` (radial, tangential)."""
    bx, by, bz = ball
    t = (h - R) / (h - bz)
    gx, gy = rx + t * (bx - rx), ry + t * (by - ry)
    d = math.hypot(gx - rx, gy - ry)
    phi = math.atan2(gy - ry, gx - rx)
    d += noise_m[0]
    phi += noise_m[1] / d
    return BallEstimate(robot, rx, ry, d, phi, rx + d * math.cos(phi), ry + d * math.sin(phi),
                        camera_height_m=h)


ROBOTS = [("r1", -4.0, 1.0), ("r2", 2.0, -3.0), ("r3", 3.0, 4.0)]


def rays_of(ball: tuple[float, float, float], h: float, cov: np.ndarray,
            robots: list[tuple[str, float, float]] = ROBOTS) -> list:
    return [ball_ray(seen(n, x, y, h, ball), h, cov) for n, x, y in robots]


@pytest.mark.parametrize(("h", "ball"), [
    (0.85, (0.5, 0.3, R)), (0.85, (1.0, -0.5, 0.6)),  # below the lens: all it can see
    (12.0, (0.5, 0.3, R)), (12.0, (1.0, -0.5, 1.2)), (12.0, (-0.7, 0.8, 2.9))])
def test_exact_rays_meet_at_the_ball(h: float, ball: tuple[float, float, float]) -> None:
    cov = np.diag([0.01 ** 2, 0.01 ** 2])
    for robots in (ROBOTS[:2], ROBOTS):
        solved = triangulate(rays_of(ball, h, cov, robots))
        assert solved is not None
        point, c = solved
        assert np.allclose(point, ball, atol=1e-9)
        assert c.shape == (3, 3) and np.all(np.linalg.eigvalsh(c) > 0)


def test_a_ray_starts_at_the_camera_and_its_ground_point_is_the_estimate() -> None:
    e = seen("r1", 1.0, 2.0, 0.85, (4.0, -1.0, 0.6))
    ray = ball_ray(e, 0.85, np.eye(2) * 1e-4)
    assert ray.origin == (1.0, 2.0, 0.85)
    assert np.isclose(np.linalg.norm(ray.direction), 1.0)
    assert np.allclose(ray.ground_point, (e.x_m, e.y_m, R))
    # the ball's centre lies on it
    o, u = np.array(ray.origin), np.array(ray.direction)
    b = np.array([4.0, -1.0, 0.6])
    assert np.linalg.norm(np.cross(b - o, u)) < 1e-12


def test_the_covariance_is_the_scatter_of_noisy_rays() -> None:
    """Ground estimates with 2 cm radial and 1 cm tangential noise, 12 m cameras, a ball
    1.5 m up: the spread of 400 triangulations matches the covariance they report."""
    rng = np.random.default_rng(3)
    ball = (0.4, -0.2, 1.5)
    sr, st = 0.02, 0.01
    points, covs = [], []
    for _ in range(400):
        rays = []
        for n, x, y in ROBOTS[:2]:
            e = seen(n, x, y, 12.0, ball, (rng.normal(0, sr), rng.normal(0, st)))
            phi = math.atan2(e.y_m - y, e.x_m - x)
            rot = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
            rays.append(ball_ray(e, 12.0, rot @ np.diag([sr ** 2, st ** 2]) @ rot.T))
        solved = triangulate(rays)
        assert solved is not None
        points.append(solved[0])
        covs.append(solved[1])
    scatter = np.cov(np.array(points).T)
    claimed = np.mean(covs, axis=0)
    assert np.allclose(np.mean(points, axis=0), ball, atol=0.02)
    for i in range(3):  # each axis's sigma within 20 % of the claim
        assert 0.8 < math.sqrt(scatter[i, i] / claimed[i, i]) < 1.2, (i, scatter, claimed)


def test_one_ray_or_parallel_rays_fix_no_point() -> None:
    cov = np.eye(2) * 1e-4
    ball = (1.0, 0.0, 1.0)
    assert triangulate(rays_of(ball, 12.0, cov)[:1]) is None
    # two robots side by side, 0.1 m apart: rays 0.5 deg apart
    beside = [("a", -4.0, 0.0), ("b", -4.0, 0.1)]
    assert triangulate(rays_of(ball, 12.0, cov, beside)) is None
    fused = TriangulateFusion().fuse([seen(n, x, y, 12.0, ball) for n, x, y in beside])
    assert fused is not None and not fused.triangulated and fused.z_m == R


def test_below_the_ground_is_solved_again_on_it() -> None:
    """Rays that cross below the ball's radius (noise) give a ball at z = R."""
    cov = np.eye(2) * 1e-4
    ests = [seen(n, x, y, 0.85, (0.0, 0.0, R), (-0.05, 0.0))
            for n, x, y in ROBOTS[:2]]
    solved = triangulate([ball_ray(e, 0.85, cov) for e in ests])
    assert solved is not None
    assert solved[0][2] == R and solved[1][2, 2] > 0.0


def test_fusion_one_robot_keeps_the_ground_estimate_and_an_unknown_height() -> None:
    e = seen("r1", -4.0, 1.0, 12.0, (1.0, 0.0, 2.0))
    fused = TriangulateFusion().fuse([e])
    assert fused is not None and not fused.triangulated
    # one estimate's information-form fusion is itself, to rounding (BLAS-dependent)
    assert (fused.x_m, fused.y_m) == pytest.approx((e.x_m, e.y_m), abs=1e-12)
    assert fused.z_m == R
    assert fused.covariance_3d is not None
    c = np.array(fused.covariance_3d)
    # the height's sigma is that of a uniform spread up to 3.5 m: about 1.96 m
    assert math.sqrt(c[2, 2]) == pytest.approx((3.5 - R) / math.sqrt(3), rel=1e-9)
    # and it is spread along the ray, towards the robot as it rises
    _, v = np.linalg.eigh(c)
    axis = v[:, -1] * np.sign(v[2, -1])
    ray = ball_ray(e, 12.0, NoiseModel().covariance(e))
    assert np.allclose(axis, -np.array(ray.direction), atol=0.02)


def test_fusion_of_two_robots_gives_the_height_and_of_none_nothing() -> None:
    ball = (1.0, 0.5, 1.8)
    ests = [seen(n, x, y, 12.0, ball) for n, x, y in ROBOTS]
    fused = get_fusion("triangulate").fuse(ests)
    assert fused is not None and fused.triangulated and fused.robots == ("r1", "r2", "r3")
    assert fused.z_m == pytest.approx(1.8, abs=1e-9)
    assert (fused.x_m, fused.y_m) == pytest.approx(ball[:2], abs=1e-9)
    assert TriangulateFusion().fuse([]) is None


def test_a_ray_off_the_others_is_dropped() -> None:
    """Three robots see a lob; the third reports a blob 2 m off: the two agree."""
    ball = (1.0, 0.5, 1.8)
    ests = [seen(n, x, y, 12.0, ball) for n, x, y in ROBOTS[:2]]
    ests.append(seen("r3", 3.0, 4.0, 12.0, (-1.0, 1.5, R)))
    fused = TriangulateFusion().fuse(ests)
    assert fused is not None and fused.robots == ("r1", "r2")
    assert fused.z_m == pytest.approx(1.8, abs=1e-6)


def test_two_rays_that_miss_fall_back_to_the_ground() -> None:
    """Two robots see different blobs: their rays miss by metres; no height is made up."""
    a = seen("r1", -4.0, 1.0, 0.85, (1.0, 0.0, R))
    b = seen("r2", 2.0, -3.0, 0.85, (3.0, 3.0, R))
    fused = TriangulateFusion().fuse([a, b])
    assert fused is not None and not fused.triangulated and fused.z_m == R


def test_no_camera_height_no_ray() -> None:
    e = BallEstimate("r1", 0.0, 0.0, 3.0, 0.0, 3.0, 0.0)
    fused = TriangulateFusion().fuse([e])
    assert fused is not None and fused.z_m == R and not fused.triangulated
    assert fused.covariance_3d is not None and fused.covariance_3d[2][2] > 1.0


def test_the_height_unknown_spread_stops_at_the_camera() -> None:
    e = seen("r1", 0.0, 0.0, 0.85, (3.0, 0.0, R))
    ray = ball_ray(e, 0.85, np.eye(2) * 1e-4)
    c = height_unknown_covariance(np.eye(2) * 1e-4, ray, 3.5)
    assert c[2, 2] == pytest.approx((0.85 - R) ** 2 / 3.0)


def _under_the_ball(e: BallEstimate, ball: tuple[float, float, float],
                    sigma_m: float) -> BallEstimate:
    """``e`` as ``--width-range`` makes it when the blob's width shows the ball in the air:
    placed under the ball, its ray's ground range kept."""
    rho = math.hypot(ball[0] - e.robot_x_m, ball[1] - e.robot_y_m)
    return replace(e, x_m=ball[0], y_m=ball[1], range_m=rho, range_sigma_m=sigma_m,
                   ray_range_m=e.range_m)


def test_a_ball_placed_under_itself_keeps_its_ray() -> None:
    ball = (4.0, -1.0, 0.6)
    e = seen("r1", 1.0, 2.0, 0.85, ball)
    moved = _under_the_ball(e, ball, 0.1)
    ray = ball_ray(moved, 0.85, np.eye(2) * 1e-4)
    assert np.allclose(ray.ground_point, (e.x_m, e.y_m, R))
    without = ball_ray(replace(moved, ray_range_m=None), 0.85, np.eye(2) * 1e-4)
    assert not np.allclose(without.ground_point, (e.x_m, e.y_m, R), atol=0.5)


def test_one_robot_whose_width_lifts_the_ball_places_it_on_its_ray_in_3d() -> None:
    """One robot alone: the ground-plane estimate says z = R with the height unknown; the
    same estimate placed under the ball by its width gives the ball's height, and a
    covariance along the ray of the width's sigma."""
    ball = (1.0, 0.0, 2.0)
    e = seen("r1", -4.0, 1.0, 12.0, ball)
    moved = _under_the_ball(e, ball, 0.1)
    fused = TriangulateFusion().fuse([moved])
    assert fused is not None and fused.z_m is not None and fused.covariance_3d is not None
    assert (fused.x_m, fused.y_m, fused.z_m) == pytest.approx(ball, abs=1e-9)
    c = np.array(fused.covariance_3d)
    ray = ray_of(moved, NoiseModel().covariance)  # the blob's ray, as sure as the blob
    blob = ball_ray(e, 12.0, NoiseModel().covariance(e))
    assert np.allclose(ray.direction, blob.direction, atol=1e-12)
    assert (ray.sigma_azimuth_rad, ray.sigma_elevation_rad) == pytest.approx(
        (blob.sigma_azimuth_rad, blob.sigma_elevation_rad), rel=1e-9)
    level = math.hypot(ray.direction[0], ray.direction[1])
    u = np.array(ray.direction)
    assert math.sqrt(float(u @ c @ u)) == pytest.approx(0.1 / level, rel=1e-6)
    point, cov = on_the_ray(ray, math.hypot(ball[0] + 4.0, ball[1] - 1.0), 0.1)
    assert point == pytest.approx(ball, abs=1e-9) and np.allclose(cov, c)
