"""dsp-calibrate: the paper's calibration procedure in simulation, and its model choice."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from dsp.errors import UsageError
from estimator.calibration import LinearCalibration, calibration_from_json
from estimator.camera import make_camera
from recorder.calibrate import Sample, calibrate, distances_m, sample_ranges
from recorder.calibrate_figure import plot_png


def test_distances_follow_the_papers_procedure() -> None:
    d = distances_m()
    assert d[0] == 0.4 and d[-1] == 9.0 and len(d) == 87
    assert np.allclose(np.diff(d), 0.1)


@pytest.mark.parametrize(("start", "stop", "step"), [(0.0, 9.0, 0.1), (2.0, 1.0, 0.1),
                                                     (0.4, 9.0, 0.0)])
def test_bad_distance_ranges_are_refused(start: float, stop: float, step: float) -> None:
    with pytest.raises(UsageError, match="need 0 < start <= stop, step > 0"):
        distances_m(start, stop, step)


def _samples(fn, directions=(0.0, 90.0), noise=0.0, seed=0):  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(seed)
    out = []
    for direction in directions:
        for d in distances_m(0.4, 9.0, 0.2):
            out.append(Sample(direction, d, fn(d) + rng.normal(0, noise), 0.0))
    return out


def test_a_linear_camera_is_fitted_and_chosen_linear() -> None:
    cam = make_camera("ideal")
    run = calibrate(cam, _samples(lambda d: (d - 0.05) / 0.017, noise=0.2))
    assert run.best.model.name in ("linear", "mirror")  # mirror's tan is ~linear here
    fit = run.paper_procedure
    assert isinstance(fit.model, LinearCalibration)
    assert fit.model.a_m_per_px == pytest.approx(0.017, rel=1e-3)
    assert fit.model.b_m == pytest.approx(0.05, abs=0.01)
    assert fit.r2 > 0.9999
    # the lookup table fits its own samples best but loses on held-out ones
    lookup = next(f for f in run.fits if f.model.name == "lookup")
    assert lookup.rms_m < run.best.rms_m
    assert run.holdout_rms_m["lookup"] > run.holdout_rms_m[run.best.model.name]


def test_a_strongly_nonlinear_camera_is_not_given_a_line() -> None:
    # NuBot-like mirror: d = a tan(b r), r = atan(d / a) / b
    run = calibrate(make_camera("mirror"),
                    _samples(lambda d: math.atan(d / 1.2) / 0.0029, noise=0.05))
    assert run.best.model.name in ("mirror", "lookup")
    linear = next(f for f in run.fits if f.model.name == "linear")
    assert run.holdout_rms_m[run.best.model.name] < 0.2 * run.holdout_rms_m["linear"]
    assert linear.rms_m > 0.1


def test_anisotropy_shows_in_the_per_direction_fits() -> None:
    samples = _samples(lambda d: d / 0.017, directions=(0.0,)) + _samples(
        lambda d: d / 0.018, directions=(90.0,))
    run = calibrate(make_camera("ideal"), samples)
    a0 = run.per_direction[0.0].model.a_m_per_px  # type: ignore[attr-defined]
    a90 = run.per_direction[90.0].model.a_m_per_px  # type: ignore[attr-defined]
    assert a0 == pytest.approx(0.017) and a90 == pytest.approx(0.018)


def test_too_few_detections_are_refused() -> None:
    samples = [Sample(0.0, d, math.nan, math.nan) for d in distances_m(0.4, 9.0, 0.5)]
    with pytest.raises(UsageError, match="only 0 of 18 ball placements were detected"):
        calibrate(make_camera("ideal"), samples)


def test_the_figure_is_a_png() -> None:
    run = calibrate(make_camera("ideal"), _samples(lambda d: d / 0.017))
    png = plot_png(run)
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    # drawn by matplotlib without the metadata that varies: the same run, the same bytes
    assert plot_png(run) == png and b"Software" not in png


def test_an_output_with_the_wrong_extension_is_refused_before_rendering(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from recorder.calibrate_cli import main

    assert main(["-o", str(tmp_path / "cal.txt")]) == 2
    assert main(["-o", str(tmp_path / "cal.json"), "--plot", str(tmp_path / "cal.jpg")]) == 2
    err = capsys.readouterr().err.splitlines()
    assert "-o/--out" in err[0] and "must end in .json" in err[0]
    assert "--plot" in err[1] and "must end in .png or .svg" in err[1]
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("camera", ["ideal", "fisheye", "mirror"])
def test_rendered_ball_radius_grows_with_range_in_every_direction(camera: str) -> None:
    cam = make_camera(camera)
    distances = [0.6, 2.0, 4.5, 8.0]
    samples, renderer = sample_ranges(cam, distances, (0.0, 90.0), face_px=512)
    assert renderer in ("egl", "tiny")
    assert all(math.isfinite(s.r_px) for s in samples), samples
    for direction in (0.0, 90.0):
        r = [s.r_px for s in samples if s.direction_deg == direction]
        assert r == sorted(r) and r[0] > 20 and r[-1] < cam.max_radius_px
        # the detected bearing is the direction the ball was put in
        assert all(abs(s.bearing_error_rad) < 0.01 for s in samples)
    # and where the camera model says: the ball's centre seen along its ray, within 2 px
    expected = cam.radius_px(np.arctan2(np.array(distances), cam.height_m - 0.11))
    got = np.array([s.r_px for s in samples if s.direction_deg == 0.0])
    assert np.abs(got - expected).max() < 2.0


def test_cli_writes_a_calibration_replay_can_read(tmp_path: Path) -> None:
    out = tmp_path / "calib.json"
    cmd = [sys.executable, "-m", "recorder.calibrate_cli", "--camera", "ideal", "-o", str(out),
           "--start-m", "0.5", "--stop-m", "8.5", "--step-m", "1.0", "--directions", "0",
           "--face-px", "512"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "paper" in done.stdout and "0.0163" in done.stdout and "best:" in done.stdout
    model = calibration_from_json(out.read_text())
    assert 8.0 < model.range_m(480.0) < 8.3  # r = 499 px <-> 8.4 m in the ideal camera
    doc = json.loads(out.read_text())
    assert doc["samples"]["detected"] == 9 and doc["source_camera"]["model"] == "ideal"
    assert (tmp_path / "calib.png").read_bytes()[:4] == b"\x89PNG"
    # a second run refuses to overwrite, in one line, without a traceback
    again = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert again.returncode != 0
    assert again.stderr.strip().count("\n") == 0 and "output exists already" in again.stderr
    assert "Traceback" not in again.stderr
