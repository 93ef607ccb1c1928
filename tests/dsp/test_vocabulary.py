"""One vocabulary across the six commands, walked from their parsers.

A word means one thing everywhere: ``--check`` verifies (a flag), ``--seed`` seeds a scene,
``--rerun`` / ``--serve`` are flags that show a recording and ``--save`` takes an .rrd file;
every parser is :class:`dsp.cli.Parser`, so a mistake on any command line is one line and a
hint (exit 2), and ``dsp-replay --help`` fits on a screen.
"""

from __future__ import annotations

import argparse
import importlib
from collections.abc import Callable, Iterator, Sequence

import pytest

from dsp.cli import Parser

COMMANDS = {
    "dsp-record": "recorder.cli",
    "dsp-replay": "replay.cli",
    "dsp-calibrate": "recorder.calibrate_cli",
    "dsp-eval": "replay.evaluate.cli",
    "dsp-info": "replay.info.cli",
    "dsp-compare": "replay.compare.cli",
}


def _parser(prog: str) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = importlib.import_module(COMMANDS[prog]).build_parser()
    return parser


def _options(prog: str) -> Iterator[tuple[str, argparse.Action]]:
    for action in _parser(prog)._actions:
        for flag in action.option_strings:
            yield flag, action


def test_the_launchers_name_these_six_commands() -> None:
    """A seventh command would be walked here too: the table is the entry points'."""
    from pathlib import Path

    import tomllib

    project = tomllib.loads((Path(__file__).parents[2] / "pyproject.toml").read_text())
    assert set(project["project"]["scripts"]) == set(COMMANDS)


@pytest.mark.parametrize("prog", COMMANDS)
def test_every_command_parses_with_the_one_line_parser(prog: str) -> None:
    parser = _parser(prog)
    assert isinstance(parser, Parser)
    assert parser.prog == prog
    assert parser.allow_abbrev is False


@pytest.mark.parametrize("prog", COMMANDS)
def test_a_word_means_the_same_in_every_command(prog: str) -> None:
    for flag, action in _options(prog):
        if flag in ("--check", "--rerun", "--serve", "--force"):
            assert action.nargs == 0, f"{prog} {flag} takes a value; elsewhere it is a flag"
        if flag == "--save":
            assert action.metavar == "RRD", f"{prog} --save: a Rerun .rrd file everywhere"
        if flag == "--seed":
            assert action.type is int and "scen" in (action.help or ""), \
                f"{prog} --seed: the scene's seed everywhere ({action.help!r})"
        if flag in ("--bootstrap-seed",):
            assert prog == "dsp-compare"


@pytest.mark.parametrize("prog", COMMANDS)
def test_a_parser_error_is_one_line_and_a_hint(prog: str,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    main: Callable[[Sequence[str] | None], int] = importlib.import_module(COMMANDS[prog]).main
    assert main(["--no-such-option"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2, err
    assert err[0].startswith(f"{prog}: error: ")
    assert err[1] == f"Try '{prog} --help' for the options."



@pytest.mark.parametrize("prog", COMMANDS)
def test_a_misspelt_option_gets_the_closest_one(prog: str,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_:
        _parser(prog).error("unrecognized arguments: --versoin")
    assert exit_.value.code == 2
    assert capsys.readouterr().err.splitlines()[0] == (
        f"{prog}: error: unrecognized arguments: --versoin (did you mean --version?)")


def test_a_misspelt_option_on_a_command_line(capsys: pytest.CaptureFixture[str]) -> None:
    from replay.cli import main

    assert main(["in.mcap", "--pose-sigmaa", "0.1"]) == 2
    assert capsys.readouterr().err.splitlines()[0] == (
        "dsp-replay: error: unrecognized arguments: --pose-sigmaa 0.1 (did you mean "
        "--pose-sigma?)")
    assert main(["in.mcap", "--pose-sigmaa=0.1", "--outt", "r.json", "--zzzz"]) == 2
    assert capsys.readouterr().err.splitlines()[0].endswith(
        "--zzzz (did you mean --pose-sigma or --out?)")
    assert main(["in.mcap", "--zzzz"]) == 2  # nothing close: no guess
    assert capsys.readouterr().err.splitlines()[0].endswith("arguments: --zzzz")


def test_replay_help_shows_the_essentials_in_40_lines(
        capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    from replay.cli import main

    monkeypatch.setenv("COLUMNS", "80")
    assert main(["--help"]) == 0
    short = capsys.readouterr().out
    assert len(short.splitlines()) <= 40
    assert "--profile" in short and "--out-dir" in short and "--help-all" in short
    assert "--localise" not in short and "--fusion" not in short
    assert main(["--help-all"]) == 0
    full = capsys.readouterr().out
    assert "--localise" in full and "--fusion" in full and "researchers' switches" in full


def test_researchers_switches_parse_under_the_short_help() -> None:
    """--help hides them; the command line takes them all the same."""
    from replay.cli import build_parser

    args = build_parser(all_options=False).parse_intermixed_args(
        ["run.mcap", "--fusion", "mean", "--localise", "lines", "--no-hops"])
    assert (args.fusion, args.localise, args.hops) == ("mean", "lines", False)


def test_out_mcap_never_swallows_the_log() -> None:
    from replay.cli import build_parser

    args = build_parser().parse_intermixed_args(["--out-mcap", "est.mcap", "run.mcap"])
    assert [str(p) for p in args.log] == ["run.mcap"]
    assert str(args.out_mcap) == "est.mcap"


def test_rerun_and_save_go_together() -> None:
    from replay.cli import build_parser, options_from_args

    opts = options_from_args(build_parser().parse_intermixed_args(
        ["run.mcap", "--rerun", "--save", "run.rrd"]))
    assert opts.rerun is not None and opts.rerun.mode == "spawn"
    assert str(opts.save_path) == "run.rrd"
    assert ("--save", opts.save_path) in opts.output_flags()
