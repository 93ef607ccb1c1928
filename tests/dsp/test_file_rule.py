"""The one rule for outputs, walked over every command's parser: each option that names a
file is declared as read or written (:func:`dsp.atomic.declare_files`), and every file a
command reads is refused as any file it writes, through a symlink too, with ``--force``:
exit 2, one line naming both, the input unchanged.

A new file option fails :func:`test_every_file_option_is_declared` until it is declared, and
:func:`test_every_input_and_output_pair_is_tried` until a case below writes on it."""

from __future__ import annotations

import argparse
import importlib
import re
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pytest

from dsp.atomic import FileOptions, declared_files

COMMANDS = {
    "dsp-record": "recorder.cli",
    "dsp-replay": "replay.cli",
    "dsp-calibrate": "replay.calibrate.cli",
    "dsp-calibrate (simulated)": "recorder.calibrate_cli",
    "dsp-eval": "replay.evaluate.cli",
    "dsp-info": "replay.info.cli",
    "dsp-compare": "replay.compare.cli",
}

_FILE_WORDS = ("FILE", "DIR", "JSON", "MCAP", "CSV", "PNG", "RRD", "ONNX", "YAML", "LOG")


def _module(command: str) -> ModuleType:
    return importlib.import_module(COMMANDS[command])


def _names(action: argparse.Action) -> str:
    return action.option_strings[-1] if action.option_strings else action.dest


def _looks_like_a_file(action: argparse.Action) -> bool:
    if action.nargs == 0 or isinstance(action, (argparse._HelpAction,
                                                 argparse._VersionAction)):
        return False
    metavar = action.metavar if isinstance(action.metavar, str) else ""
    return (action.type is Path or re.search(r"\.[A-Za-z]+$", metavar) is not None
            or any(word in metavar.upper().split("|") for word in _FILE_WORDS))


@pytest.mark.parametrize("command", COMMANDS)
def test_every_file_option_is_declared(command: str) -> None:
    parser = _module(command).build_parser()
    files = declared_files(parser)
    declared = set(files.options)
    for action in parser._actions:
        if _looks_like_a_file(action):
            assert declared & {*action.option_strings, action.dest}, (
                f"{command}: {_names(action)} names a file: declare it (dsp.atomic."
                "declare_files) as an input or an output")


# (command, input option, output option or output folder's file) -> argv, given the victim
# file (the input) and the path the output is given as (the victim or a link to it)
Case = Callable[[Path, Path, Path], list[str]]


def _replay(option: str, out: str) -> Case:
    def argv(tmp: Path, victim: Path, as_out: Path) -> list[str]:
        inputs = {"log": [str(tmp / "run.mcap")], "--ball": [], "--cameras": [],
                  "--calibration": []}
        inputs[option] = [str(victim)] if option == "log" else [option, str(victim)]
        return [*inputs["log"], *inputs["--ball"], *inputs["--cameras"],
                *inputs["--calibration"], out, str(as_out), "--force"]
    return argv


def _replay_batch(option: str, name: str) -> Case:
    def argv(tmp: Path, victim: Path, as_out: Path) -> list[str]:
        # the victim sits where the batch writes ``name`` into --out-dir
        out_dir = victim.parent
        (tmp / "logs").mkdir(exist_ok=True)
        (tmp / "logs" / "run.mcap").write_bytes(b"")
        log = [str(tmp / "logs" / "run.mcap")] if option != "log" else [str(victim)]
        extra = [] if option == "log" else [option, str(victim)]
        return [*log, *extra, "--out-dir", str(out_dir), "--force"]
    return argv


def _compare(option: str, out: str) -> Case:
    def argv(tmp: Path, victim: Path, as_out: Path) -> list[str]:
        a = str(victim) if option == "a" else str(tmp / "a.json")
        b = str(victim) if option == "b" else str(tmp / "b.json")
        shown = [] if out == "--save" else ["--rerun"]  # --log goes with one of the two
        rerun = (["--log", str(victim), *shown] if option == "--log"
                 else ["--log", str(tmp / "run.mcap")] if out == "--save" else [])
        return [a, b, *rerun, out, str(as_out), "--force"]
    return argv


def _calibrate(option: str, out: str) -> Case:
    def argv(tmp: Path, victim: Path, as_out: Path) -> list[str]:
        outs = {"--out": str(tmp / "cal.json"), out: str(as_out)}
        extra = ["--image-size", "640x480"] if option == "--from-measurements" else []
        return [option, str(victim), *extra, "--out", outs["--out"],
                *(["--plot", outs["--plot"]] if "--plot" in outs else []), "--force"]
    return argv


def _info(tmp: Path, victim: Path, as_out: Path) -> list[str]:
    return [str(victim), "--cameras-template", "--out", str(as_out), "--force"]


def _eval_images(tmp: Path, victim: Path, as_out: Path) -> list[str]:
    (tmp / "images").mkdir(exist_ok=True)
    return ["--suite", "images", str(tmp / "images"), "--check-model", str(victim),
            "--out-dir", str(victim.parent)]


def _eval_images_with(option: str) -> Case:
    def argv(tmp: Path, victim: Path, as_out: Path) -> list[str]:
        (tmp / "images").mkdir(exist_ok=True)
        extra = ["--train-count", "0"] if option == "--ball" else []
        return ["--suite", "images", str(tmp / "images"), *extra, option, str(victim),
                "--out-dir", str(victim.parent)]
    return argv


def _eval_table(tmp: Path, victim: Path, as_out: Path) -> list[str]:
    return ["--calibration", str(victim), "--out-dir", str(victim.parent)]


# command -> {(input, output): (file name the output has, argv)}
CASES: dict[str, dict[tuple[str, str], tuple[str, Case]]] = {
    "dsp-replay": {
        **{(i, o): (f"victim{sfx}", _replay(i, o))
           for i in ("log", "--ball", "--cameras", "--calibration")
           for o, sfx in (("--out", ".json"), ("--out-mcap", ".mcap"), ("--out-csv", ".csv"),
                          ("--plot", ".png"), ("--save", ".rrd"))},
        **{(i, "--out-dir"): (name, _replay_batch(i, name))
           for i in ("--ball", "--cameras", "--calibration")
           for name in ("batch-summary.json", "batch-summary.csv", "batch-summary.md",
                        "run.json")},
        ("log", "--out-dir"): ("run.json", _replay_batch("log", "run.json")),
    },
    "dsp-compare": {
        (i, o): (f"victim{sfx}", _compare(i, o))
        for i in ("a", "b", "--log")
        for o, sfx in (("--out", ".json"), ("--out-csv", ".csv"), ("--out-md", ".md"),
                       ("--plot", ".png"), ("--save", ".rrd"))
    },
    "dsp-calibrate": {
        **{(i, o): (f"victim{sfx}", _calibrate(i, o))
           for i in ("--from-measurements", "--from-log")
           for o, sfx in (("--out", ".json"), ("--plot", ".png"))},
        ("--ball-from", "--out"): ("victim.json", _calibrate("--ball-from", "--out")),
    },
    "dsp-info": {("log", "--out"): ("victim.json", _info)},
    "dsp-eval": {
        ("--check-model", "--out-dir"): ("images-summary.json", _eval_images),
        ("--ball", "--out-dir"): ("images-summary.json", _eval_images_with("--ball")),
        ("--group-by", "--out-dir"): ("images-summary.json", _eval_images_with("--group-by")),
        ("--calibration", "--out-dir"): ("paper-ideal.json", _eval_table),
    },
}
NOT_TOGETHER = {
    ("dsp-calibrate", "--ball-from", "--plot"),  # a ball model is fitted without a figure
    ("dsp-eval", "dirs", "--out-dir"),  # folders of images: no file of them is written
}
"""Pairs of a read and a written option that one run never has."""


@pytest.mark.parametrize("command", COMMANDS)
def test_every_input_and_output_pair_is_tried(command: str) -> None:
    files: FileOptions = declared_files(_module(command).build_parser())
    cases = CASES.get(command, {})
    for i in files.inputs:
        for o in files.outputs + files.output_dirs:
            assert (i, o) in cases or (command, i, o) in NOT_TOGETHER, (
                f"{command}: no test writes {o} onto {i}: add a case to CASES")


_ALL = [(command, pair, name, case) for command, cases in CASES.items()
        for pair, (name, case) in cases.items()]


@pytest.mark.parametrize("link", [False, True], ids=["same-name", "via-link"])
@pytest.mark.parametrize(("command", "pair", "name", "case"), _ALL,
                         ids=[f"{c}:{p[0]}->{p[1]}:{n}" for c, p, n, _ in _ALL])
def test_an_output_never_overwrites_an_input(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str,
        pair: tuple[str, str], name: str, case: Case, link: bool) -> None:
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    victim = out_dir / name
    victim.write_bytes(b"precious")
    as_out = victim
    if link:  # another name for the same file: a symlink beside it, read through ".."
        (tmp_path / "elsewhere").mkdir()
        (tmp_path / "elsewhere" / name).symlink_to(victim)
        as_out = tmp_path / "out" / ".." / "elsewhere" / name
    argv = case(tmp_path, victim, as_out)
    if link and pair[1] == "--out-dir":  # the folder's file reached by the input's other name
        argv = [str(as_out) if a == str(victim) else a for a in argv]
    code = _module(command).main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1 and "overwrites an input" in err, err
    assert victim.read_bytes() == b"precious"
    assert sorted(p.name for p in out_dir.iterdir()) == [name]
