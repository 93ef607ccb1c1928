"""What a user supplies is validated, each problem one line naming the file: a calibration
whose ranges fall or are negative over the image, non-finite numbers in a ball model."""

from __future__ import annotations

from pathlib import Path

import pytest

from dsp.errors import CalibrationError
from estimator.calibration import (
    PAPER_CALIBRATION,
    LinearCalibration,
    MirrorCalibration,
    calibration_to_json,
)
from replay.cameras import check_ranges
from replay.cli import main as replay_main

ROOT = Path(__file__).resolve().parents[2]
LOG = ROOT / "logs" / "golden" / "scenario1.mcap"


@pytest.mark.parametrize(("model", "message"), [
    (LinearCalibration(-0.02, -5.0), "its range falls from -5 m at 0 px to "),
    (LinearCalibration(0.02, -5.0), " m, negative; a range grows from the image centre"),
])
def test_a_calibration_whose_ranges_fall_or_are_negative_is_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], model: LinearCalibration,
        message: str) -> None:
    cal = tmp_path / "cal.json"
    cal.write_text(calibration_to_json(model))
    out = tmp_path / "r.json"
    assert replay_main([str(LOG), "--calibration", str(cal), "--out", str(out), "-q"]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"dsp-replay: error: --calibration {cal} (robot1): unusable "
                          "calibration: its ") and err.count("\n") == 1, err
    assert message in err
    assert not out.exists()


def test_the_calibrations_in_use_pass() -> None:
    check_ranges(PAPER_CALIBRATION, 540.0, "paper")
    check_ranges(LinearCalibration(0.02, -0.3), 540.0, "a small negative offset near the centre")
    # a mirror's range grows to its horizon (b r = pi/2, at 524 px here) and stops there
    check_ranges(MirrorCalibration(0.5, 0.003), 1000.0, "a mirror")
    with pytest.raises(CalibrationError, match=r"^x: unusable calibration: its range at"):
        check_ranges(LinearCalibration(0.0, -1.0), 540.0, "x")
