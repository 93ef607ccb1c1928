"""Parts from outside: the example package under examples/ installed with pip (offline, into
a folder of its own), picked by entry point and by path, its results checked against the
same algorithms computed here, the header naming the parts; bad specs are one line."""

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

from replay.compare import compare
from replay.log import ImageMessage, LogReader, decode_image
from replay.options import ReplayOptions
from replay.plugins import load_part

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "dual-sight-example-parts"
LOG = ROOT / "logs" / "golden" / "scenario2.mcap"


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


def _replay(site: Path, out: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(site)}
    return subprocess.run([sys.executable, "-m", "replay.cli", str(LOG), "--out", str(out),
                           "-q", *extra], env=env, capture_output=True, text=True)


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
             (["--fusion", "dsp_example_parts.detector:CentroidDetector"], "is not a fusion")]
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
