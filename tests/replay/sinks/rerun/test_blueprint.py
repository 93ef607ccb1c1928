"""The replay's Rerun layout: a 3-D fusion's shows the ball's height, a level one the
field straight from above; label colours read on the light and the dark theme."""

from __future__ import annotations

from collections.abc import Iterator
from typing import cast

import numpy as np
import pytest
import rerun.blueprint as rrb

from dsp.field import DEFAULT_FIELD, FIELDS
from replay.sinks.rerun.blueprint import blueprint
from replay.sinks.style import LANDING_COLOUR, TRACK_COLOUR, Rgb

ROBOTS = ("robot1", "robot2", "robot3")
LABEL_BOXES = {"light": (131, 163, 140), "dark": (41, 73, 50)}
"""A 3-D label's half-transparent box on the grass, as the web viewer draws it in each
theme (read off ``scripts/screenshot_viewer.py``'s screenshots)."""


def _views(item: object) -> Iterator[rrb.View]:
    if isinstance(item, rrb.View):
        yield item
        return
    for child in getattr(item, "contents", []):
        yield from _views(child)


def _eye(view: rrb.View) -> tuple[np.ndarray, np.ndarray]:
    eye = cast("rrb.EyeControls3D", view.properties["EyeControls3D"])
    assert eye.position is not None and eye.look_target is not None
    position = np.asarray(eye.position.as_arrow_array().to_pylist()[0])
    target = np.asarray(eye.look_target.as_arrow_array().to_pylist()[0])
    return position, target


@pytest.mark.parametrize("kind", ["moving", "log"])
def test_a_3d_fusion_sees_the_field_obliquely_and_plots_the_height(kind: str) -> None:
    field = FIELDS[DEFAULT_FIELD]
    for heights in (False, True):
        views = list(_views(blueprint(ROBOTS, field, kind, heights=heights).root_container))
        origins = [str(v.origin) for v in views]
        assert ("/plots/height" in origins) == heights
        (view,) = [v for v in views if str(v.origin) == "/field"]
        position, target = _eye(view)
        down = (target - position) / np.linalg.norm(target - position)
        off_vertical = np.degrees(np.arccos(-down[2]))
        # straight down, where a ball's height cannot show; or tilted enough that 1 m up
        # moves the ball by half a metre on the screen, while the far goal stays in view
        assert (20.0 < off_vertical < 50.0) if heights else off_vertical < 1.0


def _luminance(rgb: Rgb) -> float:
    c = np.asarray(rgb, dtype=np.float64) / 255.0
    c = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return float(c @ np.array([0.2126, 0.7152, 0.0722]))


def _contrast(a: Rgb, b: Rgb) -> float:
    lo, hi = sorted((_luminance(a), _luminance(b)))
    return (hi + 0.05) / (lo + 0.05)


def test_the_landing_label_reads_on_both_themes() -> None:
    """The label's text is the mark's colour: the track's orange vanishes on the light
    theme's box (about 1:1); the landing's colour stands out on both."""
    assert _contrast(TRACK_COLOUR, LABEL_BOXES["light"]) < 1.2
    for box in LABEL_BOXES.values():
        assert _contrast(LANDING_COLOUR, box) > 2.2
