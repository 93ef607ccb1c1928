"""Replay statistics: counts and error statistics gathered from the frames and steps.

:class:`ReplayStats` is a sink like the others: it sees every frame and step, and keeps
constant memory. Its :meth:`~ReplayStats.summary_dict` is the results file's ``summary``;
:meth:`~ReplayStats.summary` the :class:`ReplaySummary` that :func:`replay.replay` returns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dsp.jsonio import Json
from replay.log import RecoveryLoss
from replay.records import FrameResult, StepResult
from replay.sink import SinkBase

__all__ = ["ErrorStats", "ReplayStats", "ReplaySummary", "RobotSummary", "VelocitySummary"]


@dataclass
class ErrorStats:
    """Running error statistics (constant memory)."""

    n: int = 0
    sum_sq: float = 0.0
    sum_abs: float = 0.0
    max_abs: float = 0.0

    def add(self, e: float) -> None:
        self.n += 1
        self.sum_sq += e * e
        self.sum_abs += e
        self.max_abs = max(self.max_abs, e)

    @property
    def rmse_m(self) -> float | None:
        return math.sqrt(self.sum_sq / self.n) if self.n else None

    @property
    def mean_m(self) -> float | None:
        return self.sum_abs / self.n if self.n else None

    def to_dict(self) -> dict[str, Json]:
        return {"errors": self.n, "rmse_m": self.rmse_m, "mean_error_m": self.mean_m,
                "max_error_m": self.max_abs if self.n else None}


@dataclass(frozen=True)
class RobotSummary:
    frames: int
    detections: int
    estimates: int
    rmse_m: float | None
    mean_error_m: float | None
    max_error_m: float | None


@dataclass(frozen=True)
class VelocitySummary:
    """Errors |v - v_true| of the fused velocity [m/s]."""

    errors: int
    rmse_m_s: float | None
    mean_error_m_s: float | None
    max_error_m_s: float | None


@dataclass(frozen=True)
class ReplaySummary:
    """What a replay did. ``wall_s``, ``frames_per_s`` and ``estimator_ms`` are machine
    dependent: they go to the terminal and Rerun, never into results files."""

    path: Path
    robots: tuple[str, ...]
    frames: int
    steps: int
    fused_steps: int
    skipped: dict[str, int]
    per_robot: dict[str, RobotSummary]
    fused: RobotSummary
    undecodable_messages: int
    recovered: dict[str, Json] | None
    """What ``--recover`` lost, as the results file's ``log.recovered`` (None without it)."""
    wall_s: float
    estimator_ms: float | None
    outputs: tuple[Path, ...] = ()
    fused_velocity: VelocitySummary | None = None
    """The fused velocity's errors [m/s], when the fusion estimates a velocity and the log
    holds the true one."""
    loss: RecoveryLoss | None = None
    """``recovered`` as read (None without ``--recover``)."""
    pose_sources: dict[str, int] | None = None
    """With ``--localise lines``: frames by where their pose came from ("lines", "held",
    "prior"); None without it."""
    lifted: int | None = None
    """With ``--width-range``: the estimates whose blob's width placed a ball in the air
    under itself; None without it."""
    beliefs: dict[str, dict[str, Json]] | None = None
    """What the replay came to believe of each robot's pose that the log did not state (the
    learnt pose spread, the bias corrected by): :meth:`replay.estimation.FrameEstimator.beliefs`;
    None when nothing was learnt."""
    pipeline: str | None = None
    """What ran, in one line (:meth:`replay.profiles.Pipeline.describe`), for a replay made
    from a profile."""
    warnings: tuple[str, ...] = ()
    """What the user must know about a replay that worked (:mod:`replay.diagnosis`); the
    commands print them on stderr (``-q`` does not hide them)."""

    @property
    def frames_per_s(self) -> float:
        return self.frames / self.wall_s if self.wall_s > 0 else float("nan")


@dataclass
class _RobotCounts:
    frames: int = 0
    detections: int = 0
    estimates: int = 0
    errors: ErrorStats = field(default_factory=ErrorStats)

    def summary(self) -> RobotSummary:
        e = self.errors
        return RobotSummary(self.frames, self.detections, self.estimates, e.rmse_m, e.mean_m,
                            e.max_abs if e.n else None)


class ReplayStats(SinkBase):
    """Counts per robot and fused, skipped frames by reason, estimator time (display only)."""

    def __init__(self, robots: tuple[str, ...], *, width_range: bool = False) -> None:
        self.robots = robots
        self.lifted: int | None = 0 if width_range else None
        """``--width-range``: estimates placed under a ball in the air (None: not asked)."""
        self.frames = 0
        self.steps = 0
        self.fused_steps = 0
        self.skipped: dict[str, int] = {}
        self.per_robot = {r: _RobotCounts() for r in robots}
        self.fused_errors = ErrorStats()
        self.velocity_errors = ErrorStats()
        self.estimator_s = 0.0
        self.estimator_n = 0
        self.undecodable = 0
        self.recovered: RecoveryLoss | None = None
        self.pose_sources: dict[str, int] = {}
        self.fit_statuses: dict[str, int] = {}
        self.beliefs: dict[str, dict[str, Json]] = {}
        """Set once the log is read (:meth:`finish`)."""

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        self.frames += 1
        counts = self.per_robot[result.robot]
        counts.frames += 1
        if result.status.skipped:
            self.skipped[result.status.value] = self.skipped.get(result.status.value, 0) + 1
        if image_bgr is not None:
            self.estimator_s += result.estimator_s
            self.estimator_n += 1
        loc = result.localisation
        if loc is not None:
            self.pose_sources[loc.source] = self.pose_sources.get(loc.source, 0) + 1
            self.fit_statuses[loc.status] = self.fit_statuses.get(loc.status, 0) + 1
        if result.detection is not None:
            counts.detections += 1
        if result.estimate is not None:
            counts.estimates += 1
            if self.lifted is not None and result.estimate.ray_range_m is not None:
                self.lifted += 1
            if result.error_m is not None:
                counts.errors.add(result.error_m)

    def step(self, result: StepResult) -> None:
        self.steps += 1
        if result.fused is not None:
            self.fused_steps += 1
            if result.error_m is not None:
                self.fused_errors.add(result.error_m)
            velocity_error = result.velocity_error_m_s
            if velocity_error is not None:
                self.velocity_errors.add(velocity_error)

    def finish(self, *, undecodable: int, recovered: RecoveryLoss | None,
               beliefs: dict[str, dict[str, Json]] | None = None) -> None:
        """What only the reader (and the estimator) knows once the log is read."""
        self.undecodable = undecodable
        self.recovered = recovered
        self.beliefs = dict(beliefs or {})

    def summary_dict(self) -> dict[str, Json]:
        """The results file's ``summary``."""
        return {
            "frames": self.frames,
            "steps": self.steps,
            "fused_steps": self.fused_steps,
            "skipped": dict(sorted(self.skipped.items())),
            "robots": {
                r: {"frames": c.frames, "detections": c.detections, "estimates": c.estimates,
                    **c.errors.to_dict()}
                for r, c in self.per_robot.items()
            },
            "fused": {"estimates": self.fused_steps, **self.fused_errors.to_dict(),
                      **self._velocity_dict()},
            "undecodable_messages": self.undecodable,
            **self._localisation_dict(),
            **({} if self.lifted is None else {"width": {"lifted": self.lifted}}),
            **({"learnt": dict(self.beliefs)} if self.beliefs else {}),
        }

    def _localisation_dict(self) -> dict[str, Json]:
        """``{"localisation": {...}}`` when frames were localised, else nothing."""
        if not self.pose_sources:
            return {}
        return {"localisation": {"sources": dict(sorted(self.pose_sources.items())),
                                 "statuses": dict(sorted(self.fit_statuses.items()))}}

    def _velocity_dict(self) -> dict[str, Json]:
        """``{"velocity": {...}}`` when there are velocity errors, else nothing (so a
        window fusion's summary is as it was)."""
        v = self.velocity_errors
        if not v.n:
            return {}
        return {"velocity": {"errors": v.n, "rmse_m_s": v.rmse_m, "mean_error_m_s": v.mean_m,
                             "max_error_m_s": v.max_abs}}

    def summary(self, path: Path, *, wall_s: float,
                outputs: tuple[Path, ...] = ()) -> ReplaySummary:
        fused = _RobotCounts(self.steps, self.fused_steps, self.fused_steps, self.fused_errors)
        return ReplaySummary(
            path=path,
            robots=self.robots,
            frames=self.frames,
            steps=self.steps,
            fused_steps=self.fused_steps,
            skipped=dict(sorted(self.skipped.items())),
            per_robot={r: c.summary() for r, c in self.per_robot.items()},
            fused=fused.summary(),
            undecodable_messages=self.undecodable,
            recovered=None if self.recovered is None else self.recovered.to_dict(),
            wall_s=wall_s,
            estimator_ms=(1e3 * self.estimator_s / self.estimator_n) if self.estimator_n
            else None,
            outputs=outputs,
            fused_velocity=None if not self.velocity_errors.n else VelocitySummary(
                self.velocity_errors.n, self.velocity_errors.rmse_m, self.velocity_errors.mean_m,
                self.velocity_errors.max_abs),
            loss=self.recovered,
            pose_sources=dict(sorted(self.pose_sources.items())) if self.pose_sources else None,
            lifted=self.lifted,
            beliefs=dict(self.beliefs) or None,
        )
