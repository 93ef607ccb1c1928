"""The venue's trouble: people in the ball's colour beside the field, robot covers of it and
uneven light, each seeded from its own stream and rendered where it is."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from estimator.camera import CameraModel, make_camera
from recorder.ball import BALL_COLOURS, ball_look
from recorder.omni import OmniRenderer
from recorder.scenarios import make_scenario
from recorder.scenery import (
    LIGHT_BASE,
    LIGHT_MAX,
    LightPool,
    Person,
    colour_temperature_rgb,
    light_at,
    make_scenery,
)
from recorder.world import World, field_spec

SPEC = field_spec("18x12")
HL, HW, BORDER = SPEC.half_length_m, SPEC.half_width_m, SPEC.border_m


def _pixel(cam: CameraModel, pose: tuple[float, float, float],
           point: tuple[float, float, float]) -> tuple[float, float]:
    """Where a field point appears in the image of a camera on a robot at ``pose``."""
    x, y, yaw = pose
    dx, dy = point[0] - x, point[1] - y
    c, s = math.cos(yaw), math.sin(yaw)
    ray = np.array([c * dx + s * dy, -s * dx + c * dy, point[2] - cam.height_m])
    u, v = cam.ray_to_pixel(ray)
    return float(u), float(v)


def _yellow(img: np.ndarray) -> np.ndarray:
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    return cv2.inRange(hsv, (20, 120, 80), (34, 255, 255)) > 0


def test_people_stand_beyond_the_carpet_facing_the_field() -> None:
    people = [p for seed in range(20) for p in make_scenery(
        seed, people=5, covers=0, light_pools=0, robots=(), hl=HL, hw=HW,
        border=BORDER).people]
    assert len(people) == 100
    for person in people:
        outside = abs(person.x_m) - HL - BORDER, abs(person.y_m) - HW - BORDER
        assert 0.3 <= max(outside) <= 1.5, person  # beyond the carpet's edge, near it
        facing = math.atan2(-person.y_m, -person.x_m)
        turn = math.atan2(math.sin(person.yaw_rad - facing), math.cos(person.yaw_rad - facing))
        assert abs(turn) <= 0.5 + 1e-9
        assert 1.6 <= person.height_m <= 1.9
    assert 30 < sum(p.crouching for p in people) < 70


def test_scenery_is_seeded_and_leaves_the_scene_alone() -> None:
    plain = make_scenario("match", 3)
    dressed = make_scenario("match", 3, people=4, covers=2, light_pools=3)
    assert (dressed.robots, dressed.ball_xy_m, dressed.play) == (
        plain.robots, plain.ball_xy_m, plain.play)
    assert plain.scenery is None and "scenery" not in plain.params()
    assert dressed.scenery == make_scenario("match", 3, people=4, covers=2,
                                            light_pools=3).scenery
    assert dressed.scenery != make_scenario("match", 4, people=4, covers=2,
                                            light_pools=3).scenery
    assert dressed.scenery is not None
    assert len(dressed.scenery.people) == 4 and len(dressed.scenery.light_pools) == 3
    assert set(dressed.scenery.covers) <= {"robot1", "robot2", "robot3"}
    assert len(dressed.scenery.covers) == 2
    assert dressed.params()["scenery"]["people"][0]["height_m"] == (
        dressed.scenery.people[0].height_m)
    # a scene's opponents may wear covers too
    hidden = next(s for s in range(30) if make_scenario("random", s).opponents)
    covered = make_scenario("random", hidden, covers=4).scenery
    assert covered is not None and "opponent1" in covered.covers


def test_people_and_covers_wear_the_ball_colour_where_they_stand() -> None:
    """Seen from the ideal camera's 12 m, a person's shirt and a covered robot's skirt are
    yellow where they stand and nowhere else; the covered robot's own camera, which the
    robot hides from, does not see its own cover."""
    person = Person(0.0, HW + BORDER + 0.6, -math.pi / 2, 1.8, crouching=False)
    cam = make_camera("ideal")
    with World(SPEC, ball=ball_look("yellow", "plain")) as world:
        omni = OmniRenderer(cam, face_px=512, renderer=world.renderer)
        world.add_person(person)
        world.add_robot("robot2")
        world.set_robot_pose("robot2", 2.0, 3.0, 0.4)
        world.add_cover("robot2")
        world.set_ball(40.0, 40.0)
        pose = (0.0, 3.0, 0.0)
        yellow = _yellow(omni.render(world, None, *pose))
        own = _yellow(omni.render(world, "robot2", 2.0, 3.0, 0.4))
    n, _, stats, centroids = cv2.connectedComponentsWithStats(yellow.astype(np.uint8))
    blobs = [tuple(centroids[i]) for i in range(1, n) if stats[i, cv2.CC_STAT_AREA] > 20]
    shirt = _pixel(cam, pose, (person.x_m, person.y_m, 0.47 * 1.8 + 0.165 * 1.8))
    skirt = _pixel(cam, pose, (2.0, 3.0, 0.15))
    # within 25 px (0.4 m here): the camera sees the skirt's sides, 0.26 m from its axis
    for want in (shirt, skirt):
        assert min(math.dist(want, b) for b in blobs) < 25, (want, blobs)
    assert all(min(math.dist(b, w) for w in (shirt, skirt)) < 25 for b in blobs), blobs
    near_own = _pixel(cam, (2.0, 3.0, 0.4), (2.0, 3.0, 0.15))
    ys, xs = np.nonzero(own)
    assert not np.any(np.hypot(xs - near_own[0], ys - near_own[1]) < 30)


def test_light_pools_light_the_field_and_the_ball_where_they_shine() -> None:
    """The carpet's brightness at a pool's centre over that far from every pool is the
    light's ratio there; the ball rolled into the pool is relit by the same ratio."""
    pool = LightPool(3.0, 0.0, 1.5, 0.6, 6500.0, colour_temperature_rgb(6500.0))
    bright = light_at((pool,), 3.0, 0.0)
    assert bright == pytest.approx([LIGHT_BASE + 0.6] * 3, abs=0.01)
    cam = make_camera("ideal")
    pose = (0.0, -2.0, 0.0)
    with World(SPEC, light=(pool,)) as world:
        omni = OmniRenderer(cam, face_px=512, renderer=world.renderer)
        values = []
        for bx in (3.0, -3.0):  # in the pool; 6 m from it
            world.set_ball(bx, 1.0)
            world.relight()
            img = omni.render(world, None, *pose)
            hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
            u, v = (round(c) for c in _pixel(cam, pose, (bx, -0.5, 0.0)))
            carpet = float(np.median(hsv[v - 3:v + 4, u - 3:u + 4, 2]))
            bu, bv = (round(c) for c in _pixel(cam, pose, (bx, 1.0, 0.11)))
            ball = float(np.max(hsv[bv - 2:bv + 3, bu - 2:bu + 3, 2]))
            values.append((carpet, ball))
    (carpet_in, ball_in), (carpet_out, ball_out) = values
    expect = float(light_at((pool,), 3.0, -0.5)[1] / light_at((pool,), -3.0, -0.5)[1])
    assert carpet_in / carpet_out == pytest.approx(expect, rel=0.08)
    ball_expect = float(light_at((pool,), 3.0, 1.0)[0] / light_at((pool,), -3.0, 1.0)[0])
    assert ball_in / ball_out == pytest.approx(ball_expect, rel=0.1)


def test_light_is_even_without_pools_and_bounded_with_them() -> None:
    assert np.array_equal(light_at((), np.zeros(4), np.zeros(4)), np.ones((4, 3)))
    many = tuple(LightPool(0.0, 0.0, 2.0, 0.7, 3000.0, colour_temperature_rgb(3000.0))
                 for _ in range(8))
    assert float(light_at(many, 0.0, 0.0).max()) == LIGHT_MAX
    assert colour_temperature_rgb(6500.0) == pytest.approx((1.0, 1.0, 1.0), abs=0.02)
    warm = colour_temperature_rgb(3000.0)
    assert warm[0] > 1.2 and warm[2] < 0.6  # warm light: more red, less blue
    pools = make_scenery(5, people=0, covers=0, light_pools=4, robots=(), hl=HL, hw=HW,
                         border=BORDER).light_pools
    for pool in pools:
        lum = 0.299 * pool.rgb[0] + 0.587 * pool.rgb[1] + 0.114 * pool.rgb[2]
        assert lum == pytest.approx(1.0, abs=1e-3)
        assert 3000 <= pool.kelvin <= 6500 and 1.5 <= pool.sigma_m <= 3.5


def test_distractor_boxes_take_the_ball_colour() -> None:
    """The match's distractor boxes are the ball's colour (orange: as in every earlier log)."""
    cam = make_camera("ideal")
    with World(SPEC, ball=ball_look("white", "plain")) as world:
        omni = OmniRenderer(cam, face_px=512, renderer=world.renderer)
        world.add_distractor(2.0, HW + 0.8, 0.3)
        world.set_ball(40.0, 40.0)
        img = omni.render(world, None, 0.0, 3.0, 0.0)
    u, v = (round(c) for c in _pixel(cam, (0.0, 3.0, 0.0), (2.0, HW + 0.8, 0.3)))
    top = img[v - 1:v + 2, u - 1:u + 2].reshape(-1, 3).astype(float)
    white = np.array(BALL_COLOURS["white"][0][::-1], float)
    # the box's top, lit from above: white's hue-less tone, not orange
    assert np.all(np.abs(top - top.mean(axis=1, keepdims=True)) < 12)
    assert np.all(top.mean(axis=1) > 0.6 * white.mean())
