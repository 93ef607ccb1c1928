"""The replay's Rerun layout: a 3-D fusion's shows the ball's height, a level one the
field straight from above."""

from __future__ import annotations

from collections.abc import Iterator
from typing import cast

import numpy as np
import pytest
import rerun.blueprint as rrb

from dsp.field import DEFAULT_FIELD, FIELDS
from replay.sinks.rerun.blueprint import blueprint

ROBOTS = ("robot1", "robot2", "robot3")


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
