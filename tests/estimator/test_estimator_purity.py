"""estimator/ is pure: importing it (or any submodule) pulls in no mcap, rerun or pybullet."""

from __future__ import annotations

import subprocess
import sys

import pytest

MODULES = [
    "estimator",
    "estimator.errors",
    "estimator.geometry",
    "estimator.detection",
    "estimator.paper",
    "estimator.constants",
    "estimator.calibration",
    "estimator.calibration_models",
    "estimator.calibration_fit",
    "estimator.calibration_json",
    "estimator.corrected",
    "estimator.fusion",
]
FORBIDDEN = ("mcap", "rerun", "pybullet", "mcap_ros2", "rosbags")


@pytest.mark.parametrize("module", MODULES)
def test_import_is_pure(module: str) -> None:
    code = (
        f"import sys, importlib; importlib.import_module({module!r}); "
        f"bad = sorted(m for m in sys.modules if m.split('.')[0] in {FORBIDDEN!r}); "
        "print(','.join(bad))"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60
    )
    assert result.stdout.strip() == ""
