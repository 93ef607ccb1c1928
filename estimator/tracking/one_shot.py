"""The tracker as a one-shot fusion of simultaneous estimates (``--fusion track`` in the
window fusions' place: :class:`TrackFusion`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

from estimator.estimates import BallEstimate, FusedEstimate, covariance_rows
from estimator.noise import CalibratedNoise, Noise
from estimator.tracking.params import TrackerParams
from estimator.tracking.state import Measurement
from estimator.tracking.tracker import BallTracker

__all__ = ["TrackFusion"]


@dataclass(frozen=True)
class TrackFusion:
    """The tracker as a one-shot :class:`~estimator.fusion.Fusion`: simultaneous estimates
    fed to a fresh tracker in input order; the result is the track at that instant (the
    estimates that pass the gate, inverse-covariance weighted), its robots those accepted."""

    noise: Noise = field(default_factory=CalibratedNoise)
    params: TrackerParams = field(default_factory=TrackerParams)

    @property
    def name(self) -> str:
        return "track"

    def fuse(self, estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        if not estimates:
            return None
        tracker = BallTracker(self.params)
        for e in estimates:
            tracker.update(Measurement(0, e.robot, e.x_m, e.y_m,
                                       covariance_rows(self.noise.covariance(e))))
        state = tracker.state_at(0)
        if state is None:  # pragma: no cover - a track at stamp 0 always exists
            return None
        return FusedEstimate(state.x_m, state.y_m, state.position_covariance,
                             tracker.accepted_at(0))
