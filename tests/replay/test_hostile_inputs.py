"""What a careless or hostile user gives the commands: a folder (``/``, ``.``) for every output
flag, a device or a FIFO for every input file, camera metadata with empty fields. Each is one
line naming the file, a non-zero exit, no traceback, nothing written and nothing blocking."""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Sequence
from pathlib import Path

import pytest
from fuzzing import read_raw, write_raw
from synthetic import write_log

from recorder.cli import main as record_main
from replay.calibrate.cli import main as calibrate_main
from replay.cli import main as replay_main
from replay.evaluate.cli import main as eval_main
from replay.info.cli import main as info_main

Main = Callable[[Sequence[str] | None], int]


pytestmark = pytest.mark.usefixtures("no_hang")


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_log(tmp_path_factory.mktemp("log") / "in.mcap", duration_s=0.3).path


def one_line(main: Main, argv: Sequence[str | Path], capsys: pytest.CaptureFixture[str],
             code: int) -> str:
    got = main([str(a) for a in argv])
    _, err = capsys.readouterr()
    assert (got, err.count("\n"), "Traceback" in err) == (code, 1, False), err
    return err.strip()


# --- output paths that can only be folders ----------------------------------------------------
REPLAY_OUTPUTS = [("--out", ".json"), ("--out-mcap", ".mcap"), ("--out-csv", ".csv"),
                  ("--save", ".rrd"), ("--plot", ".png")]


@pytest.mark.parametrize("folder", ["/", ".", ".."])
@pytest.mark.parametrize(("flag", "suffix"), REPLAY_OUTPUTS)
def test_a_folder_as_a_replay_output_is_one_line(log: Path, tmp_path: Path, folder: str,
                                                 flag: str, suffix: str,
                                                 monkeypatch: pytest.MonkeyPatch,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    err = one_line(replay_main, [log, flag, folder, "--no-progress"], capsys, 2)
    assert err == (f"dsp-replay: error: {flag} {folder}: is a folder; give a file name "
                   f"(e.g. {Path(folder) / ('out' + suffix)})")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("folder", ["/", "."])
def test_a_folder_as_another_commands_output_is_one_line(
        log: Path, tmp_path: Path, folder: str, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    err = one_line(record_main, [folder, "--scenario", "scenario1", "--no-progress"], capsys, 2)
    assert err.startswith(f"dsp-record: error: output {folder}: is a folder")
    err = one_line(calibrate_main, ["-o", folder, "--no-progress"], capsys, 2)
    assert err.startswith(f"dsp-calibrate: error: -o/--out {folder}: is a folder")
    err = one_line(calibrate_main, ["-o", "c.json", "--plot", folder, "--no-progress"],
                   capsys, 2)
    assert err.startswith(f"dsp-calibrate: error: --plot {folder}: is a folder")
    err = one_line(info_main, [log, "--cameras-template", "-o", folder], capsys, 2)
    assert err.startswith(f"dsp-info: error: -o/--out {folder}: is a folder")
    assert list(tmp_path.iterdir()) == []


# --- input files that are not regular files ---------------------------------------------------
@pytest.fixture
def fifo(tmp_path: Path) -> Path:
    path = tmp_path / "pipe.json"
    os.mkfifo(path)
    return path


def inputs(log: Path, bad: Path) -> list[tuple[Main, list[str | Path]]]:
    return [
        (replay_main, [log, "--calibration", bad, "--no-progress"]),
        (replay_main, [log, "--cameras", bad.with_suffix(".yaml"), "--no-progress"]),
        (eval_main, ["--calibration", bad, "--no-progress"]),
        (calibrate_main, ["--from-measurements", bad.with_suffix(".csv"), "-o",
                          bad.with_name("c.yaml"), "--image-size", "1080x1080", "--no-progress"]),
    ]


@pytest.mark.parametrize("case", range(4))
def test_a_device_or_a_fifo_as_an_input_file_is_one_line(
        log: Path, tmp_path: Path, case: int, capsys: pytest.CaptureFixture[str]) -> None:
    for suffix in (".json", ".yaml", ".csv"):
        os.mkfifo(tmp_path / f"pipe{suffix}")
        (tmp_path / f"dev{suffix}").symlink_to("/dev/zero")
    for bad in (tmp_path / "pipe.json", tmp_path / "dev.json"):
        main, argv = inputs(log, bad)[case]
        err = one_line(main, argv, capsys, 1)
        assert "not a regular file" in err and str(bad.stem) in err, err
    made = {p.name for p in tmp_path.iterdir()}
    assert made == {f"{k}{s}" for k in ("pipe", "dev") for s in (".json", ".yaml", ".csv")}


def test_a_folder_as_the_calibration_is_told_from_a_missing_one(
        log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    err = one_line(replay_main, [log, "--calibration", tmp_path, "--no-progress"], capsys, 1)
    assert err.endswith(f"{tmp_path}: unusable calibration: is a folder; give a calibration "
                        "JSON file"), err
    missing = tmp_path / "missing.json"
    err = one_line(replay_main, [log, "--calibration", missing, "--no-progress"], capsys, 1)
    assert err.endswith(f"{missing}: unusable calibration: cannot read: No such file or "
                      "directory"), err


# --- camera metadata with empty fields --------------------------------------------------------
@pytest.mark.parametrize("key", ["cu_px", "cv_px", "width_px", "height_px", "model",
                                 "k_m_per_px", "max_radius_px"])
def test_camera_metadata_with_a_null_field_is_one_line(
        log: Path, tmp_path: Path, key: str, capsys: pytest.CaptureFixture[str]) -> None:
    raw = read_raw(log)
    assert any(name == "dsp.cameras" for name, _ in raw.metadata)
    raw.metadata = [(name, {robot: json.dumps({**json.loads(text), key: None})
                            for robot, text in data.items()} if name == "dsp.cameras" else data)
                    for name, data in raw.metadata]
    bad = tmp_path / "null.mcap"
    bad.write_bytes(write_raw(raw))
    out = tmp_path / "r.json"
    err = one_line(replay_main, [bad, "--out", out, "--no-progress"], capsys, 1)
    assert err.startswith(f"dsp-replay: error: {bad}: metadata dsp.cameras: ") and key in err
    assert not out.exists()
    assert info_main([str(bad)]) == 0  # the summary says what is wrong and goes on
    shown = capsys.readouterr()
    assert "Traceback" not in shown.err and f".{key}" in shown.out


def test_a_folder_a_device_and_a_missing_log_get_their_own_message(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "missing.mcap"
    for main, prog in ((replay_main, "dsp-replay"), (info_main, "dsp-info")):
        err = one_line(main, [missing], capsys, 1)
        assert err == f"{prog}: error: {missing}: no such file (check the path)"
        err = one_line(main, [tmp_path], capsys, 1)
        assert err.startswith(f"{prog}: error: {tmp_path}: is a folder, not a log")
        err = one_line(main, ["/dev/zero"], capsys, 1)
        assert err == (f"{prog}: error: /dev/zero: not a regular file (a device, pipe or "
                       "socket): give the log file itself")


# --- options are spelled out ---------------------------------------------------------------
@pytest.mark.parametrize(("main", "argv"), [
    (replay_main, ["in.mcap", "--sav", "r.rrd"]),  # not --save
    (info_main, ["in.mcap", "--js", "x"]),  # not --json
    (record_main, ["out.mcap", "--scen", "scenario1"]),  # not --scenario
    (eval_main, ["--sui", "paper"]),  # not --suite
    (calibrate_main, ["-o", "c.json", "--start", "1"]),  # not --start-m
])
def test_an_abbreviated_option_is_refused(main: Main, argv: list[str],
                                          capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    assert "unrecognized arguments: " + argv[-2] in capsys.readouterr().err
