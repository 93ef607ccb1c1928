"""How replay draws things, shared by the Rerun recording and the matplotlib figures.

Colours are mid-luminance so they read on Rerun's light and dark themes and on white
paper alike; the field view has its own grass background, so its white lines and the
markers on it look the same whatever the theme. Sizes are to scale: a robot is its
footprint (MSL robots fit a 0.52 m square; the simulated one is 0.49 m), the ball is
:data:`estimator.constants.BALL_RADIUS_M`.
"""

from __future__ import annotations

import math

from estimator.constants import BALL_RADIUS_M

__all__ = [
    "BALL_COLOUR",
    "BALL_RADIUS_M",
    "CANDIDATE_COLOUR",
    "FIELD_BACKGROUND",
    "FIELD_LINE_COLOUR",
    "FUSED_COLOUR",
    "LANDING_COLOUR",
    "LINE_POINT_COLOUR",
    "OUTLINE_COLOUR",
    "RADIUS_COLOUR",
    "ROBOT_COLOURS",
    "ROBOT_FOOTPRINT_M",
    "TRACK_COLOUR",
    "TRUTH_COLOUR",
    "Rgb",
    "footprint",
    "hex_colour",
    "robot_colour",
]

Rgb = tuple[int, int, int]

ROBOT_COLOURS: tuple[Rgb, ...] = (
    (68, 119, 230),   # blue
    (170, 68, 200),   # purple
    (0, 153, 170),    # teal
    (200, 120, 30),   # ochre
    (210, 60, 140),   # pink
)
"""One per robot, in the log's robot order (cycled)."""
FUSED_COLOUR: Rgb = (230, 40, 40)
"""The fused estimate: red, in the field view and the plots."""
TRACK_COLOUR: Rgb = (255, 120, 0)
"""The tracked ball's trail and velocity arrow."""
LANDING_COLOUR: Rgb = (255, 236, 214)
"""The predicted landing's mark and label: a pale orange. A label's text is its entity's
colour on a half-transparent box, grey-green on the grass in the light theme, where the
track's orange all but vanishes (contrast 1.0:1); this reads there (2.4:1) and in the dark
theme (8:1), and stands apart from the orange arrow it lies under seen from above."""
TRUTH_COLOUR: Rgb = (250, 230, 60)
"""The true ball: yellow, so it stands out on the grass and beside the red estimate."""
BALL_COLOUR: Rgb = (255, 140, 0)
"""The detected ball's centroid in the camera images."""
OUTLINE_COLOUR: Rgb = (0, 230, 255)
RADIUS_COLOUR: Rgb = (255, 60, 255)
CANDIDATE_COLOUR: Rgb = (200, 200, 200)
"""The real detector's candidates that did not win (grey boxes)."""
FIELD_BACKGROUND: Rgb = (38, 102, 56)
"""The field view's background: grass, whatever the viewer's theme."""
FIELD_LINE_COLOUR: Rgb = (245, 245, 245)
LINE_POINT_COLOUR: Rgb = (90, 255, 90)
"""The field-line points the pose fit used, in the camera images (``--localise lines``)."""
ROBOT_FOOTPRINT_M = 0.5
"""Side of the square a robot is drawn as [m] (to scale)."""


def robot_colour(index: int) -> Rgb:
    """The colour of the log's ``index``-th robot (0-based)."""
    return ROBOT_COLOURS[index % len(ROBOT_COLOURS)]


def hex_colour(rgb: Rgb) -> str:
    """``(68, 119, 230)`` -> ``"#4477e6"`` (for matplotlib)."""
    return "#" + "".join(f"{c:02x}" for c in rgb)


def footprint(x_m: float, y_m: float, yaw_rad: float,
              side_m: float = ROBOT_FOOTPRINT_M) -> list[tuple[float, float]]:
    """A robot's square footprint as a closed polyline (5 corners, the first repeated)."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    h = side_m / 2.0
    corners = [(h, h), (-h, h), (-h, -h), (h, -h), (h, h)]
    return [(x_m + c * u - s * v, y_m + s * u + c * v) for u, v in corners]
