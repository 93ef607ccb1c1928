"""The paper's calibration procedure (Section II.G, Fig. 10-11), run in the simulator.

A robot stands alone on the field; the ball is put in front of it from 0.4 m to 9.0 m in
0.1 m steps (and, to show whether the camera is isotropic, in other directions too); each
omni image is rendered, the ball detected, and the centroid's pixel radius r (eq. 3) kept
beside the true range d (robot centre to ball centre, horizontal). Then every calibration
model is fitted to the (r, d) samples.

Choosing "the best" model on the samples it was fitted to would always pick the lookup
table (it interpolates its own samples), so models are compared on held-out samples:
two-fold cross-validation over alternate distances, the rule every calibration shares
(:func:`estimator.calibration.fit_all`). Each model is fitted to every sample and written
with its fit quality.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from dsp.errors import UsageError
from estimator.calibration import FitResult, fit_all, fit_linear
from estimator.camera import CameraModel
from estimator.constants import PAPER_B_M, PAPER_K_M_PER_PX, PAPER_R2
from estimator.detection import detect_ball
from recorder.omni import DEFAULT_FACE_PX, OmniRenderer
from recorder.world import World, field_spec

__all__ = [
    "PAPER_FIT",
    "CalibrationRun",
    "Sample",
    "calibrate",
    "distances_m",
    "sample_ranges",
]

PAPER_FIT = {"a_m_per_px": PAPER_K_M_PER_PX, "b_m": PAPER_B_M, "r2": PAPER_R2}
"""The paper's eq. 4 and its R^2, printed beside ours."""

ROBOT = "robot1"
ROBOT_POSE = (-4.5, 0.0, 0.0)
"""Where the calibrating robot stands (x_m, y_m, yaw_rad): on our half, facing +x, so the
ball 9 m ahead is still on the field."""

@dataclass(frozen=True)
class Sample:
    """One ball placement: its direction (robot frame, deg, 0 = forward, 90 = left), true
    range, and what the detector saw (NaN when the ball was not found)."""

    direction_deg: float
    range_m: float
    r_px: float
    bearing_error_rad: float


@dataclass(frozen=True)
class CalibrationRun:
    camera: dict[str, object]
    samples: tuple[Sample, ...]
    fits: tuple[FitResult, ...]
    """Every model fitted to all detected samples, best (lowest held-out RMS) first."""
    holdout_rms_m: dict[str, float]
    """Model name -> RMS [m] on held-out samples (two-fold over alternate distances)."""
    paper_procedure: FitResult
    """The paper's own procedure: a linear fit to the forward samples only."""
    per_direction: dict[float, FitResult]
    """A linear fit per direction: equal slopes mean an isotropic camera."""

    @property
    def best(self) -> FitResult:
        return self.fits[0]

    @property
    def detected(self) -> int:
        return sum(1 for s in self.samples if math.isfinite(s.r_px))


def distances_m(start_m: float = 0.4, stop_m: float = 9.0, step_m: float = 0.1) -> list[float]:
    """start, start + step, ..., stop (inclusive), rounded to the millimetre."""
    if step_m <= 0 or stop_m < start_m or start_m <= 0:
        raise UsageError(
            f"distances {start_m}..{stop_m} m step {step_m} m: need 0 < start <= stop, step > 0"
        )
    n = math.floor((stop_m - start_m) / step_m + 1e-9) + 1
    return [round(start_m + i * step_m, 3) for i in range(n)]


def sample_ranges(
    camera: CameraModel,
    distances: Sequence[float],
    directions_deg: Sequence[float] = (0.0,),
    *,
    renderer: str = "auto",
    face_px: int = DEFAULT_FACE_PX,
    on_sample: Callable[[Sample], None] | None = None,
) -> tuple[list[Sample], str]:
    """Render the ball at each distance in each direction; return the samples and the
    renderer that drew them."""
    omni = OmniRenderer(camera, face_px=face_px)
    cu, cv_ = camera.centre_px
    rx, ry, ryaw = ROBOT_POSE
    samples: list[Sample] = []
    with World(field_spec("18x12"), renderer=renderer) as world:
        world.add_robot(ROBOT)
        world.set_robot_pose(ROBOT, rx, ry, ryaw)
        for direction in directions_deg:
            phi = ryaw + math.radians(direction)
            for d in distances:
                world.set_ball(rx + d * math.cos(phi), ry + d * math.sin(phi))
                image = omni.render(world, ROBOT, rx, ry, ryaw)
                det = detect_ball(image)
                if det is None:
                    sample = Sample(float(direction), float(d), math.nan, math.nan)
                else:
                    du, dv = det.cx_px - cu, det.cy_px - cv_
                    theta = math.atan2(-du, -dv)  # robot-frame bearing (docs/api.md)
                    err = math.remainder(theta - math.radians(direction), math.tau)
                    sample = Sample(float(direction), float(d), math.hypot(du, dv), err)
                samples.append(sample)
                if on_sample is not None:
                    on_sample(sample)
        used = world.renderer
    return samples, used


def _arrays(samples: Sequence[Sample]) -> tuple[np.ndarray, np.ndarray]:
    ok = [s for s in samples if math.isfinite(s.r_px)]
    return np.array([s.r_px for s in ok]), np.array([s.range_m for s in ok])


def _held_out(fit: FitResult) -> float:
    return math.inf if fit.holdout_rms_m is None else fit.holdout_rms_m


def calibrate(camera: CameraModel, samples: Sequence[Sample]) -> CalibrationRun:
    """Fit every model to the detected samples and rank them on held-out samples."""
    r, d = _arrays(samples)
    if len(r) < 6:
        raise UsageError(
            f"only {len(r)} of {len(samples)} ball placements were detected; need at least "
            "6 to fit (give more placements: a smaller --step or more --directions)"
        )
    ranked = fit_all(r, d)  # ranked on held-out samples: at least 6 give 3 ranges a fold
    forward = [s for s in samples if s.direction_deg == 0.0] or list(samples)
    per_direction: dict[float, FitResult] = {}
    for direction in sorted({s.direction_deg for s in samples}):
        rd, dd = _arrays([s for s in samples if s.direction_deg == direction])
        if len(rd) >= 2:
            per_direction[direction] = fit_linear(rd, dd)
    return CalibrationRun(
        camera=dict(camera.to_dict()),
        samples=tuple(samples),
        fits=tuple(ranked),
        holdout_rms_m={f.model.name: _held_out(f) for f in ranked},
        paper_procedure=fit_linear(*_arrays(forward)),
        per_direction=per_direction,
    )
