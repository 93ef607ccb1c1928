"""Fitting calibration models to (pixel radius, range) samples, and choosing between them.

Every fit is least squares without scipy and returns a :class:`FitResult`: the model and
its goodness of fit on the samples it was fitted to. :func:`fit_all` fits every model and
ranks them on held-out samples (:func:`holdout_rms_m`: two-fold cross-validation over
alternate distances), the rule every calibration procedure shares (the simulated one in
``dsp-calibrate``, from measurements, from a log): on the samples it was fitted to, the
lookup table, which interpolates them, would always win.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from estimator.calibration.models import (
    Calibration,
    LinearCalibration,
    LookupCalibration,
    MirrorCalibration,
)
from estimator.errors import CalibrationError, FitError

__all__ = ["FITTERS", "MIN_HOLDOUT_RANGES", "FitResult", "fit_all", "fit_linear", "fit_lookup",
           "fit_mirror", "holdout_rms_m"]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class FitResult:
    """A fitted model and its goodness of fit on the samples it was fitted to."""

    model: Calibration
    r2: float
    """Coefficient of determination 1 - SS_res / SS_tot (1.0 when all d are equal and
    the fit is exact, 0.0 when they are equal and it is not)."""
    rms_m: float
    max_abs_m: float
    n: int
    holdout_rms_m: float | None = None
    """RMS [m] on held-out samples (:func:`holdout_rms_m`) when :func:`fit_all` ranked the
    model on them; None when it did not (too few distinct ranges to hold any out)."""


def _samples(
    r_px: Sequence[float] | FloatArray, d_m: Sequence[float] | FloatArray, minimum: int
) -> tuple[FloatArray, FloatArray]:
    r = np.asarray(r_px, dtype=np.float64).ravel()
    d = np.asarray(d_m, dtype=np.float64).ravel()
    if r.shape != d.shape:
        raise FitError(f"{r.size} radii but {d.size} ranges; pass one range per radius")
    if r.size < minimum:
        raise FitError(f"{r.size} samples; this fit needs at least {minimum}")
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(d))):
        raise FitError("samples contain NaN or inf; drop those samples before fitting")
    return r, d


def _result(model: Calibration, r: FloatArray, d: FloatArray) -> FitResult:
    predicted = np.array([model.range_m(float(ri)) for ri in r])
    residual = d - predicted
    ss_res = float(np.sum(residual**2))
    ss_tot = float(np.sum((d - d.mean()) ** 2))
    if ss_tot > 0.0:
        r2 = 1.0 - ss_res / ss_tot
    else:
        r2 = 1.0 if ss_res == 0.0 else 0.0
    return FitResult(
        model=model,
        r2=r2,
        rms_m=math.sqrt(ss_res / r.size),
        max_abs_m=float(np.max(np.abs(residual))),
        n=int(r.size),
    )


def fit_linear(r_px: Sequence[float] | FloatArray, d_m: Sequence[float] | FloatArray) -> FitResult:
    """Least-squares ``d = a r + b`` (how the paper obtained eq. 4)."""
    r, d = _samples(r_px, d_m, 2)
    r_mean = r.mean()
    s_rr = float(np.sum((r - r_mean) ** 2))
    if s_rr == 0.0:
        raise FitError(f"all radii equal {r[0]} px; sample the ball at several distances")
    a = float(np.sum((r - r_mean) * (d - d.mean()))) / s_rr
    b = float(d.mean() - a * r_mean)
    return _result(LinearCalibration(a, b), r, d)


def _pool_adjacent_violators(y: FloatArray, w: FloatArray) -> FloatArray:
    """Weighted isotonic (non-decreasing) least-squares regression of y (PAV)."""
    values: list[float] = []
    weights: list[float] = []
    counts: list[int] = []
    for yi, wi in zip(y.tolist(), w.tolist(), strict=True):
        values.append(yi)
        weights.append(wi)
        counts.append(1)
        while len(values) > 1 and values[-2] > values[-1]:  # violator: pool the two blocks
            wv = weights[-2] + weights[-1]
            v = (weights[-2] * values[-2] + weights[-1] * values[-1]) / wv
            c = counts[-2] + counts[-1]
            del values[-1], weights[-1], counts[-1]
            values[-1], weights[-1], counts[-1] = v, wv, c
    return np.repeat(np.array(values), counts)


def fit_lookup(r_px: Sequence[float] | FloatArray, d_m: Sequence[float] | FloatArray) -> FitResult:
    """A monotone lookup table through the samples.

    Samples are sorted by radius, samples at the same radius are pooled (their mean range,
    weighted by their count), and the ranges are made non-decreasing by isotonic
    regression (pool adjacent violators): the closest monotone table in least squares.
    """
    r, d = _samples(r_px, d_m, 2)
    r_unique, inverse, counts = np.unique(r, return_inverse=True, return_counts=True)
    if r_unique.size < 2:
        raise FitError(f"all radii equal {r[0]} px; sample the ball at several distances")
    d_pooled = np.bincount(inverse, weights=d) / counts
    d_monotone = _pool_adjacent_violators(d_pooled, counts.astype(np.float64))
    model = LookupCalibration(tuple(r_unique.tolist()), tuple(d_monotone.tolist()))
    return _result(model, r, d)


def fit_mirror(
    r_px: Sequence[float] | FloatArray,
    d_m: Sequence[float] | FloatArray,
    *,
    grid: int = 400,
) -> FitResult:
    """Least-squares ``d = a tan(b r)`` without scipy.

    For a fixed b the model is linear in a, so a(b) = sum(t d) / sum(t t) with t = tan(b r)
    in closed form; the remaining 1-D problem in b is solved by a grid search over
    (0, pi / (2 r_max)) followed by golden-section refinement around the best grid point.
    """
    r, d = _samples(r_px, d_m, 2)
    r_max = float(np.max(np.abs(r)))
    if r_max == 0.0:
        raise FitError("all radii are 0 px; sample the ball at several distances")
    b_max = math.pi / (2.0 * r_max)

    def sse(b: float) -> tuple[float, float]:
        t = np.tan(b * r)
        tt = float(np.dot(t, t))
        a = float(np.dot(t, d)) / tt if tt > 0.0 else 0.0
        return float(np.sum((d - a * t) ** 2)), a

    bs = b_max * (np.arange(1, grid + 1) / (grid + 1.0))
    costs = [sse(float(b))[0] for b in bs]
    i = int(np.argmin(costs))
    lo = float(bs[i - 1]) if i > 0 else float(bs[0]) * 1e-3
    hi = float(bs[i + 1]) if i + 1 < grid else float(bs[-1])
    ratio = (math.sqrt(5.0) - 1.0) / 2.0
    for _ in range(60):  # golden-section search on [lo, hi]
        m1 = hi - ratio * (hi - lo)
        m2 = lo + ratio * (hi - lo)
        if sse(m1)[0] <= sse(m2)[0]:
            hi = m2
        else:
            lo = m1
    b = (lo + hi) / 2.0
    a = sse(b)[1]
    return _result(MirrorCalibration(a, b), r, d)


Samples = Sequence[float] | FloatArray

FITTERS: dict[str, Callable[[Samples, Samples], FitResult]] = {
    "linear": fit_linear,
    "mirror": fit_mirror,
    "lookup": fit_lookup,
}
"""Every model :func:`fit_all` fits, in its tie order."""

MIN_HOLDOUT_RANGES = 4
"""Distinct ranges needed to hold half of them out (two in each fold)."""


def holdout_rms_m(name: str, r_px: Sequence[float] | FloatArray,
                  d_m: Sequence[float] | FloatArray) -> float:
    """RMS [m] of model ``name`` (a key of :data:`FITTERS`) on held-out samples: two-fold
    cross-validation over alternate distances (samples at one distance, whatever their
    direction, fall in the same fold): fit on one fold, test on the other, and back.
    Infinite when a fold cannot be fitted or a held-out radius is out of the model's range."""
    r, d = _samples(r_px, d_m, 2)
    rank = np.searchsorted(np.unique(d), d)
    sq: list[float] = []
    for train in (0, 1):
        tr = rank % 2 == train
        try:
            model = FITTERS[name](r[tr], d[tr]).model
        except CalibrationError:
            return math.inf
        for ri, di in zip(r[~tr], d[~tr], strict=True):
            try:
                sq.append((float(model.range_m(float(ri))) - float(di)) ** 2)
            except CalibrationError:
                sq.append(math.inf)
    return math.sqrt(sum(sq) / len(sq)) if sq else math.inf


def fit_all(
    r_px: Sequence[float] | FloatArray, d_m: Sequence[float] | FloatArray
) -> list[FitResult]:
    """Every model that can be fitted to all the samples, best first, RANKED ON HELD-OUT
    SAMPLES (:func:`holdout_rms_m`, recorded in each result's ``holdout_rms_m``); ties keep
    the order linear, mirror, lookup. With fewer than :data:`MIN_HOLDOUT_RANGES` distinct
    ranges nothing can be held out: the results are then ranked by their RMS on the samples
    they were fitted to and say so (``holdout_rms_m`` None), which favours the lookup table."""
    results: list[FitResult] = []
    errors: list[str] = []
    for fit in FITTERS.values():
        try:
            results.append(fit(r_px, d_m))
        except CalibrationError as err:
            errors.append(f"{fit.__name__}: {err}")
    if not results:
        raise FitError("no model could be fitted: " + "; ".join(errors))
    if np.unique(np.asarray(d_m, dtype=np.float64)).size < MIN_HOLDOUT_RANGES:
        return sorted(results, key=lambda fr: fr.rms_m)
    held = [replace(fr, holdout_rms_m=holdout_rms_m(fr.model.name, r_px, d_m))
            for fr in results]
    return sorted(held, key=lambda fr: math.inf if fr.holdout_rms_m is None
                  else fr.holdout_rms_m)
