"""dsp.cli: --version on every command, one exit-code mapping, one progress rule, shared
option names; through the real entry points."""

from __future__ import annotations

import argparse
import io
import os
import subprocess
import sys
from collections.abc import Callable, Sequence
from importlib import metadata
from pathlib import Path

import pytest
from synthetic import write_log

import recorder.calibrate_cli
import recorder.cli
import replay.cli
import replay.evaluate.cli
from dsp.cli import RENDERERS, add_common_arguments, progress_enabled, run_main
from dsp.errors import DspError, InputError, OutputExistsError, UsageError
from estimator.camera import CAMERA_MODELS
from replay import ReplayOptions
from replay.parallel import Workers

COMMANDS = {
    "dsp-record": "recorder.cli",
    "dsp-calibrate": "recorder.calibrate_cli",
    "dsp-replay": "replay.cli",
    "dsp-eval": "replay.evaluate.cli",
}
MAINS: dict[str, Callable[[Sequence[str] | None], int]] = {
    "dsp-record": recorder.cli.main,
    "dsp-calibrate": recorder.calibrate_cli.main,
    "dsp-replay": replay.cli.main,
    "dsp-eval": replay.evaluate.cli.main,
}
PARSERS = {
    "dsp-record": recorder.cli.build_parser,
    "dsp-calibrate": recorder.calibrate_cli.build_parser,
    "dsp-replay": replay.cli.build_parser,
    "dsp-eval": replay.evaluate.cli.build_parser,
}


def run(module: str, *args: str | Path, cwd: Path | None = None
        ) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", module, *map(str, args)], capture_output=True,
                          text=True, timeout=120, check=False, cwd=cwd)


@pytest.mark.parametrize("prog", COMMANDS)
def test_version_on_every_command(prog: str) -> None:
    done = run(COMMANDS[prog], "--version")
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"{prog} {metadata.version('dual-sight')}"


@pytest.mark.parametrize("prog", COMMANDS)
def test_argparse_errors_are_usage_errors(prog: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert MAINS[prog](["--no-such-option"]) == 2
    assert f"{prog}: error:" in capsys.readouterr().err
    assert MAINS[prog](["--version"]) == 0  # main returns, it does not raise SystemExit


@pytest.mark.parametrize("prog", ["dsp-record", "dsp-calibrate", "dsp-eval"])
def test_camera_and_renderer_choices_are_shared(prog: str) -> None:
    actions = {a.dest: a for a in PARSERS[prog]()._actions}
    assert tuple(actions["camera"].choices) == tuple(CAMERA_MODELS)
    assert actions["camera"].default == "ideal"
    assert tuple(actions["renderer"].choices) == RENDERERS


def test_option_names_and_units_agree() -> None:
    record = {a.dest for a in PARSERS["dsp-record"]()._actions}
    calibrate = {a.dest for a in PARSERS["dsp-calibrate"]()._actions}
    # --robots is a list of names (dsp-replay); dsp-record takes a count
    assert "robot_count" in record and "robots" not in record
    # --start is seconds (dsp-replay); dsp-calibrate's distances say metres
    assert {"start_m", "stop_m", "step_m"} <= calibrate
    assert not {"start", "stop", "step"} & calibrate
    for prog in COMMANDS:
        dests = {a.dest for a in PARSERS[prog]()._actions}
        assert {"progress", "quiet"} <= dests, prog
        assert ("force" in dests) == (prog != "dsp-eval"), prog


def fail_with(exc: BaseException) -> Callable[[Sequence[str] | None], int]:
    def fn(argv: Sequence[str] | None) -> int:
        raise exc
    return fn


@pytest.mark.parametrize(("exc", "code", "line"), [
    (UsageError("--window 0; must be > 0"), 2, "prog: error: --window 0; must be > 0"),
    (InputError("x.mcap: not a file"), 1, "prog: error: x.mcap: not a file"),
    (OutputExistsError("o.json"), 3,
     "prog: error: o.json: output exists already (use --force to overwrite)"),
    (DspError("plain"), 1, "prog: error: plain"),
    (KeyboardInterrupt(), 130, "prog: interrupted"),
    (FileNotFoundError(2, "No such file or directory", "d/x"), 1,
     "prog: error: d/x: No such file or directory"),
    (PermissionError(13, "Permission denied", "a", None, "b"), 1,
     "prog: error: a -> b: Permission denied"),
    (OSError("no errno"), 1, "prog: error: no errno"),
])
def test_run_main_maps_errors_to_one_line_and_a_code(
    exc: BaseException, code: int, line: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert run_main("prog", fail_with(exc), []) == code
    captured = capsys.readouterr()
    assert captured.err == line + "\n" and captured.out == ""


def test_run_main_lets_bugs_through() -> None:
    with pytest.raises(ValueError, match="a bug"):
        run_main("prog", fail_with(ValueError("a bug")), [])


def test_run_main_passes_argv_and_the_return_code() -> None:
    seen: list[Sequence[str] | None] = []

    def fn(argv: Sequence[str] | None) -> int:
        seen.append(argv)
        return 5

    assert run_main("prog", fn, ["a"]) == 5 and seen == [["a"]]


class Stream(io.StringIO):
    def __init__(self, tty: bool) -> None:
        super().__init__()
        self.tty = tty

    def isatty(self) -> bool:
        return self.tty


def parse(*argv: str) -> argparse.Namespace:
    p = argparse.ArgumentParser()
    add_common_arguments(p)
    return p.parse_args(argv)


@pytest.mark.parametrize(("argv", "tty", "expected"), [
    ((), True, True),                      # default: a bar on a terminal
    ((), False, None),                     # ... and plain lines in a pipe or a log file
    (("--progress",), False, True),        # explicit wins
    (("--no-progress",), True, False),
    (("--quiet",), True, False),           # quiet: no bar ...
    (("--quiet", "--progress"), False, True),  # ... unless asked for
])
def test_one_progress_rule(argv: tuple[str, ...], tty: bool, expected: bool | None) -> None:
    assert progress_enabled(parse(*argv), Stream(tty)) is expected


def test_progress_and_no_progress_exclude_each_other(capsys: pytest.CaptureFixture[str]
                                                     ) -> None:
    with pytest.raises(SystemExit) as info:
        parse("--progress", "--no-progress")
    assert info.value.code == 2
    capsys.readouterr()


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("cli") / "good.mcap"
    write_log(path, duration_s=0.4)
    return path


@pytest.mark.parametrize(("argv", "expected"), [
    ((), None),  # under pytest stderr is no terminal: plain lines
    (("--progress",), True),
    (("--quiet",), False),
])
def test_dsp_replay_passes_the_decided_progress(
    log: Path, argv: tuple[str, ...], expected: bool | None, monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    seen: list[ReplayOptions] = []

    def fake_replay(path: Path, options: ReplayOptions) -> object:
        seen.append(options)
        raise UsageError("stop here")

    monkeypatch.setattr(replay.cli, "replay", fake_replay)
    assert replay.cli.main([str(log), *argv]) == 2
    assert seen[0].progress is expected
    capsys.readouterr()


def test_dsp_replay_exit_codes_and_quiet(log: Path, tmp_path: Path) -> None:
    out = tmp_path / "r.json"
    done = run("replay.cli", log, "--out", out, "--quiet")
    assert done.returncode == 0, done.stderr
    assert done.stdout == "" and done.stderr == "" and out.is_file()
    before = out.read_bytes()
    again = run("replay.cli", log, "--out", out)
    assert again.returncode == 3  # refused overwrite: the same code on every command
    assert again.stderr == f"dsp-replay: error: {out}: output exists already " \
        "(use --force to overwrite)\n"
    assert out.read_bytes() == before
    assert run("replay.cli", log, "--window", "0").returncode == 2
    assert run("replay.cli", tmp_path / "missing.mcap").returncode == 1
    assert run("replay.cli", log, "--start", "x").returncode == 2  # argparse's own


def test_dsp_calibrate_refuses_before_rendering(tmp_path: Path) -> None:
    out = tmp_path / "c.json"
    out.write_text("mine")
    done = run("recorder.calibrate_cli", "-o", out, "--no-plot")
    assert done.returncode == 3 and "output exists already" in done.stderr
    assert out.read_text() == "mine"
    bad = run("recorder.calibrate_cli", "-o", tmp_path / "d.json", "--directions", "x,y")
    assert bad.returncode == 2 and "--directions" in bad.stderr
    gone = run("recorder.calibrate_cli", "-o", tmp_path / "no" / "d.json")
    assert gone.returncode == 2 and "does not exist" in gone.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.json"]  # no temp file left


def test_dsp_record_takes_a_robot_count(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                        ) -> None:
    assert recorder.cli.main([str(tmp_path / "scenario1.mcap"), "--robot-count", "4"]) == 2
    assert "--robot-count" in capsys.readouterr().err
    assert recorder.cli.main([str(tmp_path / "r.mcap"), "--robots", "3"]) == 2
    assert "unrecognized arguments: --robots" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_dsp_eval_counts_finished_scenes_on_its_bar() -> None:
    class Bar:
        n = 0

        def update(self, k: int) -> None:
            self.n += k

    bar = Bar()
    map_scenes = replay.evaluate.cli._scene_mapper(Workers(count=1), bar)
    assert map_scenes(lambda t: 2 * t, [1, 2, 3]) == [2, 4, 6]  # in order
    assert bar.n == 3


def test_a_closed_pipe_ends_a_command_quietly() -> None:
    """``dsp-info LOG | head``: output past what the reader took is no error to report."""
    script = ("import sys\nfrom dsp.cli import run_main\n"
              "def fn(argv):\n    for _ in range(20000):\n        print('x' * 100)\n"
              "sys.exit(run_main('dsp-x', fn, []))\n")
    proc = subprocess.run(f'{sys.executable} -c "$SCRIPT" | head -c 10', shell=True,
                          capture_output=True, text=True, timeout=60, check=False,
                          env={**os.environ, "SCRIPT": script})
    assert proc.stdout == "x" * 10
    assert proc.stderr == ""


def test_an_error_line_is_cut_to_a_readable_length(capsys: pytest.CaptureFixture[str]) -> None:
    """A log naming 10,000 robots gave a 69 kB error line: it is cut, still one line."""
    from dsp.cli import MAX_ERROR_CHARS

    names = ", ".join(f"robot{i}" for i in range(10_000))
    assert run_main("prog", fail_with(InputError(f"x.mcap: no camera for {names}")), []) == 1
    err = capsys.readouterr().err
    assert err.startswith("prog: error: x.mcap: no camera for robot0, robot1")
    assert err.endswith("...\n") and err.count("\n") == 1
    assert len(err) == MAX_ERROR_CHARS + len("...\n")
