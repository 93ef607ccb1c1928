"""Every numeric option of every command is checked (finite, in range) before any work, and a
bad one ends in one line on stderr and exit 2, never a traceback or a half-written output.

The commands run in-process through their ``main`` (dsp.cli.run_main): the log, the scene or
the renderer are never reached, so these cases cost milliseconds.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import pytest

from recorder.calibrate_cli import main as calibrate_main
from recorder.cli import main as record_main
from replay.cli import main as replay_main
from replay.evaluate.cli import main as eval_main

Main = Callable[[Sequence[str] | None], int]

REPLAY: list[tuple[list[str], str]] = [
    (["--start", "nan"], "--start nan: give a finite number in [-9000000000, 9000000000] s"),
    (["--start=-1e10"], "--start -10000000000.0"),
    (["--start", "inf"], "--start inf"),
    (["--end", "1e300"], "--end 1e+300: give a finite number in [-9000000000, 9000000000] s"),
    (["--end=-inf"], "--end -inf"),
    (["--start", "2", "--end", "1"], "--end 1.0 is before --start 2.0"),
    (["--window", "inf"], "--window inf: give a finite number in (0, 60] s"),
    (["--window", "0"], "--window 0.0"),
    (["--window", "nan"], "--window nan"),
    (["--window", "-0.1"], "--window -0.1"),
    (["--pose-tolerance", "inf"], "--pose-tolerance inf: give a finite number in [0, 60] s"),
    (["--pose-tolerance", "nan"], "--pose-tolerance nan"),
    (["--pose-tolerance", "-1"], "--pose-tolerance -1.0"),
    (["--pose-tolerance", "1e9"], "--pose-tolerance 1000000000.0"),
    (["--image-topic", "/x"], "--image-topic '/x': the pattern must hold {robot} once"),
    (["--pose-topic", "/pose"], "--pose-topic '/pose': the pattern must hold {robot} once"),
    (["--pose-topic", "/{robot}/{robot}"], "--pose-topic '/{robot}/{robot}'"),
    (["--out", "r.txt"], "--out r.txt: the file name must end in .json (e.g. r.json)"),
    (["--out-mcap", "e.json"], "--out-mcap e.json: the file name must end in .mcap"),
    (["--save", "r.json"], "--save r.json: the file name must end in .rrd (e.g. r.rrd)"),
    (["--out-dir", "d", "--workers", "99999"], "--workers 99999: give at most 1024"),
    (["--threads", "1000000000"], "--threads 1000000000: give a whole number in [1, 1024]"),
    (["--max-chunk-mib", "1e-300"], "--max-chunk-mib 1e-300: give a finite number in [1, "
     "1048576] MiB"),
]

RECORD: list[tuple[list[str], str]] = [
    (["--duration", "inf"], "--duration inf: give a finite number in (0, 3600] s"),
    (["--duration", "nan"], "--duration nan"),
    (["--duration", "0"], "--duration 0.0"),
    (["--duration", "1e300"], "--duration 1e+300"),
    (["--frames", "0"], "--frames 0: give a whole number in [1, 72000]"),
    (["--frames", "100000000000"], "--frames 100000000000"),
    (["--rate", "nan"], "--rate nan: give a finite number in [0.1, 1000] Hz"),
    (["--rate", "inf"], "--rate inf"),
    (["--rate", "0"], "--rate 0.0"),
    (["--rate", "1e-9"], "--rate 1e-09: give a finite number in [0.1, 1000] Hz"),
    (["--rate", "1e-300"], "--rate 1e-300"),
    (["--frames", "70000", "--rate", "0.5"],
     "--frames 70000 at 0.5 Hz is 140000 s of simulated time; record at most 3600 s"),
    (["--duration", "3600", "--rate", "1000"],
     "3600 s at 1000 Hz is 3600000 frames; record at most 72000 (a longer run is several logs)"),
    (["--duration", "86400"], "--duration 86400.0: give a finite number in (0, 3600] s"),
    (["--scenario", "match", "--pose-rate", "1e-300"], "--pose-rate 1e-300: give a finite "
     "number in [0.1, 240] Hz"),
    (["--scenario", "match", "--image-noise", "1e9"], "--image-noise 1000000000.0: give a "
     "finite number in [0, 255] grey levels"),
    (["--scenario", "match", "--gain-jitter", "1e300"], "--gain-jitter 1e+300"),
    (["--scenario", "match", "--pose-bias", "1e300"], "--pose-bias 1e+300"),
    (["--scenario", "match", "--pose-bias-tau", "1e300"], "--pose-bias-tau 1e+300"),
    (["--seed", "-1"], "--seed -1: give a whole number in [0, 9223372036854775807]"),
    (["--seed", str(2**64)], f"--seed {2**64}"),
    (["--jpeg-quality", "101"], "--jpeg-quality 101: give a whole number in [1, 100]"),
    (["--pose-noise", "nan"], "--pose-noise nan: give a finite number in [0, 100] m"),
    (["--pose-noise", "-0.1"], "--pose-noise -0.1"),
    (["--yaw-noise", "inf"], "--yaw-noise inf: give a finite number in [0, 180] deg"),
    (["--robot-count", "0"], "--robot-count 0: give a whole number in [1, 8]"),
    (["--face-px", "1000000"], "--face-px 1000000: give a whole number in [256, 4096]"),
    (["--face-px", "8"], "--face-px 8"),
]

CALIBRATE: list[tuple[list[str], str]] = [
    (["--directions", ",".join(str(d) for d in range(37))],
     "--directions: 37 directions; give at most 36"),
    (["--start-m", "nan"], "--start-m nan: give a finite number in (0, 30] m"),
    (["--start-m", "0"], "--start-m 0.0"),
    (["--stop-m", "inf"], "--stop-m inf"),
    (["--step-m", "0"], "--step-m 0.0: give a finite number in (0, 30] m"),
    (["--step-m", "nan"], "--step-m nan"),
    (["--step-m", "1e-9"], "--step-m 1e-09: more than 10000 ranges"),
    (["--start-m", "5", "--stop-m", "1"], "--stop-m 1.0 is below --start-m 5.0"),
    (["--face-px", "8"], "--face-px 8: give a whole number in [16, 4096]"),
    (["--face-px", "100000"], "--face-px 100000"),
    (["--directions", "0,nan"], "--directions nan: give a finite number in [-360, 360] deg"),
    (["--directions", "inf"], "--directions inf"),
    (["--plot", "c.jpg"], "--plot c.jpg: the file name must end in .png"),
]

EVAL: list[tuple[list[str], str]] = [
    (["--workers", "0"], "--workers 0: give at least 1"),
    (["--workers", "100000"], "--workers 100000: give at most 1024"),
    (["--count", "0"], "--count 0: give a whole number in [1, 100000]"),
    (["--count", "1000000000"], "--count 1000000000"),
    (["--seed", "-5"], "--seed -5"),
    (["--seed", str(2**70)], f"--seed {2**70}"),
]

CASES = (
    [("dsp-replay", replay_main, ["log.mcap", *a], m) for a, m in REPLAY]
    + [("dsp-record", record_main, ["scenario1.mcap", *a], m) for a, m in RECORD]
    + [("dsp-calibrate", calibrate_main, ["-o", "c.json", *a], m) for a, m in CALIBRATE]
    + [("dsp-eval", eval_main, ["--suite", "random", "--out-dir", "ev", *a], m)
       for a, m in EVAL]
)


@pytest.mark.parametrize(("prog", "main", "argv", "message"), CASES,
                         ids=[f"{c[0]}:{' '.join(c[2][1:])}" for c in CASES])
def test_bad_number_is_one_line_and_exit_2(prog: str, main: Main, argv: list[str],
                                           message: str, tmp_path: Path,
                                           monkeypatch: pytest.MonkeyPatch,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    code = main(argv)
    out, err = capsys.readouterr()
    assert code == 2, err
    assert err.startswith(f"{prog}: error: {message}"), err
    assert err.count("\n") == 1 and "Traceback" not in err and out == ""
    assert list(tmp_path.iterdir()) == []  # nothing written, nothing left behind


def test_record_refuses_a_log_name_without_mcap(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    code = record_main([str(tmp_path / "scenario2.txt"), "--face-px", "256"])
    err = capsys.readouterr().err
    assert code == 2
    assert err == (f"dsp-record: error: output {tmp_path / 'scenario2.txt'}: the file name must "
                   f"end in .mcap (e.g. {tmp_path / 'scenario2.mcap'})\n")
    assert list(tmp_path.iterdir()) == []


def test_calibrate_refuses_a_plot_on_its_json(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "c.json"
    link = tmp_path / "l.png"
    link.symlink_to(out)
    assert calibrate_main(["-o", str(out), "--plot", str(link), "--force"]) == 2
    assert "--out and --plot both name" in capsys.readouterr().err


def test_eval_never_writes_its_table_over_the_calibration(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from estimator.calibration import LinearCalibration, calibration_to_json

    calib = tmp_path / "paper-ideal.json"  # where dsp-eval's paper table goes
    calib.write_text(calibration_to_json(LinearCalibration(0.0166, -0.5)))
    before = calib.read_text()
    code = eval_main(["--out-dir", str(tmp_path), "--calibration", str(calib)])
    err = capsys.readouterr().err
    assert code == 2 and err == (f"dsp-eval: error: the table {calib} is the --calibration "
                                 "file; an output never overwrites an input, choose another "
                                 "file\n")
    assert calib.read_text() == before and [p.name for p in tmp_path.iterdir()] == [calib.name]


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"web_port": 99_999_999}, "--port 99999999: give a whole number in [0, 65535]"),
    ({"grpc_port": -1}, "--grpc-port -1: give a whole number in [0, 65535]"),
])
def test_a_port_out_of_range_is_refused_before_a_server_starts(
        kwargs: dict[str, int], message: str) -> None:
    """--serve --port 99999999 was an OverflowError traceback from the socket's bind."""
    from dsp.errors import UsageError
    from replay.sinks.rerun.live import ViewerServer

    with pytest.raises(UsageError) as info:
        ViewerServer(**kwargs)  # type: ignore[arg-type]
    assert str(info.value) == message
