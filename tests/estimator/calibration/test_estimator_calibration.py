"""Calibration models, fitting and JSON round trips."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from estimator.calibration import (
    PAPER_CALIBRATION,
    Calibration,
    CameraCalibration,
    LinearCalibration,
    LookupCalibration,
    MirrorCalibration,
    calibration_from_dict,
    calibration_from_json,
    calibration_to_json,
    fit_all,
    fit_linear,
    fit_lookup,
    fit_mirror,
    holdout_rms_m,
)
from estimator.errors import (
    CalibrationError,
    CalibrationFormatError,
    FitError,
    OutOfRangeError,
)


def test_paper_calibration_is_eq_4() -> None:
    assert PAPER_CALIBRATION.range_m(499.0) == pytest.approx(0.0163 * 499 + 0.2786)
    assert isinstance(PAPER_CALIBRATION, Calibration)


def test_fit_linear_recovers_the_line() -> None:
    r = np.arange(10.0, 500.0, 7.0)
    fit = fit_linear(r, 0.0163 * r + 0.2786)
    assert isinstance(fit.model, LinearCalibration)
    assert fit.model.a_m_per_px == pytest.approx(0.0163)
    assert fit.model.b_m == pytest.approx(0.2786)
    assert fit.r2 == pytest.approx(1.0)
    assert fit.rms_m == pytest.approx(0.0, abs=1e-9)
    assert fit.n == r.size


def test_fit_mirror_recovers_nubot_parameters() -> None:
    r = np.linspace(20.0, 200.0, 40)
    fit = fit_mirror(r, 1.569 * np.tan(0.007088 * r))
    assert isinstance(fit.model, MirrorCalibration)
    assert fit.model.a_m == pytest.approx(1.569, rel=1e-4)
    assert fit.model.b_rad_per_px == pytest.approx(0.007088, rel=1e-4)
    assert fit.max_abs_m < 1e-4


def test_mirror_beyond_horizon_raises() -> None:
    with pytest.raises(OutOfRangeError, match="horizon"):
        MirrorCalibration(1.0, 0.01).range_m(200.0)


def test_lookup_interpolates_and_extrapolates_linearly() -> None:
    table = LookupCalibration((10.0, 20.0, 40.0), (1.0, 2.0, 6.0))
    assert table.range_m(15.0) == pytest.approx(1.5)
    assert table.range_m(30.0) == pytest.approx(4.0)
    assert table.range_m(0.0) == pytest.approx(0.0)  # first segment's slope 0.1
    assert table.range_m(50.0) == pytest.approx(8.0)  # last segment's slope 0.2



def test_lookup_makes_its_arrays_once_not_on_every_call(monkeypatch: pytest.MonkeyPatch) -> None:
    """A fit evaluates its table at every sample: converting the n-point table on each of the
    n calls made reading 25,000 measurements take minutes (O(n^2))."""
    table = LookupCalibration(tuple(float(r) for r in range(1, 1001)),
                              tuple(0.01 * r for r in range(1, 1001)))
    tables: list[object] = []
    interp = np.interp

    def spy(x: float, xp: object, fp: object) -> object:
        tables.extend((xp, fp))
        return interp(x, xp, fp)

    monkeypatch.setattr(np, "interp", spy)
    assert [table.range_m(r) for r in (1.5, 500.25, 999.5)] == pytest.approx(
        [0.015, 5.0025, 9.995])
    assert all(isinstance(t, np.ndarray) for t in tables)
    assert len({id(t) for t in tables}) == 2  # the same two arrays every call


@pytest.mark.parametrize(
    ("r", "d", "match"),
    [
        ((1.0,), (1.0,), "at least 2"),
        ((1.0, 1.0), (1.0, 2.0), "strictly increasing"),
        ((1.0, 2.0), (2.0, 1.0), "decreases"),
        ((1.0, math.nan), (1.0, 2.0), "not finite"),
    ],
)
def test_lookup_validation(r: tuple[float, ...], d: tuple[float, ...], match: str) -> None:
    with pytest.raises(CalibrationError, match=match):
        LookupCalibration(r, d)


def test_fit_lookup_pools_duplicates_and_is_monotone() -> None:
    r = [30.0, 10.0, 20.0, 20.0, 40.0, 50.0]
    d = [2.2, 1.0, 3.0, 2.0, 2.9, 5.0]  # 20 px pools to 2.5 (weight 2); 30 px violates
    fit = fit_lookup(r, d)
    assert isinstance(fit.model, LookupCalibration)
    assert fit.model.r_px == (10.0, 20.0, 30.0, 40.0, 50.0)
    # isotonic regression: 20 and 30 px pooled (weights 2, 1) to (2 * 2.5 + 2.2) / 3 = 2.4
    assert fit.model.d_m == pytest.approx((1.0, 2.4, 2.4, 2.9, 5.0))
    assert all(b >= a for a, b in zip(fit.model.d_m, fit.model.d_m[1:], strict=False))


def test_fit_errors_name_the_problem() -> None:
    with pytest.raises(FitError, match="at least 2"):
        fit_linear([1.0], [1.0])
    with pytest.raises(FitError, match="all radii equal"):
        fit_linear([3.0, 3.0], [1.0, 2.0])
    with pytest.raises(FitError, match="one range per radius"):
        fit_lookup([1.0, 2.0], [1.0])
    with pytest.raises(FitError, match="NaN"):
        fit_mirror([1.0, math.inf], [1.0, 2.0])


def test_fit_all_ranks_on_held_out_samples() -> None:
    r = np.linspace(20.0, 200.0, 30)
    results = fit_all(r, 1.569 * np.tan(0.007088 * r))
    held = [fr.holdout_rms_m for fr in results if fr.holdout_rms_m is not None]
    assert len(held) == len(results) and held == sorted(held)
    assert {fr.model.name for fr in results} == {"linear", "mirror", "lookup"}
    assert [fr.model.name for fr in results] == ["mirror", "lookup", "linear"]


def test_fit_all_does_not_pick_the_lookup_table_that_fits_its_own_noise() -> None:
    """On noisy samples of a line the table has RMS 0 where it was fitted, and loses on the
    samples held out."""
    r = np.linspace(20.0, 500.0, 40)
    d = 0.0163 * r + 0.2786 + np.random.default_rng(1).normal(0.0, 0.02, r.size)
    results = fit_all(r, d)
    lookup = next(fr for fr in results if fr.model.name == "lookup")
    assert lookup.rms_m == min(fr.rms_m for fr in results)
    assert results[0].model.name == "linear"
    assert lookup.holdout_rms_m is not None and results[0].holdout_rms_m is not None
    assert lookup.holdout_rms_m > results[0].holdout_rms_m


def test_fit_all_says_when_it_could_not_hold_samples_out() -> None:
    results = fit_all([10.0, 20.0, 30.0], [1.0, 2.0, 3.1])
    assert all(fr.holdout_rms_m is None for fr in results)
    assert [fr.rms_m for fr in results] == sorted(fr.rms_m for fr in results)


def test_holdout_is_infinite_when_a_held_out_radius_is_beyond_the_model() -> None:
    r = np.array([100.0, 200.0, 300.0, 400.0, 500.0, 600.0])
    d = 1.2 * np.tan(np.pi / 1300.0 * r)  # the horizon at 650 px
    assert math.isfinite(holdout_rms_m("mirror", r, d))
    assert holdout_rms_m("mirror", [*r[:-1], 2000.0], [*d[:-1], 30.0]) == math.inf


class _FlatCamera:
    """A camera with d_ground = k r (like estimator.camera's ideal model)."""

    height_m = 1.0

    def nadir_angle_rad(self, r_px: float) -> float:
        return math.atan2(0.01 * r_px, self.height_m)


def test_camera_calibration_corrects_for_ball_height() -> None:
    calibration = CameraCalibration(_FlatCamera(), ball_radius_m=0.11)
    # the ray through r = 100 px meets the ground at 1 m; the ball's centre is 0.11 m up
    assert calibration.range_m(100.0) == pytest.approx((1.0 - 0.11) * 1.0)
    with pytest.raises(CalibrationError, match="below the camera height"):
        CameraCalibration(_FlatCamera(), ball_radius_m=2.0)
    with pytest.raises(CalibrationError, match="to_dict"):
        CameraCalibration(_FlatCamera()).to_dict()


def test_camera_calibration_with_the_project_camera_round_trips() -> None:
    camera_module = pytest.importorskip("estimator.camera")
    camera = camera_module.make_camera("ideal")
    calibration = CameraCalibration(camera)
    phi = float(camera.nadir_angle_rad(300.0))
    assert calibration.range_m(300.0) == pytest.approx((camera.height_m - 0.11) * math.tan(phi))
    again = calibration_from_json(calibration_to_json(calibration))
    assert again == calibration


@pytest.mark.parametrize(
    "model",
    [
        PAPER_CALIBRATION,
        LookupCalibration((0.0, 100.0, 200.0), (0.3, 2.0, 5.0)),
        MirrorCalibration(1.569, 0.007088),
    ],
)
def test_json_round_trip(model: Calibration) -> None:
    fit = fit_linear([1.0, 2.0, 3.0], [1.0, 2.0, 3.5])
    text = calibration_to_json(model, fit)
    doc = json.loads(text)
    assert doc["version"] == 1
    assert doc["model"] == model.name
    assert doc["fit"]["n"] == 3
    assert calibration_from_json(text) == model
    assert calibration_from_dict(model.to_dict()) == model


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("{not json", "not valid JSON"),
        ("[1, 2]", "not an object"),
        ('{"model": "spline"}', "'spline' is unknown"),
        ('{"model": "linear", "a_m_per_px": 0.01}', "lacks the key 'b_m'"),
        ('{"model": "linear", "a_m_per_px": "x", "b_m": 0}', "'a_m_per_px' = 'x' is not a number"),
        ('{"model": "linear", "version": 99, "a_m_per_px": 1, "b_m": 0}', "version 99"),
        ('{"model": "lookup", "r_px": 3, "d_m": []}', "not a list"),
        ('{"model": "camera", "camera": 5, "ball_radius_m": 0.11}', "not an object"),
    ],
)
def test_bad_json_names_the_problem(text: str, match: str) -> None:
    with pytest.raises(CalibrationFormatError, match=match):
        calibration_from_json(text)


@pytest.mark.parametrize("name", ["a_m_per_px", "b_m"])
def test_a_linear_calibration_holds_no_number_past_ten_kilometres(name: str) -> None:
    """Either parameter up to MAX_RANGE_M either way is taken; past it (a range no camera
    sees a ball at, a product that leaves the floats) it is refused, naming it."""
    from estimator.calibration.models import MAX_RANGE_M

    for value in (MAX_RANGE_M, -MAX_RANGE_M, 0.0):
        LinearCalibration(**{"a_m_per_px": 0.01, "b_m": 0.2, name: value})
    for value in (MAX_RANGE_M * 1.001, -MAX_RANGE_M * 1.001, 1e300):
        with pytest.raises(CalibrationError, match=rf"^{name} = .* is outside \[-10000, "
                           r"10000\]"):
            LinearCalibration(**{"a_m_per_px": 0.01, "b_m": 0.2, name: value})
    with pytest.raises(CalibrationError, match=rf"{name} = 1e\+300 is outside"):
        calibration_from_dict({"model": "linear", "a_m_per_px": 0.01, "b_m": 0.2,
                               name: 1e300})
