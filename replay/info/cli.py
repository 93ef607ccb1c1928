"""``dsp-info``: what a log holds, and with ``--check`` whether it is intact (thin CLI).

    dsp-info run.mcap [--check] [--json]
    dsp-info run.mcap --cameras-template [-o cameras.yaml] [--image-topic P --pose-topic P]

Exit codes (:func:`dsp.cli.run_main`): 0 done (and, with ``--check``, intact); 1 a file that
cannot be read, or ``--check`` found problems; 2 usage.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from dsp.atomic import atomic_output, check_distinct, declare_files
from dsp.camera_file import CAMERA_FILE_SUFFIXES
from dsp.checks import check_suffix, check_topic_pattern
from dsp.cli import Parser, add_common_arguments, run_main
from dsp.errors import EXIT_INPUT, UsageError
from dsp.text import printable
from dsp.textfile import TEXT_ERRORS
from replay.errors import CorruptLogError, ReplayError, TruncatedLogError
from replay.info.summary import format_info, log_info
from replay.info.template import camera_template

__all__ = ["build_parser", "main"]

PROG = "dsp-info"


def build_parser() -> argparse.ArgumentParser:
    p = Parser(
        prog=PROG,
        allow_abbrev=False,
        description="Summarise an MCAP log: duration, topics with types, counts and rates, "
        "robots, scenario, cameras, renderer, chunks and compression.",
    )
    p.add_argument("log", type=Path, help="the MCAP log")
    p.add_argument("--check", action="store_true",
                   help="read every chunk: check chunk, data and summary CRCs and that the "
                   "summary agrees with the data; exit 1 on any problem")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument("--cameras-template", action="store_true",
                   help="write a starting camera file for the log (dsp-replay --cameras): from "
                   "its camera metadata, else from its images' size, the calibration to fill in")
    p.add_argument("-o", "--out", type=Path, metavar="FILE",
                   help="with --cameras-template: the file to write, .yaml, .yml or .json "
                   "(default: print it)")
    p.add_argument("--image-topic", metavar="PATTERN",
                   help="with --cameras-template: the image topic pattern, {robot} = robot "
                   "name (default: found from the log's topics)")
    p.add_argument("--pose-topic", metavar="PATTERN",
                   help="with --cameras-template: the pose topic pattern (default: found)")
    add_common_arguments(p, force=True, progress=False)
    declare_files(p, inputs=("log",), outputs=("--out",))
    return p


def _template(args: argparse.Namespace) -> int:
    if args.check or args.json:
        raise UsageError("--cameras-template goes without --check and --json")
    for flag, pattern in (("--image-topic", args.image_topic),
                          ("--pose-topic", args.pose_topic)):
        if pattern is not None:
            check_topic_pattern(flag, pattern)
    out: Path | None = check_suffix("-o/--out", args.out, CAMERA_FILE_SUFFIXES)
    if out is not None:
        check_distinct([("-o/--out", out)], [("the input log", args.log)])
        with atomic_output(out, force=args.force, label="-o/--out") as tmp:
            tmp.write_text(camera_template(args.log, out.suffix.lower(),
                                           image_topic=args.image_topic,
                                           pose_topic=args.pose_topic),
                           encoding="utf-8", errors=TEXT_ERRORS)
        print(f"wrote {printable(out)}")
        return 0
    print(camera_template(args.log, image_topic=args.image_topic, pose_topic=args.pose_topic),
          end="")
    return 0


def _main(argv: Sequence[str] | None) -> int:
    args = build_parser().parse_args(argv)
    if args.cameras_template:
        return _template(args)
    given = [f for f, v in (("-o/--out", args.out), ("--image-topic", args.image_topic),
                            ("--pose-topic", args.pose_topic)) if v is not None]
    if given:
        raise UsageError(f"{', '.join(given)} only go with --cameras-template")
    try:
        summary = log_info(args.log, check=args.check)
    except (CorruptLogError, TruncatedLogError) as err:
        text = str(err).split("; use --recover")[0]
        raise ReplayError(f"{text}; dsp-info --check lists every problem") from err
    # every name in the text is escaped already; this keeps what the log's header and chunk
    # records name (profile, compression) off the terminal too
    print(summary.to_json() if args.json else printable(format_info(summary), lines=True),
          end="\n" if not args.json else "")
    if summary.problems:
        print(f"{PROG}: error: {printable(args.log)}: {len(summary.problems)} integrity "
              "problem(s), "
              f"first: {summary.problems[0]}"
              + (f"; {summary.recoverable}" if (summary.recoverable or "").startswith(
                  "nothing") else ""), file=sys.stderr)
        return EXIT_INPUT
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    return run_main(PROG, _main, argv)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
