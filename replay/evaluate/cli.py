"""``dsp-eval``: the paper's experiment end to end (record, replay, score) (thin CLI).

    dsp-eval [--camera ideal] [--calibration calib.json] [--out-dir eval/]
    dsp-eval --suite random --count 200 --seed 1 [--workers N | --ray]
    dsp-eval --suite match --count 20 [--workers N | --ray]

Prints Table 1 (the paper's beside ours) or the random-scene statistics, and writes them
as Markdown and JSON into --out-dir, beside the recorded logs (which are reused when the
same command runs again; the tables are rewritten each run). Scenes (record + replay under
every configuration) run in a local process pool (``--workers``, default every core) or as
Ray tasks (``--ray``); the tables are the same bytes whatever the worker count.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

from dsp.atomic import atomic_output, check_distinct
from dsp.checks import check_int, check_number
from dsp.cli import add_common_arguments, echo, progress_enabled, run_main
from dsp.errors import UsageError
from dsp.jsonio import Json
from dsp.jsonio import dumps as strict_json
from dsp.progress import Progress, progress_bar
from replay.cameras import read_calibration
from replay.evaluate.match import (
    MatchLogScore,
    MatchOptions,
    MatchTask,
    match_markdown,
    run_match_suite,
)
from replay.evaluate.scenes import SceneMapper, SceneTask
from replay.evaluate.suites import (
    PAPER_SCENARIOS,
    paper_markdown,
    random_markdown,
    run_paper_suite,
    run_random_suite,
)
from replay.parallel import Outcome, Workers, map_tasks
from replay.parallel.cli import add_worker_arguments, workers_from_args

__all__ = ["SimRecorder", "build_parser", "main"]

S = TypeVar("S")

PROG = "dsp-eval"
MAX_COUNT = 100_000
MAX_SEED = 2**63 - 1 - MAX_COUNT
"""Scene seeds run from --seed to --seed + --count - 1: all within 64 bits."""


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=PROG,
        allow_abbrev=False,
        description="Record the paper's four scenarios (or N random scenes), replay them with "
        "paper mode and the corrected estimator under each fusion method, and score them.",
    )
    p.add_argument("--suite", choices=("paper", "random", "match"), default="paper",
                   help="the paper's four scenarios (default), random scenes or seeded "
                   "matches (the tracker against window fusion)")
    p.add_argument("--count", type=int, default=None,
                   help="random scenes (default 200) or matches (default 20)")
    p.add_argument("--seed", type=int, default=0, help="seed of the first scene (default 0)")
    p.add_argument("--calibration", type=Path, metavar="FILE",
                   help="calibration from dsp-calibrate for the corrected estimator "
                   "(default: the camera model in the log's metadata)")
    p.add_argument("--out-dir", type=Path, default=Path("eval"), metavar="DIR",
                   help="logs and tables go here (default ./eval)")
    _add_match_arguments(p)
    add_worker_arguments(p, what="the scenes (record + replay)")
    add_common_arguments(p, camera="ideal", renderer=True)
    return p


def _add_match_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("--suite match")
    g.add_argument("--sync-count", type=int, metavar="N",
                   help="record the first N matches again with synchronised cameras "
                   "(default: all)")
    g.add_argument("--duration", type=float, default=10.0, metavar="S",
                   help="sim seconds per match (default %(default)s)")
    g.add_argument("--rate", type=float, metavar="HZ",
                   help="camera frames per second per robot (default: the scenario's, 20)")
    g.add_argument("--face-px", type=int, metavar="PX",
                   help="render resolution (default: the recorder's, 1024)")
    g.add_argument("--distractors", type=int, default=3, metavar="N",
                   help="orange boxes beside the field per match (default %(default)s)")


@dataclass(frozen=True)
class SimRecorder:
    """Records one scene with pybullet (a class, so a scene task pickles to other processes)."""

    camera: str
    renderer: str

    def __call__(self, path: Path, scenario: str, seed: int) -> None:
        from recorder.record import RecordOptions, record  # lazy: replay alone needs no pybullet

        record(path, RecordOptions(scenario=scenario, seed=seed, camera=self.camera,
                                   renderer=self.renderer))


def _check(args: argparse.Namespace) -> None:
    """Refuse bad options and a bad calibration before recording anything."""
    if args.count is None:
        args.count = 20 if args.suite == "match" else 200
    check_int("--count", args.count, low=1, high=MAX_COUNT)
    check_int("--seed", args.seed, low=0, high=MAX_SEED)
    check_int("--sync-count", args.sync_count, low=0, high=MAX_COUNT)
    check_number("--duration", args.duration, low=0, high=3600, low_open=True, unit="s")
    if args.out_dir.exists() and not args.out_dir.is_dir():
        raise UsageError(f"--out-dir {args.out_dir}: is not a folder")
    if args.calibration is not None:  # a bad file would otherwise only show at the first replay
        read_calibration(args.calibration)


@dataclass(frozen=True)
class _SceneMapper:
    """map_scenes for the suites: scenes on ``workers``, the bar counting finished scenes;
    the first scene that fails stops the others and is raised."""

    workers: Workers
    bar: Progress

    def _done(self, i: int, outcome: Outcome[S]) -> None:
        self.bar.update(1)

    def __call__(self, fn: Callable[[SceneTask[S]], S],
                 tasks: Sequence[SceneTask[S]]) -> list[S]:
        outcomes = map_tasks(fn, tasks, self.workers, on_done=self._done, fail_fast=True)
        return [o.unwrap() for o in outcomes]


def _scene_mapper(workers: Workers, bar: Progress) -> SceneMapper:
    """map_scenes for the suites (:class:`_SceneMapper`)."""
    return _SceneMapper(workers, bar)


def _run_suite(args: argparse.Namespace,
               workers: Workers) -> tuple[str, str, dict[str, Json]]:
    """Run the chosen suite; return the file stem, the Markdown table and the JSON doc."""
    if args.suite == "match":
        return _run_match_suite(args, workers)
    record = SimRecorder(args.camera, args.renderer)
    stem = _stem(args)
    scenes = len(PAPER_SCENARIOS) if args.suite == "paper" else args.count
    with progress_bar(scenes, PROG, progress_enabled(args), unit="scene") as bar:
        map_scenes = _scene_mapper(workers, bar)
        if args.suite == "paper":
            suite = run_paper_suite(record, args.out_dir, camera=args.camera,
                                    calibration=args.calibration, seed=args.seed,
                                    map_scenes=map_scenes)
            return stem, paper_markdown(suite), suite.to_dict()
        rsuite = run_random_suite(record, args.out_dir, camera=args.camera, count=args.count,
                                  seed=args.seed, calibration=args.calibration,
                                  map_scenes=map_scenes)
    return stem, random_markdown(rsuite), rsuite.to_dict()


def _stem(args: argparse.Namespace) -> str:
    """The tables' file stem in --out-dir."""
    stem = f"{args.suite}-{args.camera}"
    return stem if args.suite == "paper" else f"{stem}-{args.count}-seed{args.seed}"


def _run_match_suite(args: argparse.Namespace,
                     workers: Workers) -> tuple[str, str, dict[str, Json]]:
    options = MatchOptions(camera=args.camera, duration_s=args.duration, rate_hz=args.rate,
                           face_px=args.face_px, distractors=args.distractors,
                           renderer=args.renderer, calibration=args.calibration)
    sync = args.count if args.sync_count is None else min(args.sync_count, args.count)
    with progress_bar(args.count + sync, PROG, progress_enabled(args), unit="log") as bar:

        def done(i: int, outcome: Outcome[MatchLogScore]) -> None:
            bar.update(1)

        def map_logs(fn: Callable[[MatchTask], MatchLogScore],
                     tasks: Sequence[MatchTask]) -> list[MatchLogScore]:
            outcomes = map_tasks(fn, tasks, workers, on_done=done, fail_fast=True)
            return [o.unwrap() for o in outcomes]

        suite = run_match_suite(args.out_dir, options, count=args.count, seed=args.seed,
                                sync_count=sync, map_tasks=map_logs)
    return _stem(args), match_markdown(suite), suite.to_dict()


def _main(argv: Sequence[str] | None) -> int:
    args = build_parser().parse_args(argv)
    out_dir: Path = args.out_dir
    t0 = time.perf_counter()
    _check(args)
    md, js = out_dir / f"{_stem(args)}.md", out_dir / f"{_stem(args)}.json"
    check_distinct([("the table", md), ("the table", js)],
                   [("the --calibration file", args.calibration)])
    workers = workers_from_args(args)
    out_dir.mkdir(parents=True, exist_ok=True)
    _, text, doc = _run_suite(args, workers)
    with atomic_output(md, force=True) as tmp:  # tables are rewritten on every run
        tmp.write_text(text, encoding="utf-8")
    with atomic_output(js, force=True) as tmp:
        tmp.write_text(strict_json(doc, sort_keys=True, indent=2) + "\n", encoding="utf-8")
    echo(args, text)
    echo(args, f"wrote {md} and .json in {time.perf_counter() - t0:.0f} s")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    return run_main(PROG, _main, argv)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
