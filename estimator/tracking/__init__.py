"""The ball tracker: robots' estimates at their own stamps -> the ball's position and velocity.

- :mod:`estimator.tracking.tracker`: :class:`BallTracker` (gate, manoeuvres, re-acquisition,
  late estimates); :mod:`estimator.tracking.one_shot`: :class:`TrackFusion`, the tracker as a
  one-shot fusion;
- :mod:`estimator.tracking.offsets`: the track's velocity, from a filter beside it that
  holds each robot's offset (how far its estimates sit from the others');
- :mod:`estimator.tracking.model`: the motion model and the Kalman filter's steps;
- :mod:`estimator.tracking.params`: :class:`TrackerParams`; :mod:`estimator.tracking.state`:
  its input :class:`Measurement` and output :class:`TrackState`;
- :mod:`estimator.tracking.reacquire`, :mod:`estimator.tracking.clutter`: restarting on a
  new path, and where false blobs keep falling;
- :mod:`estimator.tracking.smoother`: the offline RTS smoother over a recorded track;
- :mod:`estimator.tracking.bias`: each robot's drifting pose bias, learned from how its
  estimates disagree with the track (``--localise ball``).

It builds on the shared leaves :mod:`estimator.estimates` and :mod:`estimator.noise`, never
on :mod:`estimator.fusion` (which offers the tracker as its ``track`` method).
"""

from __future__ import annotations

from estimator.tracking.clutter import ClutterMap
from estimator.tracking.one_shot import TrackFusion
from estimator.tracking.params import GATE_CHI2_999, TrackerParams
from estimator.tracking.smoother import FilterNode, SmoothedTrack
from estimator.tracking.state import Measurement, TrackState
from estimator.tracking.tracker import BallTracker

__all__ = [
    "GATE_CHI2_999",
    "BallTracker",
    "ClutterMap",
    "FilterNode",
    "Measurement",
    "SmoothedTrack",
    "TrackFusion",
    "TrackState",
    "TrackerParams",
]
