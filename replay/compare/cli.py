"""``dsp-compare``: did B do better than A on the same logs, by more than noise? (thin CLI)

    dsp-compare A B [--out cmp.json] [--out-csv cmp.csv] [--out-md cmp.md] [--plot cmp.png]
                    [--replicates N] [--bootstrap-seed N] [--allow-different-logs] [--fail-if-worse]

A and B: results files (``dsp-replay --out``) or folders of them (``--out-dir``). Prints the
Markdown report; exit 0, or 1 with ``--fail-if-worse`` when a total is worse in B.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from dsp.atomic import atomic_output, check_distinct, check_output_path, declare_files
from dsp.checks import check_int, check_rrd, check_suffix
from dsp.cli import Parser, add_common_arguments, echo, run_main
from dsp.errors import InputError, UsageError
from dsp.plotting import FIGURE_SUFFIXES
from dsp.textfile import TEXT_ERRORS
from replay.compare import DEFAULT_REPLICATES, Report, compare

__all__ = ["build_parser", "main"]

PROG = "dsp-compare"


def build_parser() -> argparse.ArgumentParser:
    p = Parser(
        allow_abbrev=False,
        prog=PROG, description="Compare two replays of the same logs: per log and in total, "
        "fused RMSE, p95, detection rate and velocity error of A, B and B - A, with a paired "
        "bootstrap 95% interval and a verdict per metric (docs/compare.md).")
    p.add_argument("a", type=Path, metavar="A", help="results file or folder of run A")
    p.add_argument("b", type=Path, metavar="B", help="results file or folder of run B")
    p.add_argument("--out", type=Path, metavar="FILE.json", help="the report as JSON")
    p.add_argument("--out-csv", type=Path, metavar="FILE.csv", help="one row per log and metric")
    p.add_argument("--out-md", type=Path, metavar="FILE.md", help="the report as Markdown")
    p.add_argument("--plot", type=Path, metavar="FILE.png",
                   help="the paired per-log differences with their intervals (.png or .svg)")
    p.add_argument("--replicates", type=int, default=DEFAULT_REPLICATES, metavar="N",
                   help="bootstrap replicates (default %(default)s; more are allowed while the "
                   "work stays within minutes)")
    p.add_argument("--bootstrap-seed", type=int, default=0, metavar="N",
                   help="the bootstrap's random seed (default 0)")
    p.add_argument("--allow-different-logs", action="store_true",
                   help="compare results of different logs (paired by the log's file name)")
    p.add_argument("--fail-if-worse", action="store_true",
                   help="exit 1 when B is worse than A in a total (for CI)")
    p.add_argument("--log", type=Path, metavar="LOG",
                   help="replay LOG as A and as B into one Rerun recording, side by side "
                   "(with --rerun or --save)")
    p.add_argument("--rerun", action="store_true",
                   help="with --log: spawn a Rerun viewer (as dsp-replay --rerun)")
    p.add_argument("--save", type=Path, metavar="RRD",
                   help="with --log: save the side-by-side recording as a .rrd file")
    add_common_arguments(p, force=True, progress=False)
    p.add_argument("-q", "--quiet", action="store_true", help="print no report")
    declare_files(p, inputs=("a", "b", "--log"),
                  outputs=("--out", "--out-csv", "--out-md", "--plot", "--save"))
    return p


def _outputs(args: argparse.Namespace) -> list[tuple[str, Path | None]]:
    check_suffix("--out", args.out, (".json",))
    check_suffix("--out-csv", args.out_csv, (".csv",))
    check_suffix("--out-md", args.out_md, (".md",))
    check_suffix("--plot", args.plot, FIGURE_SUFFIXES)
    check_rrd("--save", args.save)
    if (args.save is not None or args.rerun) and args.log is None:
        raise UsageError("--rerun and --save show a log's two replays: give --log LOG")
    if args.log is not None and args.save is None and not args.rerun:
        raise UsageError("--log LOG is shown side by side: give --rerun (a viewer) or "
                         "--save FILE.rrd")
    if args.save is not None and args.rerun:
        raise UsageError("--rerun and --save: give one (the side-by-side recording goes to "
                         "a viewer or to a file)")
    outs = [("--out", args.out), ("--out-csv", args.out_csv), ("--out-md", args.out_md),
            ("--plot", args.plot), ("--save", args.save)]
    inputs: list[tuple[str, Path | None]] = [("the input A", args.a), ("the input B", args.b),
                                             ("the --log log", args.log)]
    for name, run in (("A", args.a), ("B", args.b)):  # a folder's results files are read too
        if run.is_dir():
            inputs += [(f"a results file of run {name}", p) for p in sorted(run.glob("*.json"))]
    check_distinct(outs, inputs)
    for flag, path in outs:
        if path is not None:
            check_output_path(path, force=args.force, label=flag)
    return outs


def _main(argv: Sequence[str] | None) -> int:
    args = build_parser().parse_args(argv)
    check_int("--replicates", args.replicates, low=1, high=1_000_000)
    check_int("--bootstrap-seed", args.bootstrap_seed, low=0, high=2**63 - 1)
    outs = dict(_outputs(args))
    report = compare(args.a, args.b, replicates=args.replicates, seed=args.bootstrap_seed,
                     allow_different_logs=args.allow_different_logs)
    for flag, text in (("--out", report.to_json()), ("--out-csv", report.to_csv()),
                       ("--out-md", report.to_markdown())):
        path = outs[flag]
        if path is not None:
            with atomic_output(path, force=args.force, label=flag) as tmp:
                tmp.write_text(text, encoding="utf-8", errors=TEXT_ERRORS)
    if args.plot is not None:
        from replay.compare.figure import draw

        with atomic_output(args.plot, force=args.force, label="--plot") as tmp:
            draw(report, tmp, args.plot.suffix.lower().lstrip("."))
    echo(args, report.to_markdown().rstrip("\n"))
    if args.log is not None:
        _rerun(args, report)
    if args.fail_if_worse and report.worse:
        print(f"{PROG}: B is worse than A in total: {', '.join(report.worse)}", file=sys.stderr)
        return 1
    return 0


def _rerun(args: argparse.Namespace, report: Report) -> None:
    from replay.compare.side_by_side import side_by_side
    from replay.runner import file_digest

    if not args.log.is_file():
        raise InputError(f"{args.log}: no such log")
    digest = file_digest(args.log)
    pair = next((p for p in report.pairs if digest in (p.a.sha256, p.b.sha256)), None)
    if pair is None:
        raise InputError(f"{args.log}: neither run holds results of this log")
    side_by_side(args.log, pair.a, pair.b, save=args.save, force=args.force)
    if args.save is not None:
        echo(args, f"wrote {args.save}: A under /A, B under /B")


def main(argv: Sequence[str] | None = None) -> int:
    return run_main(PROG, _main, argv)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
