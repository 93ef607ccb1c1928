"""``dsp-info``: what a log holds, and with ``--check`` whether it is intact (thin CLI).

    dsp-info run.mcap [--check] [--json]

Exit codes (:func:`dsp.cli.run_main`): 0 done (and, with ``--check``, intact); 1 a file that
cannot be read, or ``--check`` found problems; 2 usage.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from dsp.cli import add_common_arguments, run_main
from dsp.errors import EXIT_INPUT
from replay.errors import CorruptLogError, ReplayError, TruncatedLogError
from replay.info.summary import format_info, log_info

__all__ = ["build_parser", "main"]

PROG = "dsp-info"


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=PROG,
        description="Summarise an MCAP log: duration, topics with types, counts and rates, "
        "robots, scenario, cameras, renderer, chunks and compression.",
    )
    p.add_argument("log", type=Path, help="the MCAP log")
    p.add_argument("--check", action="store_true",
                   help="read every chunk: check chunk, data and summary CRCs and that the "
                   "summary agrees with the data; exit 1 on any problem")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    add_common_arguments(p, progress=False)
    return p


def _main(argv: Sequence[str] | None) -> int:
    args = build_parser().parse_args(argv)
    try:
        summary = log_info(args.log, check=args.check)
    except (CorruptLogError, TruncatedLogError) as err:
        text = str(err).split("; use --recover")[0]
        raise ReplayError(f"{text}; dsp-info --check lists every problem") from err
    print(summary.to_json() if args.json else format_info(summary), end="\n" if not args.json
          else "")
    if summary.problems:
        print(f"{PROG}: error: {args.log}: {len(summary.problems)} integrity problem(s), "
              f"first: {summary.problems[0]}", file=sys.stderr)
        return EXIT_INPUT
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    return run_main(PROG, _main, argv)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
