"""Parts from outside: the example package under examples/ installed with pip (offline, into
a folder of its own), picked by entry point and by path, its results checked against the
same algorithms computed here (a detector, a fusion, a tracker keeping state from step to
step, a calibration model), the header naming the parts; bad specs are one line."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from dsp.errors import UsageError
from replay.compare import compare
from replay.log import ImageMessage, LogReader, decode_image
from replay.options import ReplayOptions
from replay.plugins import load_part, new_part

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "dual-sight-example-parts"
LOG = ROOT / "logs" / "golden" / "scenario2.mcap"
ROLLING = ROOT / "logs" / "golden" / "rolling.mcap"  # a moving ball: a tracker's state shows


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The example package pip-installed into a folder (a copy is built: no build files in
    the source tree)."""
    root = tmp_path_factory.mktemp("plugin")
    src = root / "src"
    shutil.copytree(EXAMPLE, src)
    target = root / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-build-isolation",
                    "--no-deps", "--no-index", "--target", str(target), str(src)],
                   check=True, capture_output=True)
    return target


def _replay(site: Path, out: Path, *extra: str,
            log: Path = LOG) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(site)}
    return subprocess.run([sys.executable, "-m", "replay.cli", str(log), "--out", str(out),
                           "-q", *extra], env=env, capture_output=True, text=True)


def _quadratic_range(r_px: float) -> float | None:
    """The example calibration model, written out here: None beyond its 500 px horizon."""
    return 0.05 + 0.0165 * r_px + 1.0e-6 * r_px**2 if r_px <= 500.0 else None


def _reference_centroids() -> dict[tuple[int, str], tuple[float, float]]:
    """Every orange pixel's centroid, per image, computed here from the decoded images."""
    out = {}
    with LogReader(LOG) as reader:
        for msg in reader.messages():
            if isinstance(msg, ImageMessage):
                image = decode_image(msg)
                assert image is not None
                hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)
                h, s, v = (hsv[..., i].astype(int) for i in range(3))
                mask = (h >= 5) & (h <= 25) & (s >= 120) & (v >= 80)
                rows, cols = np.nonzero(mask)
                out[(msg.stamp_ns, msg.robot)] = (cols.mean(), rows.mean())
    return out


def _load(path: Path) -> dict[str, Any]:
    doc: dict[str, Any] = json.loads(path.read_text())
    return doc


def test_the_example_is_picked_by_entry_point_and_by_path(site: Path, tmp_path: Path) -> None:
    by_name, by_path, default = (tmp_path / f"{n}.json" for n in ("name", "path", "default"))
    for out, extra in ((by_name, ["--detector", "example-centroid", "--fusion",
                                  "example-median"]),
                       (by_path, ["--detector", "dsp_example_parts.detector:CentroidDetector",
                                  "--fusion", "dsp_example_parts.fusion:MedianFusion"]),
                       (default, ["--fusion", "mean"])):
        done = _replay(site, out, *extra)
        assert done.returncode == 0, done.stderr
    a, b = _load(by_name), _load(by_path)
    assert a["frames"] == b["frames"] and a["fused"] == b["fused"]
    assert a["parts"]["detector"] == {"name": "example-centroid", "version": "0.1.0",
                                      "spec": "example-centroid",
                                      "source": "entry point dual_sight.detectors"}
    assert b["parts"]["fusion"]["source"] == "module"
    assert b["parts"]["fusion"]["version"] == "0.1.0"
    assert "parts" not in _load(default)  # built-in parts: the file as it always was
    # the detections are the centroids computed here
    ref = _reference_centroids()
    assert len(a["frames"]) == len(ref) > 0
    for f in a["frames"]:
        cx, cy = ref[(f["stamp_ns"], f["robot"])]
        assert f["detection"]["cx_px"] == pytest.approx(cx, abs=2e-6)
        assert f["detection"]["cy_px"] == pytest.approx(cy, abs=2e-6)
    # each fused step is the median of its frames' estimates (the cameras are in sync)
    for step in a["fused"]:
        est = [f["estimate"] for f in a["frames"]
               if f["stamp_ns"] == step["stamp_ns"] and f["estimate"] is not None]
        assert step["x_m"] == pytest.approx(np.median([e["x_m"] for e in est]), abs=2e-6)
        assert step["y_m"] == pytest.approx(np.median([e["y_m"] for e in est]), abs=2e-6)
        assert step["covariance"] == [[0.0025, 0.0], [0.0, 0.0025]]
    # and dsp-compare says what differed
    report = compare(default, by_name, replicates=20).to_dict()
    diff = report["differences"]
    assert diff["fusion"] == ["mean", "example-median"]
    assert diff["parts.detector.version"] == [None, "0.1.0"]


def test_a_spec_that_does_not_load_is_one_line(site: Path, tmp_path: Path) -> None:
    cases = [(["--fusion", "no-such"], "not a built-in fusion"),
             (["--detector", "no_such_module:X"], "No module named"),
             (["--detector", "os:getcwd"], "is not a detector"),
             (["--fusion", "dsp_example_parts.detector:CentroidDetector"], "is not a fusion"),
             (["--calibration-model", "dsp_example_parts.fusion:MedianFusion"],
              "is not a calibration")]
    for extra, what in cases:
        done = _replay(site, tmp_path / "x.json", *extra)
        assert done.returncode == 2, extra
        assert done.stderr.count("\n") == 1 and what in done.stderr, done.stderr
        assert not (tmp_path / "x.json").exists()


def test_a_part_from_sys_path_in_process() -> None:
    part = load_part("fusion", "estimator.fusion:MeanFusion")
    assert part.name == "mean" and part.source == "module"
    assert part.version not in ("", "unknown")  # dual-sight's own version
    opts = ReplayOptions(fusion="estimator.fusion:MeanFusion")
    assert opts.results_view()["fusion"] == "estimator.fusion:MeanFusion"
    assert opts.parts_view()["fusion"] == part.view()


def _check_ranges(frames: list[dict[str, Any]]) -> None:
    """Each located frame's range is the example model's; beyond its horizon, out of range."""
    for f in frames:
        if f["detection"] is None:
            continue
        expected = _quadratic_range(f["detection"]["r_px"])
        if expected is None:
            assert f["status"] == "out_of_range" and f["estimate"] is None
        else:
            assert f["status"] == "ok"
            assert f["estimate"]["range_m"] == pytest.approx(expected, abs=2e-6)


def test_a_calibration_model_and_a_tracker_from_outside(site: Path, tmp_path: Path) -> None:
    moving, still = tmp_path / "moving.json", tmp_path / "still.json"
    done = _replay(site, moving, "--calibration-model", "example-quadratic", "--fusion",
                   "example-smoothing", log=ROLLING)
    assert done.returncode == 0, done.stderr
    done = _replay(site, still, "--calibration-model",
                   "dsp_example_parts.calibration:QuadraticCalibration")
    assert done.returncode == 0, done.stderr
    assert ("or the example-quadratic calibration from --calibration-model right for this "
            "camera?") in done.stderr  # the warning says where robot1's ranges came from
    a, b = _load(moving), _load(still)
    assert a["parts"]["calibration"] == {"name": "example-quadratic", "version": "0.1.0",
                                         "spec": "example-quadratic",
                                         "source": "entry point dual_sight.calibrations"}
    assert a["options"]["calibration_model"] == "example-quadratic"
    assert b["parts"] == {"calibration": {**a["parts"]["calibration"], "source": "module",
                                          "spec": "dsp_example_parts.calibration:"
                                                  "QuadraticCalibration"}}
    _check_ranges(a["frames"])
    _check_ranges(b["frames"])  # scenario 2: one robot sees the ball beyond 500 px
    assert {f["status"] for f in b["frames"]} == {"ok", "out_of_range"}
    # the tracker keeps time (fuse_at): each step moves 1 - exp(-dt / 0.5 s) of the way from
    # its last output to the step's median, dt from the step before
    track, last = None, 0
    moved = 0
    for step in a["fused"]:
        est = [f["estimate"] for f in a["frames"]
               if f["stamp_ns"] == step["stamp_ns"] and f["estimate"] is not None]
        median = np.array([np.median([e["x_m"] for e in est]),
                           np.median([e["y_m"] for e in est])])
        gain = 1.0 - np.exp(-(step["stamp_ns"] - last) / 1e9 / 0.5)
        track = median if track is None else track + gain * (median - track)
        last = step["stamp_ns"]
        assert [step["x_m"], step["y_m"]] == pytest.approx(list(track), abs=2e-6)
        moved += bool(np.hypot(*(track - median)) > 0.05)
    assert len(a["fused"]) >= 3 and moved >= 2  # the state shows: the track lags the median


def test_a_bad_calibration_model_and_a_fresh_part_per_replay() -> None:
    cases = [({"calibration_model": "no-such"}, "not an installed dual_sight.calibrations"),
             ({"calibration_model": "no_such_module:X"}, "No module named"),
             ({"calibration_model": "estimator.fusion:MeanFusion"}, "is not a calibration"),
             ({"calibration_model": "estimator.calibration:LinearCalibration"},
              "making it failed"),
             ({"calibration_model": "estimator.fusion:MeanFusion", "calibration": "paper"},
              "give one of the two")]
    for kwargs, what in cases:
        with pytest.raises(UsageError) as err:
            ReplayOptions(**kwargs)  # type: ignore[arg-type]
        assert what in str(err.value) and "\n" not in str(err.value), str(err.value)
        assert str(err.value).startswith("--calibration-model"), str(err.value)
    # a fusion from outside is made anew for each replay: no state carried over
    spec = "estimator.fusion:MeanFusion"
    first, second = new_part("fusion", spec), new_part("fusion", spec)
    assert first is not second and type(first) is type(second)
    assert first is not load_part("fusion", spec).obj


FACTORY = '''
from estimator.fusion import MeanFusion


def make_mean():
    """A factory: a function that makes the part, as a plug-in may offer instead of a class."""
    return MeanFusion()
'''


def test_a_factory_function_is_called_for_its_part(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """Guards how a spec's object becomes a part: a function is a factory, called (anew for
    each replay), never taken as the part itself."""
    from estimator.fusion import MeanFusion

    (tmp_path / "dsp_factory_parts.py").write_text(FACTORY)
    monkeypatch.syspath_prepend(str(tmp_path))
    spec = "dsp_factory_parts:make_mean"
    part = load_part("fusion", spec)
    assert isinstance(part.obj, MeanFusion) and part.name == "mean"
    first, second = new_part("fusion", spec), new_part("fusion", spec)
    assert isinstance(first, MeanFusion) and first is not second
