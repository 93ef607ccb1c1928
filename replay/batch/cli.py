"""``dsp-replay``'s batch mode (``--out-dir``): the arguments and the thin command.

    dsp-replay LOG|FOLDER [LOG|FOLDER ...] --out-dir DIR [--out-mcap] [--workers N | --ray]

:func:`is_batch` tells the two modes apart; :func:`run_batch` checks the combination of
flags, calls :func:`replay.batch.run.replay_batch`, prints the summary table and exits 1 when a
log failed (after all the others were replayed and the summary written).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

from dsp.cli import echo, progress_enabled
from dsp.errors import InputError, UsageError
from dsp.text import printable
from replay.batch.run import SUMMARY_STEM, replay_batch, summary_paths
from replay.options import ReplayOptions
from replay.parallel.cli import add_worker_arguments, workers_from_args

__all__ = ["add_batch_arguments", "check_single", "is_batch", "run_batch"]

def add_batch_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("many logs")
    g.add_argument("--out-dir", type=Path, metavar="DIR",
                   help=f"replay each LOG (a FOLDER's *.mcap) into DIR, and {SUMMARY_STEM}")
    g.add_argument("--estimates", action="store_true",
                   help="with --out-dir: also each log's estimates as DIR/<stem>.estimates.mcap")
    add_worker_arguments(g, what="the logs of a batch (--out-dir)")


def is_batch(args: argparse.Namespace) -> bool:
    return args.out_dir is not None or len(args.log) > 1


def check_single(args: argparse.Namespace) -> None:
    """Refuse batch-only flags in a single replay."""
    if args.workers is not None or args.ray:
        raise UsageError("--workers and --ray replay a batch: give --out-dir DIR")
    if args.estimates:
        raise UsageError("--estimates writes each log's estimates in a batch: give "
                         "--out-dir DIR (one log: --out-mcap FILE)")


def _check(args: argparse.Namespace) -> None:
    if args.out_dir is None:
        raise UsageError(f"{len(args.log)} logs: give --out-dir DIR for their outputs")
    if args.out is not None:
        raise UsageError("--out names one file; with --out-dir each log's results go to "
                         "DIR/<stem>.json")
    if args.out_mcap is not None:
        raise UsageError("--out-mcap names one file; with --out-dir, --estimates writes "
                         "each log's to DIR/<stem>.estimates.mcap")
    if args.out_csv is not None or args.plot is not None:
        raise UsageError("--out-csv and --plot name one file: leave them out of a batch")
    if args.rerun or args.save is not None or args.connect is not None or args.serve:
        raise UsageError("--rerun, --save, --connect and --serve show one log: leave them "
                         "out of a batch")


def run_batch(args: argparse.Namespace,
              options_from_args: Callable[[argparse.Namespace], ReplayOptions]) -> int:
    """The batch command: 0 when every log replayed; else :class:`InputError` (exit 1)."""
    _check(args)
    estimates_mcap = args.estimates
    workers = workers_from_args(args)
    summary = replay_batch(args.log, args.out_dir, options_from_args(args),
                           estimates_mcap=estimates_mcap, workers=workers,
                           progress=progress_enabled(args))
    echo(args, summary.to_markdown().rstrip("\n"))
    echo(args, "wrote " + ", ".join(str(p) for p in summary_paths(args.out_dir))
         + f" and {len(summary.rows) - len(summary.failed)} logs' results")
    for row in summary.failed:
        print(printable(f"dsp-replay: error: {row.error}"), file=sys.stderr)
    if summary.failed:
        raise InputError(f"{len(summary.failed)} of {len(summary.rows)} logs failed "
                         f"(see {summary_paths(args.out_dir)[2]})")
    return 0
