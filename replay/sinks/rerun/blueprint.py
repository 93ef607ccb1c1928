"""The Rerun layout of a replay: one blueprint per scenario kind.

Every layout shows the robots' camera views as tabs (one camera at a time, large enough to
see the ball's outline; a last tab shows them all side by side), the field from above on a
grass background (so its colours read the same in the viewer's light and dark themes), and
the plots. A 3-D fusion's (``triangulate``, ``ballistic``) sees the field obliquely, from
above its near touchline, so that a ball in the air and its arc show, and plots its
height. What changes with the kind of scenario is where the space goes:

- ``paper`` (the paper's four still scenes, a handful of frames): the cameras take the
  full height beside the field; the plots are a strip under the field;
- ``moving`` (a tracked ball: fusion ``track``): the error plot under the cameras, the
  field, and the tracked and true speed under it;
- ``log`` (a rolling ball without the tracker, random scenes, a robot's own log): as
  ``moving``, without the speed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import rerun.blueprint as rrb

from dsp.field import FieldSpec
from replay.sinks.style import FIELD_BACKGROUND

__all__ = ["KINDS", "blueprint", "cameras_view", "field_view", "learnt_view", "scenario_kind"]

KINDS = ("paper", "moving", "log")


def scenario_kind(scenario: str | None, *, tracked: bool = False) -> str:
    """The layout for a scenario's name (None: a log without one)."""
    if scenario is not None and scenario.startswith("scenario"):
        return "paper"
    if tracked:
        return "moving"
    return "log"


def cameras_view(robots: Sequence[str], prefix: str = "",
                 images_from: str | None = None, extra: Sequence[rrb.View] = ()) -> rrb.Container:
    """The cameras as tabs (and all of them in the last, then ``extra``); ``prefix``: a
    run's entities'; ``images_from``: the prefix whose images to show under them (one copy
    for two runs)."""
    label = f"{prefix.strip('/')} " if prefix else ""

    def view(r: str, name: str) -> rrb.View:
        origin = f"{prefix}/robots/{r}/camera"
        contents = ["$origin/**"]
        if images_from is not None:
            contents.insert(0, f"{images_from}/robots/{r}/camera/image")
        return rrb.Spatial2DView(origin=origin, name=name, contents=contents)

    tabs: list[rrb.Container | rrb.View] = [view(r, f"{label}{r} camera") for r in robots]
    if len(robots) > 1:
        tabs.append(rrb.Grid(*[view(r, f"{label}{r}") for r in robots],
                             name=f"{label}all cameras"))
    tabs.extend(extra)
    return rrb.Tabs(*tabs, active_tab=0, name=f"{label}cameras")


def field_view(field: FieldSpec, prefix: str = "", *, oblique: bool = False) -> rrb.View:
    """The field from above; ``prefix``: a run's entities'. ``oblique``: from above its
    near touchline instead of straight down, so that a ball in the air stands off its line
    to the ground and the flight's arc shows (a 3-D fusion's view)."""
    # straight down from high enough that the field and its border fit a wide panel (the
    # viewer's vertical field of view is about 55 deg)
    eye_m = field.width_m + 2 * field.border_m
    title = f"{prefix.strip('/') + ' ' if prefix else ''}field, %s ({field.name})"
    if oblique:  # as far, 35 deg off the vertical: 1 m up shows as 0.57 m on the ground;
        # aimed a metre short of the centre, as the perspective draws the near half larger
        tilt, aim = math.radians(35.0), (0.0, -1.0, 0.0)
        eye = rrb.EyeControls3D(
            position=(0.0, aim[1] - eye_m * math.sin(tilt), eye_m * math.cos(tilt)),
            look_target=aim, eye_up=(0.0, 0.0, 1.0))
    else:
        eye = rrb.EyeControls3D(position=(0.0, -0.01, eye_m), look_target=(0.0, 0.0, 0.0),
                                eye_up=(0.0, 1.0, 0.0))
    return rrb.Spatial3DView(
        origin=f"{prefix}/field", name=title % ("from above" if oblique else "top-down"),
        background=rrb.Background(color=FIELD_BACKGROUND), line_grid=rrb.LineGrid3D(False),
        eye_controls=eye)


def learnt_view(prefix: str = "") -> rrb.View:
    """The tab of what the replay learnt of each robot's pose (logged when it ends);
    ``prefix``: a run's entities' (a short name: two runs' tabs share the width)."""
    name = f"{prefix.strip('/')} learnt" if prefix else "what the replay learnt"
    return rrb.TextDocumentView(origin=f"{prefix}/summary/learnt", name=name)


def _series(origin: str, name: str) -> rrb.View:
    return rrb.TimeSeriesView(origin=origin, name=name,
                              plot_legend=rrb.PlotLegend(rrb.Corner2D.RightTop))


def _layout(robots: Sequence[str], field: FieldSpec, kind: str,
            heights: bool) -> rrb.Container:
    error = _series("/plots/error", "error vs ground truth [m]")
    small = [_series("/plots/blob_area", "blob area [px]"),
             _series("/plots/pose_sigma", "pose sigma [cm]"),
             _series("/plots/estimator_ms", "estimator time [ms]")]
    if kind == "paper":
        # a handful of frames of a still ball: the images and the field say most
        return rrb.Horizontal(
            cameras_view(robots, extra=[learnt_view()]),
            rrb.Vertical(field_view(field, oblique=heights), rrb.Horizontal(error, *small),
                         row_shares=[3.0, 1.2]),
            column_shares=[1.0, 1.45])
    bottom: list[rrb.View] = small
    shares = [1.0] * len(small)
    if kind == "moving":
        bottom = [_series("/plots/speed", "ball speed [m/s]"), *small]
        shares = [2.0, *shares]
    if heights:  # the ball's height beside the truth's: the arc, to read off
        bottom.insert(len(bottom) - len(small), _series("/plots/height", "ball height [m]"))
        shares.insert(len(shares) - len(small), 2.0)
    return rrb.Horizontal(
        rrb.Vertical(cameras_view(robots, extra=[learnt_view()]), error, row_shares=[3.0, 2.0]),
        rrb.Vertical(field_view(field, oblique=heights),
                     rrb.Horizontal(*bottom, column_shares=shares),
                     row_shares=[3.0, 1.3]),
        column_shares=[1.0, 1.6])


def blueprint(robots: Sequence[str], field: FieldSpec, kind: str, *,
              heights: bool = False) -> rrb.Blueprint:
    """The layout of a replay of ``robots`` on ``field`` for a scenario ``kind``;
    ``heights``: a 3-D fusion's (the field seen obliquely, the height plotted)."""
    if kind not in KINDS:
        raise ValueError(f"scenario kind {kind!r}; choose one of {', '.join(KINDS)}")
    return rrb.Blueprint(
        _layout(robots, field, kind, heights),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline="sim_time", play_state="following"),
    )
