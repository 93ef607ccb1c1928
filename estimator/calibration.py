"""Pixel radius -> ground range calibrations, their fitting and their JSON form.

A calibration maps the pixel radius r [px] of the ball's centroid (its distance from the
image centre) to the horizontal range d [m] from the robot's centre to the ball's centre.
Every model implements the :class:`Calibration` protocol:

- :class:`LinearCalibration` ``d = a r + b``, the paper's eq. 4 (:data:`PAPER_CALIBRATION`);
- :class:`LookupCalibration`, a monotone piecewise-linear table;
- :class:`MirrorCalibration` ``d = a tan(b r)``, NuBot's catadioptric mirror;
- :class:`CameraCalibration`, from a camera model with the ball-height correction.

The JSON form is ``{"format": "dsp-calibration", "version": 1, "model": <name>, ...params,
"fit": {...}?}`` with sorted keys; it is parsed with :func:`json.loads` only.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from estimator.constants import BALL_RADIUS_M, PAPER_B_M, PAPER_K_M_PER_PX
from estimator.errors import CalibrationError, CalibrationFormatError, FitError, OutOfRangeError

__all__ = [
    "CALIBRATION_FORMAT",
    "CALIBRATION_FORMAT_VERSION",
    "CALIBRATION_MODELS",
    "PAPER_CALIBRATION",
    "Calibration",
    "CameraCalibration",
    "CameraLike",
    "FitResult",
    "LinearCalibration",
    "LookupCalibration",
    "MirrorCalibration",
    "calibration_from_dict",
    "calibration_from_json",
    "calibration_to_json",
    "fit_all",
    "fit_linear",
    "fit_lookup",
    "fit_mirror",
]

CALIBRATION_FORMAT = "dsp-calibration"
CALIBRATION_FORMAT_VERSION = 1
CALIBRATION_MODELS = ("linear", "lookup", "mirror", "camera")

FloatArray = npt.NDArray[np.float64]


@runtime_checkable
class Calibration(Protocol):
    """Pixel radius [px] -> ground range of the ball's centre [m]."""

    @property
    def name(self) -> str:
        """The model's name, the ``"model"`` key of its dict form."""
        ...

    def range_m(self, r_px: float) -> float:
        """Horizontal range [m] from the robot's centre to the ball's centre."""
        ...

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict with a ``"model"`` key, read back by calibration_from_dict."""
        ...


def _check_finite(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise CalibrationError(f"{name} = {value} is not finite; pass a finite number")
    return value


@dataclass(frozen=True)
class LinearCalibration:
    """``d = a r + b``, the paper's eq. 4 (its own fit is :data:`PAPER_CALIBRATION`)."""

    a_m_per_px: float
    b_m: float

    def __post_init__(self) -> None:
        _check_finite("a_m_per_px", self.a_m_per_px)
        _check_finite("b_m", self.b_m)

    @property
    def name(self) -> str:
        return "linear"

    def range_m(self, r_px: float) -> float:
        return self.a_m_per_px * r_px + self.b_m  # eq. 4

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.name, "a_m_per_px": self.a_m_per_px, "b_m": self.b_m}


PAPER_CALIBRATION = LinearCalibration(a_m_per_px=PAPER_K_M_PER_PX, b_m=PAPER_B_M)
"""The paper's eq. 4: d = 0.0163 r + 0.2786 (R^2 = 0.9932)."""


@dataclass(frozen=True)
class LookupCalibration:
    """A monotone piecewise-linear table r_px -> d_m.

    ``r_px`` must be strictly increasing and ``d_m`` non-decreasing (a ball further out in
    the image is never nearer), at least two points. Between points the range is linearly
    interpolated; outside the table it is linearly EXTRAPOLATED along the first or last
    segment (so a ball slightly beyond the calibrated span still gets a sensible range).
    """

    r_px: tuple[float, ...]
    d_m: tuple[float, ...]

    def __post_init__(self) -> None:
        r = tuple(_check_finite("r_px", v) for v in self.r_px)
        d = tuple(_check_finite("d_m", v) for v in self.d_m)
        if len(r) != len(d) or len(r) < 2:
            raise CalibrationError(
                f"lookup table has {len(r)} radii and {len(d)} ranges; "
                "pass two equally long sequences of at least 2 points"
            )
        for i in range(1, len(r)):
            if not r[i] > r[i - 1]:
                raise CalibrationError(
                    f"lookup r_px is not strictly increasing at index {i} "
                    f"({r[i - 1]} then {r[i]}); sort the table and pool duplicates "
                    "(fit_lookup does both)"
                )
            if d[i] < d[i - 1]:
                raise CalibrationError(
                    f"lookup d_m decreases at index {i} ({d[i - 1]} then {d[i]}); "
                    "the range must be non-decreasing in r (fit_lookup enforces it)"
                )
        object.__setattr__(self, "r_px", r)
        object.__setattr__(self, "d_m", d)

    @property
    def name(self) -> str:
        return "lookup"

    def range_m(self, r_px: float) -> float:
        r, d = self.r_px, self.d_m
        if r_px <= r[0]:  # linear extrapolation along the first segment
            return d[0] + (r_px - r[0]) * (d[1] - d[0]) / (r[1] - r[0])
        if r_px >= r[-1]:  # linear extrapolation along the last segment
            return d[-1] + (r_px - r[-1]) * (d[-1] - d[-2]) / (r[-1] - r[-2])
        return float(np.interp(r_px, r, d))

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.name, "r_px": list(self.r_px), "d_m": list(self.d_m)}


@dataclass(frozen=True)
class MirrorCalibration:
    """``d = a tan(b r)``: NuBot's catadioptric mirror (e.g. a = 1.569 m, b = 0.007088).

    Defined for 0 <= b r < pi/2 (the horizon); beyond it :meth:`range_m` raises
    :class:`OutOfRangeError`.
    """

    a_m: float
    b_rad_per_px: float

    def __post_init__(self) -> None:
        _check_finite("a_m", self.a_m)
        if _check_finite("b_rad_per_px", self.b_rad_per_px) <= 0.0:
            raise CalibrationError(
                f"b_rad_per_px = {self.b_rad_per_px} must be > 0 (d = a tan(b r))"
            )

    @property
    def name(self) -> str:
        return "mirror"

    def range_m(self, r_px: float) -> float:
        angle = self.b_rad_per_px * r_px
        if not abs(angle) < math.pi / 2.0:
            raise OutOfRangeError(
                f"r_px = {r_px} is at or beyond the mirror's horizon "
                f"r = pi / (2 b) = {math.pi / (2.0 * self.b_rad_per_px):.1f} px; "
                "reject detections that far out or refit the calibration"
            )
        return self.a_m * math.tan(angle)

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.name, "a_m": self.a_m, "b_rad_per_px": self.b_rad_per_px}


class CameraLike(Protocol):
    """The two members of ``estimator.camera.CameraModel`` a CameraCalibration needs."""

    @property
    def height_m(self) -> float:
        """Optical centre above the ground [m]."""
        ...

    def nadir_angle_rad(self, r_px: float) -> npt.ArrayLike:
        """Angle between the pixel's ray and straight down [rad] (a float or 0-d array;
        NaN where the pixel sees no ground)."""
        ...


@dataclass(frozen=True)
class CameraCalibration:
    """Range of the ball's CENTRE from a camera model: the ball-height correction.

    The ray through the ball's centroid meets the plane z = ball_radius_m (the height of
    the ball's centre), not the ground, so with h the camera height and phi the ray's
    nadir angle::

        d = (h - ball_radius_m) * tan(phi(r))

    (NuBot's ``range * (h - r_ball) / h`` correction, written for a ray.) Raises
    :class:`OutOfRangeError` at or above the horizon (phi >= pi/2).
    """

    camera: CameraLike
    ball_radius_m: float = BALL_RADIUS_M

    def __post_init__(self) -> None:
        radius = _check_finite("ball_radius_m", self.ball_radius_m)
        height = float(self.camera.height_m)
        if not radius < height:
            raise CalibrationError(
                f"ball_radius_m = {radius} is not below the camera height {height} m; "
                "the camera must look down on the ball's centre"
            )

    @property
    def name(self) -> str:
        return "camera"

    def range_m(self, r_px: float) -> float:
        phi = float(np.asarray(self.camera.nadir_angle_rad(r_px), dtype=np.float64))
        if not phi < math.pi / 2.0:  # NaN (no ground) fails this test too
            raise OutOfRangeError(
                f"r_px = {r_px} looks {math.degrees(phi):.1f} deg from nadir (NaN: outside the "
                "camera's image), at or above the horizon; reject detections that far out"
            )
        return (self.camera.height_m - self.ball_radius_m) * math.tan(phi)

    def to_dict(self) -> dict[str, Any]:
        to_dict: Callable[[], dict[str, Any]] | None = getattr(self.camera, "to_dict", None)
        if to_dict is None:
            raise CalibrationError(
                f"camera {self.camera!r} has no to_dict(); use an estimator.camera model "
                "to serialise a CameraCalibration"
            )
        return {"model": self.name, "camera": to_dict(), "ball_radius_m": self.ball_radius_m}


# ---------------------------------------------------------------------------------------
# Fitting


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


def fit_all(
    r_px: Sequence[float] | FloatArray, d_m: Sequence[float] | FloatArray
) -> list[FitResult]:
    """Every model that can be fitted, best (lowest RMS) first; ties keep the order
    linear, mirror, lookup. Note the lookup table interpolates its own samples, so on
    the fitting data it usually wins: compare on held-out samples to choose honestly."""
    results: list[FitResult] = []
    errors: list[str] = []
    for fit in (fit_linear, fit_mirror, fit_lookup):
        try:
            results.append(fit(r_px, d_m))
        except CalibrationError as err:
            errors.append(f"{fit.__name__}: {err}")
    if not results:
        raise FitError("no model could be fitted: " + "; ".join(errors))
    return sorted(results, key=lambda fr: fr.rms_m)


# ---------------------------------------------------------------------------------------
# Serialisation


def calibration_to_json(model: Calibration, fit: FitResult | None = None) -> str:
    """The model (and optionally its fit statistics) as a small JSON string."""
    doc: dict[str, Any] = {
        "format": CALIBRATION_FORMAT,
        "version": CALIBRATION_FORMAT_VERSION,
        **model.to_dict(),
    }
    if fit is not None:
        doc["fit"] = {"r2": fit.r2, "rms_m": fit.rms_m, "max_abs_m": fit.max_abs_m, "n": fit.n}
    return json.dumps(doc, sort_keys=True, indent=2)


def calibration_from_json(text: str) -> Calibration:
    """The model in a JSON string written by :func:`calibration_to_json`."""
    try:
        doc = json.loads(text)
    except (json.JSONDecodeError, TypeError) as err:
        raise CalibrationFormatError(
            f"calibration is not valid JSON ({err}); pass the text calibration_to_json wrote"
        ) from err
    if not isinstance(doc, dict):
        raise CalibrationFormatError(
            f"calibration JSON is a {type(doc).__name__}, not an object with a 'model' key"
        )
    return calibration_from_dict(doc)


def _number(doc: Mapping[str, Any], key: str) -> float:
    if key not in doc:
        raise CalibrationFormatError(
            f"calibration model {doc.get('model')!r} lacks the key {key!r}; add it"
        )
    value = doc[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise CalibrationFormatError(
            f"calibration key {key!r} = {value!r} is not a number; write a number"
        )
    return float(value)


def _numbers(doc: Mapping[str, Any], key: str) -> tuple[float, ...]:
    value = doc.get(key)
    if not isinstance(value, list):
        raise CalibrationFormatError(
            f"calibration key {key!r} = {value!r} is not a list of numbers; write one"
        )
    return tuple(_number({key: v, "model": doc.get("model")}, key) for v in value)


def calibration_from_dict(d: Mapping[str, Any]) -> Calibration:
    """The model described by a dict with a ``"model"`` key (the ``to_dict()`` form,
    optionally with ``"format"``, ``"version"`` and ``"fit"`` keys, which are checked or
    ignored)."""
    version = d.get("version", CALIBRATION_FORMAT_VERSION)
    if version != CALIBRATION_FORMAT_VERSION:
        raise CalibrationFormatError(
            f"calibration format version {version!r} is not supported; this estimator "
            f"reads version {CALIBRATION_FORMAT_VERSION} (re-save it with this version)"
        )
    fmt = d.get("format", CALIBRATION_FORMAT)
    if fmt != CALIBRATION_FORMAT:
        raise CalibrationFormatError(
            f"format {fmt!r} is not {CALIBRATION_FORMAT!r}; this is not a calibration file"
        )
    model = d.get("model")
    if model == "linear":
        return LinearCalibration(_number(d, "a_m_per_px"), _number(d, "b_m"))
    if model == "lookup":
        return LookupCalibration(_numbers(d, "r_px"), _numbers(d, "d_m"))
    if model == "mirror":
        return MirrorCalibration(_number(d, "a_m"), _number(d, "b_rad_per_px"))
    if model == "camera":
        camera_doc = d.get("camera")
        if not isinstance(camera_doc, dict):
            raise CalibrationFormatError(
                f"camera calibration key 'camera' = {camera_doc!r} is not an object; "
                "write the camera's to_dict()"
            )
        from estimator.camera import camera_from_dict  # lazy: camera models are optional

        try:
            camera = camera_from_dict(camera_doc)
        except (KeyError, TypeError, ValueError) as err:
            raise CalibrationFormatError(
                f"camera {camera_doc!r} cannot be rebuilt ({err}); write a camera's to_dict()"
            ) from err
        return CameraCalibration(camera, _number(d, "ball_radius_m"))
    raise CalibrationFormatError(
        f"calibration model {model!r} is unknown; use one of {', '.join(CALIBRATION_MODELS)}"
    )
