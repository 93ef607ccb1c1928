"""Balls in the air seen by cameras with no model: placed by their blob's width, unless still.

A camera described by a range table alone (a ``lookup`` calibration, no height, no lens)
gives the 3-D track no ray, so a ball in the air is placed where its ray meets the ground:
metres out along it, which the ground tracker takes for a kick. The blob's width across the
bearing gives the range of the point under the ball at any height
(:mod:`estimator.width`); such a robot's estimates are placed by it where it shows a ball in
the air (:class:`~replay.locators.CorrectedLocator`, its ``width_robots``:
:func:`width_robots`), every robot's with ``--width-range``, none with
``--no-width-range``. By default the width lifts a robot's blobs only once they are seen to
agree with its calibration: the width assumes the images show the ball to scale, and a
camera file's table or the detector's outline may not (:meth:`StillFilter.trusted`: of its
last :data:`TRUST_WINDOW` measured blobs, the upper quartile of the width's range over the
calibrated one at least :data:`TRUST_RATIO`; a ball on the ground gives 1). Two things a box
of the ball's colour beside the field would otherwise do with it, and :class:`StillFilter`
and the tracker prevent:

- A box is wider than a ball at its ray's ground range, so its width lifts it and places it
  nearer, on the field. But a box stands still: where its ray meets the ground stays put,
  where a ball in the air's moves with it. :class:`StillFilter` remembers, per robot, where
  the rays of its lifted estimates met the ground, and an estimate whose ground point
  falls where they keep falling (:class:`~estimator.tracking.clutter.ClutterMap`: three
  over 0.2 s within 0.3 m in the last 3 s) is placed on the ground again, as without the
  width.
- The tracker calls a place clutter where its rejected estimates pile up; a lifted
  estimate counts where its ray meets the ground (``Measurement.ground_xy``), so a box
  lifted in one frame and not in the next is still one still place.

Deterministic: the estimates come in frame order.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

from estimator.detection import Detection
from estimator.tracking.clutter import ClutterMap
from estimator.width import width_range
from replay.records import RobotEstimate

if TYPE_CHECKING:
    from replay.options import ReplayOptions

__all__ = ["TRUST_COUNT", "TRUST_RATIO", "TRUST_WINDOW", "StillFilter", "blob_range_m",
           "ground_xy", "width_robots"]

TRUST_COUNT = 8
"""Blobs of a robot measured (wide enough) before its widths may lift a ball."""
TRUST_WINDOW = 200
"""The robot's last this many measured blobs are what its trust is judged on."""
TRUST_RATIO = 0.9
"""The least upper quartile of width range / calibrated range over those: below it the
blobs are wider than the calibration's ball (images not drawn to scale, an outline or a
calibration off), and a width would lift balls on the ground."""


def width_robots(options: ReplayOptions, robots: Sequence[str],
                 models: Collection[str]) -> frozenset[str]:
    """The robots whose blobs the width places (:mod:`estimator.width`): every robot with
    ``--width-range``, none with ``--no-width-range`` or the paper's method, else those
    whose camera has no model (``models``: the robots that have one)."""
    if options.method == "paper" or options.width_range is False:
        return frozenset()
    if options.width_range:
        return frozenset(robots)
    return frozenset(r for r in robots if r not in models)


def blob_range_m(det: Detection, centre_px: tuple[float, float]) -> float | None:
    """The range the blob's width across the bearing gives (None: too narrow to tell)."""
    w = width_range(det.outline_px, centre_px, (float(det.cx_px), float(det.cy_px)))
    return None if w is None else w.range_m


def ground_xy(e: RobotEstimate) -> tuple[float, float] | None:
    """Where the estimate's ray meets the ground [m], for a ball its width placed in the air
    (None: the estimate is placed there already)."""
    if e.ray_range_m is None:
        return None
    phi = e.robot_yaw_rad + e.bearing_rad
    return (e.robot_x_m + e.ray_range_m * math.cos(phi),
            e.robot_y_m + e.ray_range_m * math.sin(phi))


@dataclass
class StillFilter:
    """Per robot, whether its blob widths are trusted and where its lifted estimates' rays
    met the ground: an untrusted or still one is put back down."""

    _still: dict[str, ClutterMap] = field(default_factory=dict)
    """Robot -> the ground points of its lifted estimates."""
    _ratios: dict[str, list[float]] = field(default_factory=dict)
    """Robot -> width range / calibrated range of its last measured blobs."""

    def trusted(self, robot: str) -> bool:
        """Whether the robot's blob widths agree with its calibration: of the width's range
        over the calibrated one, over its blobs so far wide enough to measure (at least
        :data:`TRUST_COUNT`), the upper quartile is at least :data:`TRUST_RATIO` (a ball on
        the ground gives 1, one in the air less; a quarter of them on the ground will do)."""
        ratios = self._ratios.get(robot, [])
        return len(ratios) >= TRUST_COUNT and statistics.quantiles(
            ratios, n=4, method="inclusive")[2] >= TRUST_RATIO

    def placed(self, robot: str, stamp_ns: int, e: RobotEstimate,
               width_m: float | None) -> RobotEstimate:
        """``e`` as it is used: lifted, or back on the ground where the robot's widths are
        not trusted (yet) or such estimates of it keep falling (module docstring).
        ``width_m``: the range its blob's width gives (:func:`blob_range_m`). In frame
        order."""
        ground = ground_xy(e)
        ratios = self._ratios.setdefault(robot, [])
        ground_m = e.range_m if e.ray_range_m is None else e.ray_range_m
        if width_m is not None and ground_m > 0:
            ratios.append(width_m / ground_m)
            del ratios[:-TRUST_WINDOW]
        if ground is None:
            return e
        if not self.trusted(robot):
            return _down(e, ground)
        still = self._still.setdefault(robot, ClutterMap())
        covered = still.covers(stamp_ns, *ground)
        still.add(stamp_ns, *ground)
        return e if not covered else _down(e, ground)


def _down(e: RobotEstimate, ground: tuple[float, float]) -> RobotEstimate:
    """A lifted estimate placed where its ray meets the ground, as without the width."""
    assert e.ray_range_m is not None
    return replace(e, x_m=ground[0], y_m=ground[1], range_m=e.ray_range_m,
                   range_sigma_m=None, ray_range_m=None)
