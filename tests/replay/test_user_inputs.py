"""What a user supplies is validated, each problem one line naming the file: a calibration
whose ranges fall or are negative over the image, non-finite numbers in a ball model."""

from __future__ import annotations

from pathlib import Path

import pytest

from dsp.errors import CalibrationError
from estimator.calibration import (
    PAPER_CALIBRATION,
    LinearCalibration,
    LookupCalibration,
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
    (LinearCalibration(0.0, 0.0), "its range only grows from 0 m at 0 px to 0 m at 540 px"),
    (LinearCalibration(1e-308, 1.0), "its range only grows from 1 m at 0 px to 1 m at 540 px"),
    (LookupCalibration((1.0, 2.0, 3.0), (-5.0, -3.0, -1.0)),
     "its range at 59 px, within the inner half of the image, is 111 m;"),
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


@pytest.mark.parametrize(("text", "message"), [
    ('{"model": "lookup", "r_px": [-100, 300], "d_m": [0, 3]}', "r_px = -100 is outside"),
    ('{"model": "lookup", "r_px": [0, 1e308], "d_m": [0, 3]}', "r_px = 1e+308 is outside"),
    ('{"model": "lookup", "r_px": [0, 300], "d_m": [0, 1e308]}', "d_m = 1e+308 is outside"),
    ('{"model": "mirror", "a_m": 1e308, "b_rad_per_px": 0.001}', "a_m = 1e+308 is outside"),
    ('{"model": "linear", "a_m_per_px": 1e300, "b_m": 0}', "a_m_per_px = 1e+300 is outside"),
])
def test_a_calibration_with_numbers_no_camera_has_is_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, message: str) -> None:
    cal = tmp_path / "cal.json"
    cal.write_text(text)
    assert replay_main([str(LOG), "--calibration", str(cal), "-q"]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"dsp-replay: error: {cal}: unusable calibration: {message} [")
    assert err.count("\n") == 1 and "Traceback" not in err


def test_the_calibrations_in_use_pass() -> None:
    check_ranges(PAPER_CALIBRATION, 540.0, "paper")
    check_ranges(LinearCalibration(0.02, -0.3), 540.0, "a small negative offset near the centre")
    # a mirror's range grows to its horizon (b r = pi/2, at 524 px here) and stops there
    check_ranges(MirrorCalibration(0.5, 0.003), 1000.0, "a mirror")
    with pytest.raises(CalibrationError, match=r"^x: unusable calibration: its range at"):
        check_ranges(LinearCalibration(0.0, -1.0), 540.0, "x")


def _ball_model(size_line: list[float], diameter_px: tuple[float, float] = (4.0, 160.0)) -> str:
    import json

    import numpy as np

    from estimator.detection.real.model import (
        COLOUR_BINS,
        FIELD_BINS,
        BallModel,
        model_to_dict,
    )

    model = BallModel(colour_lut=np.zeros(COLOUR_BINS, np.uint8),
                      field_mask=np.zeros(FIELD_BINS, np.uint8), levels=(150,))
    return json.dumps({**model_to_dict(model), "size_line": size_line,
                       "diameter_px": list(diameter_px)})


@pytest.mark.parametrize("size_line", [[float("nan"), 3.0], [1e308, 0.0], [0.2, -1e308],
                                       [-0.5, 10.0]])
def test_a_ball_model_with_a_size_line_out_of_range_is_one_line(
        tmp_path: Path, size_line: list[float]) -> None:
    from dsp.ball_file import read_ball_file
    from dsp.errors import InputError

    path = tmp_path / "ball.json"
    path.write_text(_ball_model(size_line))
    with pytest.raises(InputError) as info:
        read_ball_file(path)
    assert str(info.value).startswith(f"{path}: size_line (") and "\n" not in str(info.value)
    path.write_text(_ball_model([0.2, 3.0]))
    assert read_ball_file(path).size_line == (0.2, 3.0)


@pytest.mark.parametrize("diameter_px", [(4.0, 1e308), (0.0, 10.0), (20.0, 10.0)])
def test_a_ball_model_with_a_diameter_range_no_ball_has_is_one_line(
        tmp_path: Path, diameter_px: tuple[float, float]) -> None:
    from dsp.ball_file import read_ball_file
    from dsp.errors import InputError

    path = tmp_path / "ball.json"
    path.write_text(_ball_model([0.2, 3.0], diameter_px))
    with pytest.raises(InputError) as info:
        read_ball_file(path)
    assert str(info.value).startswith(f"{path}: diameter range [") and "\n" not in str(info.value)
    assert str(info.value).endswith("px is not 0 < min <= max <= 10000")


@pytest.mark.parametrize(("key", "value"), [("height_m", "1e308"), ("cu_px", "-1e300"),
                                            ("k_m_per_px", ".nan"), ("k_m_per_px", "1e7")])
def test_a_camera_file_with_a_number_out_of_range_is_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], key: str, value: str) -> None:

    from replay.info.cli import main as info_main

    template = tmp_path / "cameras.yaml"
    assert info_main([str(LOG), "--cameras-template", "-o", str(template)]) == 0
    capsys.readouterr()
    text = template.read_text()
    line = next(t for t in text.splitlines() if t.strip().startswith(f"{key}:"))
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace(line, f"{line.split(':')[0]}: {value}", 1))
    assert replay_main([str(LOG), "--cameras", str(bad), "-q"]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"dsp-replay: error: {bad}: robot1.{key} = ") and err.count("\n") == 1


def test_a_reused_eval_log_of_another_scene_is_refused(tmp_path: Path) -> None:
    """dsp-eval reuses a log it finds under the expected name only when its metadata is
    that scene: another scenario's log named random-seed0 is not scored as random seed 0."""
    import shutil

    from dsp.errors import InputError
    from replay.evaluate.scenes import prepare_log
    from replay.log import LogReader

    with LogReader(LOG) as reader:
        assert reader.info.scenario is not None
        seed = reader.info.scenario.seed
    log = tmp_path / "random-seed0.mcap"
    shutil.copyfile(LOG, log)
    before = log.read_bytes()
    recorded: list[Path] = []
    with pytest.raises(InputError) as info:
        prepare_log(log, "random", 0, lambda: recorded.append(log))
    assert str(info.value) == (f"{log}: reused as random seed 0, but the log is scenario1 seed "
                               f"{seed}; remove it (it is recorded again) or choose another "
                               "--out-dir")
    assert log.read_bytes() == before and not recorded
    prepare_log(log, "scenario1", seed, lambda: recorded.append(log))  # the same scene: reused
    assert not recorded
    prepare_log(tmp_path / "missing.mcap", "random", 0, lambda: recorded.append(log))
    assert recorded == [log]


def test_a_ball_model_with_too_many_levels_is_one_line(tmp_path: Path) -> None:
    """Each level is a pass over every image: 255 of them took minutes a frame."""
    import json

    from dsp.ball_file import read_ball_file
    from dsp.errors import InputError

    path = tmp_path / "ball.json"
    path.write_text(json.dumps({**json.loads(_ball_model([0.2, 3.0])),
                                "levels": list(range(1, 256))}))
    with pytest.raises(InputError, match=r"levels .* must be at most 16 distinct bytes"):
        read_ball_file(path)
