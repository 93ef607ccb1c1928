"""The paper's calibration procedure (Section II.G, Fig. 10-11), run in the simulator.

A robot stands alone on the field; the ball is put in front of it from 0.4 m to 9.0 m in
0.1 m steps (and, to show whether the camera is isotropic, in other directions too); each
omni image is rendered, the ball detected, and the centroid's pixel radius r (eq. 3) kept
beside the true range d (robot centre to ball centre, horizontal). Then every calibration
model is fitted to the (r, d) samples.

Choosing "the best" model on the samples it was fitted to would always pick the lookup
table (it interpolates its own samples), so models are compared on held-out samples:
two-fold cross-validation over alternate distances. The chosen kind is then refitted on
every sample and written with its fit quality.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from dsp.errors import UsageError
from estimator.calibration import (
    PAPER_CALIBRATION,
    Calibration,
    FitResult,
    fit_linear,
    fit_lookup,
    fit_mirror,
)
from estimator.camera import CameraModel
from estimator.constants import PAPER_B_M, PAPER_K_M_PER_PX, PAPER_R2
from estimator.detection import detect_ball
from estimator.errors import CalibrationError
from recorder.omni import DEFAULT_FACE_PX, OmniRenderer
from recorder.world import World, field_spec

__all__ = [
    "PAPER_FIT",
    "CalibrationRun",
    "Sample",
    "calibrate",
    "distances_m",
    "plot_png",
    "sample_ranges",
]

PAPER_FIT = {"a_m_per_px": PAPER_K_M_PER_PX, "b_m": PAPER_B_M, "r2": PAPER_R2}
"""The paper's eq. 4 and its R^2, printed beside ours."""

ROBOT = "robot1"
ROBOT_POSE = (-4.5, 0.0, 0.0)
"""Where the calibrating robot stands (x_m, y_m, yaw_rad): on our half, facing +x, so the
ball 9 m ahead is still on the field."""

_FITTERS: dict[str, Callable[[np.ndarray, np.ndarray], FitResult]] = {
    "linear": fit_linear,
    "mirror": fit_mirror,
    "lookup": fit_lookup,
}


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


def _holdout_rms(name: str, r: np.ndarray, d: np.ndarray) -> float:
    """Two-fold cross-validation over alternate distances (every direction's sample at a
    distance falls in the same fold): fit on one fold, test on the other, and back."""
    rank = np.searchsorted(np.unique(d), d)
    sq: list[float] = []
    for train in (0, 1):
        tr = rank % 2 == train
        model = _FITTERS[name](r[tr], d[tr]).model
        for ri, di in zip(r[~tr], d[~tr], strict=False):
            try:
                sq.append((float(model.range_m(float(ri))) - float(di)) ** 2)
            except CalibrationError:
                sq.append(math.inf)
    return math.sqrt(sum(sq) / len(sq)) if sq else math.inf


def calibrate(camera: CameraModel, samples: Sequence[Sample]) -> CalibrationRun:
    """Fit every model to the detected samples and rank them on held-out samples."""
    r, d = _arrays(samples)
    if len(r) < 6:
        raise UsageError(
            f"only {len(r)} of {len(samples)} ball placements were detected; need at least "
            "6 to fit (give more placements: a smaller --step or more --directions)"
        )
    fits: dict[str, FitResult] = {}
    holdout: dict[str, float] = {}
    for name, fitter in _FITTERS.items():
        try:
            fits[name] = fitter(r, d)
            holdout[name] = _holdout_rms(name, r, d)
        except CalibrationError:
            continue
    ranked = sorted(fits, key=lambda n: (holdout[n], list(_FITTERS).index(n)))
    forward = [s for s in samples if s.direction_deg == 0.0] or list(samples)
    per_direction: dict[float, FitResult] = {}
    for direction in sorted({s.direction_deg for s in samples}):
        rd, dd = _arrays([s for s in samples if s.direction_deg == direction])
        if len(rd) >= 2:
            per_direction[direction] = fit_linear(rd, dd)
    return CalibrationRun(
        camera=dict(camera.to_dict()),
        samples=tuple(samples),
        fits=tuple(fits[n] for n in ranked),
        holdout_rms_m={n: holdout[n] for n in ranked},
        paper_procedure=fit_linear(*_arrays(forward)),
        per_direction=per_direction,
    )


# --- the figure (like the paper's Fig. 10, with residuals) -----------------------------------
_W, _H = 1000, 760
_COLOURS = [(200, 80, 0), (0, 140, 0), (0, 0, 200), (160, 0, 160), (0, 140, 160), (90, 90, 90)]


def _model_curve(model: Calibration, r: np.ndarray) -> np.ndarray:
    out = np.full(r.shape, np.nan)
    for i, ri in enumerate(r):
        try:
            out[i] = float(model.range_m(float(ri)))
        except CalibrationError:
            pass
    return out


def plot_png(run: CalibrationRun) -> bytes:
    """Samples, the fitted models and the paper's line (top); residuals of the best model
    per direction (bottom). Drawn with OpenCV, returned as PNG bytes."""
    img = np.full((_H, _W, 3), 255, np.uint8)
    r_all, d_all = _arrays(run.samples)
    r_max = max(float(r_all.max()) * 1.05, 1.0)
    d_max = max(float(d_all.max()) * 1.1, 1.0)
    best = run.best.model
    resid = d_all - _model_curve(best, r_all)
    res_lim = max(float(np.nanmax(np.abs(resid))) * 1.2, 0.01) if len(resid) else 0.01
    top = (70, 40, _W - 30, 470)       # x0, y0, x1, y1
    bot = (70, 540, _W - 30, _H - 50)

    def to_px(box: tuple[int, int, int, int], x: float, y: float, ylo: float, yhi: float
              ) -> tuple[int, int]:
        x0, y0, x1, y1 = box
        return (round(x0 + (x1 - x0) * x / r_max),
                round(y1 - (y1 - y0) * (y - ylo) / (yhi - ylo)))

    font = cv2.FONT_HERSHEY_SIMPLEX
    for box, ylo, yhi, label in ((top, 0.0, d_max, "range d [m]"),
                                 (bot, -res_lim, res_lim, "residual [m]")):
        cv2.rectangle(img, box[:2], box[2:], (0, 0, 0), 1)
        cv2.putText(img, label, (box[0] - 60, box[1] - 10), font, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
        for k in range(6):
            yv = ylo + (yhi - ylo) * k / 5
            px = to_px(box, 0, yv, ylo, yhi)
            digits = 3 if yhi - ylo < 0.2 else 2
            cv2.putText(img, f"{yv:.{digits}f}", (5, px[1] + 4), font, 0.4, (0, 0, 0), 1,
                        cv2.LINE_AA)
            xv = r_max * k / 5
            qx = to_px(box, xv, ylo, ylo, yhi)
            cv2.putText(img, f"{xv:.0f}", (qx[0] - 10, box[3] + 16), font, 0.4, (0, 0, 0), 1,
                        cv2.LINE_AA)
    cv2.putText(img, "pixel radius r [px]", (_W // 2 - 70, _H - 12), font, 0.5, (0, 0, 0), 1,
                cv2.LINE_AA)
    zero = to_px(bot, 0, 0.0, -res_lim, res_lim)
    cv2.line(img, (bot[0], zero[1]), (bot[2], zero[1]), (150, 150, 150), 1)
    directions = sorted(run.per_direction)
    for s in run.samples:
        if not math.isfinite(s.r_px):
            continue
        colour = _COLOURS[directions.index(s.direction_deg) % len(_COLOURS)]
        cv2.circle(img, to_px(top, s.r_px, s.range_m, 0.0, d_max), 3, colour, -1, cv2.LINE_AA)
        res = s.range_m - float(_model_curve(best, np.array([s.r_px]))[0])
        if math.isfinite(res):
            cv2.circle(img, to_px(bot, s.r_px, res, -res_lim, res_lim), 3, colour, -1,
                       cv2.LINE_AA)
    grid = np.linspace(0.0, r_max, 300)
    curves = [(PAPER_CALIBRATION, (0, 0, 0), "paper eq. 4")] + [
        (f.model, _COLOURS[(i + 3) % len(_COLOURS)], f"{f.model.name}") for i, f in
        enumerate(run.fits)]
    for model, colour, _ in curves:
        ys = _model_curve(model, grid)
        pts = [to_px(top, x, y, 0.0, d_max) for x, y in zip(grid, ys, strict=False)
               if math.isfinite(y) and 0.0 <= y <= d_max]
        if len(pts) > 1:
            cv2.polylines(img, [np.array(pts, np.int32)], False, colour, 1, cv2.LINE_AA)
    cam = str(run.camera.get("model", "?"))
    cv2.putText(img, f"camera {cam}: samples by direction, fitted models, paper's line",
                (top[0] + 90, 25), font, 0.55, (0, 0, 0), 1, cv2.LINE_AA)
    y = top[1] + 20
    for i, direction in enumerate(directions):
        cv2.circle(img, (top[0] + 15, y - 4), 4, _COLOURS[i % len(_COLOURS)], -1)
        cv2.putText(img, f"{direction:g} deg", (top[0] + 25, y), font, 0.45, (0, 0, 0), 1,
                    cv2.LINE_AA)
        y += 18
    for _model, colour, label in curves:
        cv2.line(img, (top[0] + 8, y - 4), (top[0] + 22, y - 4), colour, 2)
        cv2.putText(img, label, (top[0] + 25, y), font, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
        y += 18
    cv2.putText(img, f"residuals of the best model ({best.name})", (bot[0] + 90, bot[1] - 10),
                font, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    ok, buf = cv2.imencode(".png", img)
    if not ok:  # pragma: no cover - OpenCV always encodes a uint8 BGR image
        raise RuntimeError("PNG encoding failed")
    return bytes(buf)
