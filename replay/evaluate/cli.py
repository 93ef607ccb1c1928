"""``dsp-eval``: the paper's experiment end to end (record, replay, score) (thin CLI).

    dsp-eval [--camera ideal] [--calibration calib.json] [--out-dir eval/]
    dsp-eval --suite random --count 200 --seed 1 [--workers N | --ray]
    dsp-eval --suite match --count 20 [--workers N | --ray]
    dsp-eval --suite match --camera mirror --realism field --localise lines
    dsp-eval --suite images DIR [DIR ...] --train-count 10 --out-dir OUT
    dsp-eval --suite lobs --count 3 --seed 100     # balls in the air, free-running cameras
    dsp-eval --suite lobs --camera-phase sync      # the same in sync, triangulated
    dsp-eval --suite foreign [--foreign-set report|tune|check]   # logs drawn without the recorder

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

from dsp.atomic import atomic_output, check_distinct, declare_files
from dsp.ball_file import read_ball_file, read_check_file, shipped_check, shipped_generic
from dsp.checks import (
    MAX_DISTRACTORS,
    MAX_FACE_PX,
    MAX_RATE_HZ,
    MIN_FACE_PX,
    MIN_RATE_HZ,
    check_int,
    check_number,
)
from dsp.cli import Parser, add_common_arguments, echo, progress_enabled, run_main
from dsp.errors import UsageError
from dsp.image_groups import read_grouping
from dsp.jsonio import Json
from dsp.jsonio import dumps as strict_json
from dsp.progress import Progress, progress_bar
from dsp.realism import REALISM, realism_preset
from dsp.textfile import TEXT_ERRORS
from replay.cameras import read_calibration
from replay.evaluate.foreign_suite import (
    add_foreign_arguments,
    foreign_stem,
    run_foreign_from_args,
)
from replay.evaluate.images import images_csv, images_markdown, run_images_suite
from replay.evaluate.lobs import (
    CAMERA_PHASES,
    LobsOptions,
    lobs_rates,
    lobs_sets_doc,
    lobs_sets_markdown,
    run_lobs_suite,
)
from replay.evaluate.match import (
    MatchLogScore,
    MatchOptions,
    MatchTask,
    match_markdown,
    run_match_suite,
)
from replay.evaluate.scenes import SceneMapper, SceneTask, configs_for
from replay.evaluate.suites import (
    PAPER_SCENARIOS,
    paper_markdown,
    random_markdown,
    run_paper_suite,
    run_random_suite,
)
from replay.options import LOCALISE_MODES
from replay.parallel import Outcome, Workers, map_tasks
from replay.parallel.cli import add_worker_arguments, workers_from_args
from replay.real_ball import DETECTORS

__all__ = ["SimRecorder", "build_parser", "main"]

S = TypeVar("S")

PROG = "dsp-eval"
IMAGES_OUTPUTS = ("images-summary.json", "images-summary.md", "images.csv")
"""What ``--suite images`` writes into ``--out-dir``."""
MAX_COUNT = 100_000
MAX_SEED = 2**63 - 1 - MAX_COUNT
"""Scene seeds run from --seed to --seed + --count - 1: all within 64 bits."""


def build_parser() -> argparse.ArgumentParser:
    p = Parser(
        prog=PROG,
        allow_abbrev=False,
        description="Record the paper's four scenarios (or N random scenes), replay them with "
        "paper mode and the corrected estimator under each fusion method, and score them.",
    )
    p.add_argument("--suite", choices=("paper", "random", "match", "lobs", "images", "foreign"),
                   default="paper",
                   help="the paper's four scenarios (default), random scenes, seeded "
                   "matches (the tracker against window fusion), lobs (3-D, triangulated), "
                   "the ball detector on folders of labelled real images (DIR ...), or the "
                   "default pipeline on logs drawn without the recorder (foreign)")
    p.add_argument("--count", type=int, default=None,
                   help="random scenes (default 200), matches (default 20) or lobs scenes "
                   "(default 3)")
    p.add_argument("--seed", type=int, default=0, help="seed of the first scene (default 0)")
    p.add_argument("--calibration", type=Path, metavar="FILE",
                   help="calibration from dsp-calibrate for the corrected estimator "
                   "(default: the camera model in the log's metadata)")
    p.add_argument("--out-dir", type=Path, default=Path("eval"), metavar="DIR",
                   help="logs and tables go here (default ./eval)")
    _add_match_arguments(p)
    _add_images_arguments(p)
    add_foreign_arguments(p)
    add_worker_arguments(p, what="the scenes (record + replay)")
    add_common_arguments(p, camera="ideal", renderer=True)
    declare_files(p, inputs=("--calibration", "dirs", "--check-model", "--ball", "--group-by"),
                  output_dirs=("--out-dir",), names=("folder", "day"))
    return p


def _add_match_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("--suite match, --suite lobs")
    g.add_argument("--sync-count", type=int, metavar="N",
                   help="record the first N matches again with synchronised cameras "
                   "(default: all)")
    g.add_argument("--duration", type=float, default=None, metavar="S",
                   help="sim seconds per match (default 10) or lobs scene (default 4)")
    g.add_argument("--rate", type=float, metavar="HZ",
                   help="camera frames per second per robot (default: the scenario's, 20; "
                   "lobs: a set of logs at 20 and one at 40 free-running, 10 in sync)")
    g.add_argument("--face-px", type=int, metavar="PX",
                   help="render resolution (default: the recorder's, 1024)")
    g.add_argument("--camera-phase", choices=CAMERA_PHASES, default=None,
                   help="lobs: record the scenes free-running (random, the default: each "
                   "robot's camera at its own seeded phase, as in a match; the ballistic "
                   "fusion is scored at the steps two robots saw within 0.1 s) or with the "
                   "cameras in sync (rays of one instant, triangulated). The match suite "
                   "records both (--sync-count)")
    g.add_argument("--distractors", type=int, default=3, metavar="N",
                   help="orange boxes beside the field per match (default %(default)s)")
    p.add_argument("--realism", choices=REALISM, default="none",
                   help="record every scene with this preset of localisation error and "
                   "camera effects (dsp-record --realism; field: a real field's); the logs "
                   "and tables are named after it (default none: exact poses, ideal images)")
    p.add_argument("--localise", choices=LOCALISE_MODES, default="none",
                   help="lines: replay every scene also with each frame's pose corrected "
                   "from the field lines in its image (dsp-replay --localise lines), scored "
                   "beside the believed poses (rows '+ lines'); ball: the tracker's rows "
                   "also with each robot's bias learned from the ball (dsp-replay --localise "
                   "ball; rows '+ ball'); paper, random and match suites (default none)")
    p.add_argument("--hops", action="store_true",
                   help="match suite: replay the tracker's rows with dsp-replay --hops (its "
                   "position from a 3-D track beside it while the ball hops after kicks)")
    p.add_argument("--width-range", action="store_true",
                   help="lobs suite: every replay with dsp-replay --width-range (a blob wider "
                   "than a ball on the ground at its range is a ball in the air, placed under "
                   "itself); the tables are named after it")
    p.add_argument("--pose-uncertainty", action="store_true",
                   help="every replay weighs each robot by its own pose's covariance "
                   "(dsp-replay --pose-uncertainty); the tables are named after it")


def _add_images_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("--suite images")
    g.add_argument("dirs", nargs="*", type=Path, metavar="DIR",
                   help="folders of images with YOLO labels; each folder under them that holds "
                   "labelled images is fitted and scored apart")
    g.add_argument("--train-count", type=int, default=10, metavar="N",
                   help="fit on each folder's first N labelled images by name, score the rest "
                   "(default %(default)s; 0: fit nothing, score every image with the generic "
                   "ball model, as at a venue with no labelled frame)")
    g.add_argument("--group-by", default="folder", metavar="folder|day|FILE",
                   help="fit and score each folder apart (default), each day (a folder's "
                   "first path part) or each group of a grouping file (lines of NAME "
                   "PATTERN ...; train/msl-events.txt groups the shared set by event)")
    g.add_argument("--only", action="append", default=[], metavar="GROUP",
                   help="score this folder or group alone (repeatable), e.g. an event held "
                   "out of the check given")
    g.add_argument("--ball", type=Path, metavar="BALL.json",
                   help="with --train-count 0: the ball model to score with (default: the "
                   "shipped generic one, dsp-calibrate --ball-generic)")
    g.add_argument("--train-from", type=int, default=0, metavar="K",
                   help="fit on the N labelled images from the K-th on (counted from 0) "
                   "instead, score every other one (default 0: the first N)")
    g.add_argument("--ball-class", type=int, default=0, metavar="N",
                   help="the labels' class of the ball (default 0)")
    g.add_argument("--detector", choices=DETECTORS, default="real",
                   help="the real-ball detector (default) or the paper's chain")
    g.add_argument("--check-model", type=Path, metavar="ONNX", dest="check",
                   help="the learned check to use (default: the shipped one; train/train.py "
                   "makes others, e.g. one that never saw the venue)")
    g.add_argument("--no-head", action="store_true", help="fit no venue head")
    g.add_argument("--threshold", type=float, metavar="P",
                   help="report the best candidate from P(ball) = P (default: the fitted "
                   "model's, 0.731 with a venue head, 0.5 without)")


@dataclass(frozen=True)
class SimRecorder:
    """Records one scene with pybullet (a class, so a scene task pickles to other processes)."""

    camera: str
    renderer: str
    realism: str = "none"

    def __call__(self, path: Path, scenario: str, seed: int) -> None:
        from recorder.record import RecordOptions, record  # lazy: replay alone needs no pybullet

        record(path, RecordOptions(scenario=scenario, seed=seed, camera=self.camera,
                                   renderer=self.renderer).with_realism(
            realism_preset(self.realism).for_scenario(scenario)))


def _check(args: argparse.Namespace) -> None:
    """Refuse bad options and a bad calibration before recording anything."""
    if args.count is None:
        args.count = {"match": 20, "lobs": 3}.get(args.suite, 200)
    if args.duration is None:
        args.duration = 4.0 if args.suite == "lobs" else 10.0
    if args.realism != "none" and args.suite in ("lobs", "images"):
        raise UsageError(f"--realism records its scenes with a field's errors; --suite "
                         f"{args.suite} does not take it")
    _check_poses(args)
    if args.camera_phase is not None and args.suite != "lobs":
        raise UsageError(f"--camera-phase goes with --suite lobs (the match suite records "
                         f"both phases, see --sync-count); --suite {args.suite} does not take it")
    check_int("--count", args.count, low=1, high=MAX_COUNT)
    check_int("--seed", args.seed, low=0, high=MAX_SEED)
    check_int("--sync-count", args.sync_count, low=0, high=MAX_COUNT)
    check_number("--duration", args.duration, low=0, high=3600, low_open=True, unit="s")
    # the recorder's own ranges, checked here so a suite refuses them before its folder
    check_number("--rate", args.rate, low=MIN_RATE_HZ, high=MAX_RATE_HZ, unit="Hz")
    check_int("--face-px", args.face_px, low=MIN_FACE_PX, high=MAX_FACE_PX)
    check_int("--distractors", args.distractors, low=0, high=MAX_DISTRACTORS)
    if args.out_dir.exists() and not args.out_dir.is_dir():
        raise UsageError(f"--out-dir {args.out_dir}: is not a folder")
    if args.calibration is not None:  # a bad file would otherwise only show at the first replay
        read_calibration(args.calibration)


def _check_poses(args: argparse.Namespace) -> None:
    """--localise and --pose-uncertainty replay logs: the lobs and images suites refuse them;
    --hops goes with the match suite, --width-range with the lobs suite."""
    if (args.localise != "none" or args.pose_uncertainty) and args.suite in ("lobs", "images"):
        raise UsageError(f"--localise and --pose-uncertainty go with the paper, random and "
                         f"match suites; --suite {args.suite} does not take them")
    if args.width_range and args.suite != "lobs":
        raise UsageError(f"--width-range goes with --suite lobs, not {args.suite} (in play, "
                         f"boxes of the ball's colour become balls in the air: docs/hops.md)")
    if args.hops and args.suite != "match":
        raise UsageError(f"--hops follows the ball's hops after kicks in play: it goes with "
                         f"--suite match, not {args.suite}")


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
    if args.suite == "foreign":
        return run_foreign_from_args(args, workers, progress=progress_enabled(args))
    if args.suite == "lobs":
        phase = args.camera_phase or "random"
        sets = [run_lobs_suite(args.out_dir, LobsOptions(
            camera=args.camera, duration_s=args.duration, rate_hz=rate,
            renderer=args.renderer, calibration=args.calibration, camera_phase=phase,
            width_range=args.width_range), count=args.count, seed=args.seed)
            for rate in lobs_rates(phase, args.rate)]
        return _stem(args), lobs_sets_markdown(sets), lobs_sets_doc(sets)
    record = SimRecorder(args.camera, args.renderer, args.realism)
    stem = _stem(args)
    _log_dir(args).mkdir(parents=True, exist_ok=True)
    scenes = len(PAPER_SCENARIOS) if args.suite == "paper" else args.count
    with progress_bar(scenes, PROG, progress_enabled(args), unit="scene") as bar:
        map_scenes = _scene_mapper(workers, bar)
        if args.suite == "paper":
            suite = run_paper_suite(record, _log_dir(args), camera=args.camera,
                                    calibration=args.calibration, seed=args.seed,
                                    configs=configs_for(args.localise), map_scenes=map_scenes,
                                    pose_uncertainty=args.pose_uncertainty)
            return stem, paper_markdown(suite), suite.to_dict()
        rsuite = run_random_suite(record, _log_dir(args), camera=args.camera, count=args.count,
                                  seed=args.seed, calibration=args.calibration,
                                  configs=configs_for(args.localise), map_scenes=map_scenes,
                                  pose_uncertainty=args.pose_uncertainty)
    return stem, random_markdown(rsuite), rsuite.to_dict()


def _stem(args: argparse.Namespace) -> str:
    """The tables' file stem in --out-dir."""
    if args.suite == "foreign":
        return foreign_stem(args)
    stem = f"{args.suite}-{args.camera}"
    if args.realism != "none":
        stem += f"-{args.realism}"
    if args.localise != "none":
        stem += f"-{args.localise}"
    if args.pose_uncertainty:
        stem += "-posecov"
    if args.hops:
        stem += "-hops"
    if args.width_range:
        stem += "-width"
    phase = args.camera_phase or ("random" if args.suite == "lobs" else None)
    if phase not in (None, "sync"):
        stem += f"-{phase}"
    return stem if args.suite == "paper" else f"{stem}-{args.count}-seed{args.seed}"


def _log_dir(args: argparse.Namespace) -> Path:
    """Where the paper and random suites' logs go: --out-dir, or a folder of it named after
    the --realism preset (their log names do not say it, and a log is reused by name)."""
    out: Path = args.out_dir
    return out if args.realism == "none" else out / f"realism-{args.realism}"


def _run_match_suite(args: argparse.Namespace,
                     workers: Workers) -> tuple[str, str, dict[str, Json]]:
    options = MatchOptions(camera=args.camera, duration_s=args.duration, rate_hz=args.rate,
                           face_px=args.face_px, distractors=args.distractors,
                           renderer=args.renderer, calibration=args.calibration,
                           realism=args.realism, localise=args.localise,
                           pose_uncertainty=args.pose_uncertainty, hops=args.hops)
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


def _run_images(args: argparse.Namespace) -> int:
    out_dir: Path = args.out_dir
    if not args.dirs:
        raise UsageError("--suite images needs one or more folders of labelled images (DIR)")
    check_int("--train-count", args.train_count, low=0, high=MAX_COUNT)
    check_int("--train-from", args.train_from, low=0, high=MAX_COUNT)
    check_int("--ball-class", args.ball_class, low=0, high=MAX_COUNT)
    if args.train_count == 0 and (args.train_from or args.no_head):
        raise UsageError("--train-count 0 fits nothing: --train-from and --no-head do not "
                         "go with it")
    if args.ball is not None and args.train_count != 0:
        raise UsageError("--ball goes with --train-count 0 (a fitted model is each venue's)")
    check_number("--threshold", args.threshold, low=0.0, high=1.0)
    if out_dir.exists() and not out_dir.is_dir():
        raise UsageError(f"--out-dir {out_dir}: is not a folder")
    grouping_file = None if args.group_by in ("folder", "day") else Path(args.group_by)
    check_distinct([(f"the output {name}", out_dir / name) for name in IMAGES_OUTPUTS],
                   [("the --check-model file", args.check), ("the --ball file", args.ball),
                    ("the --group-by file", grouping_file),
                    *((f"the input folder {d}", d) for d in args.dirs)])
    grouping = read_grouping(args.group_by)
    check = shipped_check() if args.check is None else read_check_file(args.check)
    generic = None
    if args.train_count == 0 and args.detector == "real":
        generic = shipped_generic() if args.ball is None else read_ball_file(args.ball)
    t0 = time.perf_counter()
    doc, rows = run_images_suite(args.dirs, train_count=args.train_count,
                                 detector=args.detector, ball_class=args.ball_class,
                                 check=check, head=not args.no_head,
                                 threshold=args.threshold, train_from=args.train_from,
                                 grouping=grouping, generic=generic, only=args.only)
    out_dir.mkdir(parents=True, exist_ok=True)
    text = images_markdown(doc)
    doc["check"] = "shipped" if args.check is None else args.check.name
    doc["threshold"] = args.threshold  # None: each folder's model's own
    if generic is not None:
        doc["ball"] = "generic (shipped)" if args.ball is None else args.ball.name
    for name, content in zip(IMAGES_OUTPUTS, (strict_json(doc, sort_keys=True, indent=2)
                                              + "\n", text, images_csv(rows)), strict=True):
        with atomic_output(out_dir / name, force=True) as tmp:
            tmp.write_text(content, encoding="utf-8", errors=TEXT_ERRORS)
    echo(args, text)
    echo(args, f"wrote {out_dir / 'images-summary.json'}, .md and images.csv in "
         f"{time.perf_counter() - t0:.0f} s")
    return 0


def _main(argv: Sequence[str] | None) -> int:
    args = build_parser().parse_args(argv)
    if args.suite == "images":
        _check_poses(args)
        return _run_images(args)
    if args.dirs:
        raise UsageError("folders (DIR) go with --suite images")
    out_dir: Path = args.out_dir
    t0 = time.perf_counter()
    md, js = out_dir / f"{_stem(args)}.md", out_dir / f"{_stem(args)}.json"
    check_distinct([("the table", md), ("the table", js)],
                   [("the --calibration file", args.calibration)])
    _check(args)
    workers = workers_from_args(args)
    out_dir.mkdir(parents=True, exist_ok=True)
    _, text, doc = _run_suite(args, workers)
    with atomic_output(md, force=True) as tmp:  # tables are rewritten on every run
        tmp.write_text(text, encoding="utf-8", errors=TEXT_ERRORS)
    with atomic_output(js, force=True) as tmp:
        tmp.write_text(strict_json(doc, sort_keys=True, indent=2) + "\n", encoding="utf-8",
                       errors=TEXT_ERRORS)
    echo(args, text)
    echo(args, f"wrote {md} and .json in {time.perf_counter() - t0:.0f} s")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    return run_main(PROG, _main, argv)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
