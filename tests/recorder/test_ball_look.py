"""The ball's colour and pattern: the rendered ball has the asked hue, a panelled or banded
ball shows its second tone, the pattern turns with the ball's physics, and the default look
is the plain orange ball of every earlier log."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from estimator.camera import make_camera
from recorder.ball import (
    BALL_COLOURS,
    BALL_PATTERNS,
    TEXTURE_SIZE_PX,
    ball_look,
    ball_texture,
    sphere_obj,
)
from recorder.omni import OmniRenderer
from recorder.world import BALL_RADIUS_M, BALL_RGB, World, field_spec

FACE_PX = 384
BALL_AT = (1.0, 0.2)
"""Where the ball lies in front of the bare fisheye camera at the origin (~40 px across)."""


def _hsv(bgr: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(bgr.reshape(-1, 1, 3), cv2.COLOR_BGR2HSV).reshape(-1, 3)


class Scene:
    """A world of one look and a fisheye at the origin; the ball's pixels are those that
    change when the ball is taken away. One world at a time: with EGL, two worlds alive in
    one process disturb each other's images once one of them has a textured ball."""

    def __init__(self, colour: str, pattern: str) -> None:
        self.world = World(field_spec("18x12"), ball=ball_look(colour, pattern))
        self.omni = OmniRenderer(make_camera("fisheye"), face_px=FACE_PX,
                                 renderer=self.world.renderer)
        self.world.set_ball(40.0, 40.0)
        self.empty = self.render()

    def render(self) -> np.ndarray:
        return self.omni.render(self.world, None, 0.0, 0.0, 0.0)

    def ball_pixels(self, img: np.ndarray) -> np.ndarray:
        """The pixels the ball covers whole (its anti-aliased rim left out)."""
        changed = (np.abs(img.astype(int) - self.empty).max(axis=2) > 40).astype(np.uint8)
        return cv2.erode(changed, np.ones((3, 3), np.uint8)) > 0

    def __enter__(self) -> Scene:
        return self

    def __exit__(self, *exc: object) -> None:
        self.world.close()


_RENDERED: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}


def _ball_at_rest(colour: str, pattern: str) -> tuple[np.ndarray, np.ndarray]:
    """The image of the ball of that look at BALL_AT, unturned, and its pixels (cached)."""
    if (colour, pattern) not in _RENDERED:
        with Scene(colour, pattern) as scene:
            scene.world.set_ball(*BALL_AT)
            img = scene.render()
            _RENDERED[colour, pattern] = (img, scene.ball_pixels(img))
    return _RENDERED[colour, pattern]


HUES = {"orange": (9, 17), "yellow": (22, 32)}
"""OpenCV hue (0-179) of the lit ball's pixels, median."""


@pytest.mark.parametrize(("colour", "pattern"), [
    ("orange", "plain"), ("orange", "panels"), ("yellow", "panels"), ("yellow", "bands"),
    ("white", "panels"),
])
def test_the_ball_has_the_asked_colour(colour: str, pattern: str) -> None:
    img, mask = _ball_at_rest(colour, pattern)
    assert mask.sum() > 300, "the ball is not in view"
    hsv = _hsv(img[mask])
    h, s, v = (float(np.median(hsv[:, i])) for i in range(3))
    if colour == "white":
        assert s < 40 and v > 150, (h, s, v)
    else:
        lo, hi = HUES[colour]
        assert lo <= h <= hi and s > 150, (h, s, v)


@pytest.mark.parametrize(("colour", "pattern", "share"), [
    ("orange", "panels", (0.18, 0.5)), ("yellow", "bands", (0.15, 0.5)),
    ("white", "panels", (0.18, 0.5)),
])
def test_a_pattern_shows_its_second_tone(colour: str, pattern: str,
                                         share: tuple[float, float]) -> None:
    """Pixel by pixel against the plain ball of the same colour at the same place: the
    pattern's second tone (0.65-0.75 of the first) darkens a share of the ball, the rest
    keeps the first (EGL's texture filtering softens the edges between them)."""
    (a, mask_a), (b, mask_b) = _ball_at_rest(colour, "plain"), _ball_at_rest(colour, pattern)
    mask = mask_a & mask_b
    ratio = _hsv(b[mask])[:, 2].astype(float) / np.maximum(_hsv(a[mask])[:, 2], 1)
    dark = float(np.mean(ratio < 0.85))
    assert share[0] < dark < share[1], dark
    assert float(np.mean(np.abs(ratio - 1.0) < 0.03)) > 0.3


@pytest.mark.parametrize("pattern", ["panels", "plain"])
def test_the_pattern_turns_as_the_ball_rolls(pattern: str) -> None:
    """Rolled by the physics, the ball turns by distance / radius; rendered at the same
    place in its rolled and its unturned orientation, a patterned ball looks different, a
    plain one the same (but for the mesh's facets on its rim)."""
    with Scene("orange", pattern) as scene:
        _roll_and_compare(scene, pattern)


def _roll_and_compare(scene: Scene, pattern: str) -> None:
    world = scene.world
    world.set_ball(BALL_AT[0] - 0.25, BALL_AT[1], 2.0, 0.0)  # turns 2.3 rad (< pi)
    x0 = world.ball_position()[0]
    while world.ball_position()[0] < BALL_AT[0]:
        world.step()
    x1, y1, z1 = world.ball_position()
    q = world.ball_orientation()
    turned = 2 * math.acos(min(1.0, abs(q[3])))
    assert turned == pytest.approx((x1 - x0) / BALL_RADIUS_M, rel=0.1)
    rolled = scene.render()
    world.place_ball(x1, y1, z1)
    unturned = scene.render()
    mask = scene.ball_pixels(rolled)
    diff = np.abs(rolled.astype(int) - unturned)[mask].max(axis=1)
    changed = float(np.mean(diff > 30))
    if pattern == "plain":  # only the facets of the rim move
        assert changed < 0.02
    else:
        assert changed > 0.1


def test_the_default_look_is_the_ball_of_every_earlier_log() -> None:
    look = ball_look()
    assert (look.colour, look.pattern, look.rgb, look.textured) == (
        "orange", "plain", BALL_RGB, False)
    assert BALL_COLOURS["orange"][0] == BALL_RGB
    # the mesh text every earlier log's ball was drawn with: 24 x 48 facets, normals only
    text = sphere_obj(BALL_RADIUS_M, 24, 48)
    assert text.count("\nv ") + text.startswith("v ") == 25 * 48
    assert "vt " not in text and text.count("\nf ") == 2 * 24 * 48


def test_textures_cover_the_sphere_with_their_second_tone() -> None:
    """Weighted by solid angle, the panels' second tone (12 pentagons of a truncated
    icosahedron, 28 % of its surface, and the seams) and the three bands' cover what they
    should; a plain texture is one colour."""
    width, height = TEXTURE_SIZE_PX
    weight = np.sin(math.pi * (np.arange(height) + 0.5) / height)[:, None] * np.ones(width)
    shares = {}
    for pattern in BALL_PATTERNS:
        tex = ball_texture(ball_look("yellow", pattern), BALL_RADIUS_M)
        second = np.all(tex == BALL_COLOURS["yellow"][1][::-1], axis=2)
        assert np.all(second | np.all(tex == BALL_COLOURS["yellow"][0][::-1], axis=2))
        shares[pattern] = float((second * weight).sum() / weight.sum())
    assert shares["plain"] == 0.0
    assert 0.30 < shares["panels"] < 0.42
    band = math.sin(0.012 / BALL_RADIUS_M)  # one band's share of the sphere
    assert 2.4 * band < shares["bands"] < 3 * band


def test_unknown_looks_are_refused() -> None:
    with pytest.raises(ValueError, match="unknown ball colour 'red'"):
        ball_look("red")
    with pytest.raises(ValueError, match="unknown ball pattern 'stripes'"):
        ball_look("orange", "stripes")
