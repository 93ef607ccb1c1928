"""The ``foreign`` suite: the default pipeline scored on logs the project did not record.

Each log of :data:`FOREIGN_LOGS` (exact poses and poses drifting by 2 cm / 0.5 deg,
5 cm / 1 deg and 10 cm / 2 deg; with and without a pose covariance; cameras at 20 and 30 Hz;
2-5 robots; the camera's own profile, described by a lookup table, and two logs with the
mirror profile, described with its height so the replay can cross rays) is drawn by
:mod:`replay.evaluate.foreign` with the seed its set gives it, beside its camera file (the
ball hops for a tenth to a third of a log's steps). It is replayed as a team would replay
it (``dsp-replay LOG --cameras ... --image-topic ... --pose-topic ... --truth-topic
/mocap/ball``, no switch: the default profile) and scored over its fused steps with
:func:`~replay.evaluate.match_score.score_steps`: position RMSE, median and p95, the
velocity's median error, and the RMSE while the ball is on the ground (which a hop seen
through a camera without rays does not spoil).

The seeds come in two sets that never mix: :data:`TUNE_SEEDS`, the logs a default may be
chosen on, and :data:`REPORT_SEEDS`, the logs it is reported on (``dsp-eval --suite foreign
--foreign-set report``, the default). A log is named after everything it is drawn with, so
an existing one is reused only by a run that would draw the same one.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dsp.errors import UsageError
from dsp.jsonio import Json
from dsp.progress import progress_bar
from replay.evaluate.foreign import (
    IMAGE_TOPIC,
    TRUTH_TOPIC,
    ForeignOptions,
    pose_topic,
    write_camera_file,
    write_foreign_log,
)
from replay.evaluate.match_score import Scores, score_steps
from replay.evaluate.suites import rounded_doc
from replay.parallel import Outcome, Workers, map_tasks
from replay.profiles import without_reason

__all__ = [
    "CHECK_SEEDS",
    "FOREIGN_IMAGE_PX",
    "FOREIGN_LOGS",
    "FOREIGN_SETS",
    "REPORT_SEEDS",
    "TUNE_SEEDS",
    "ForeignLog",
    "ForeignLogScore",
    "ForeignTask",
    "add_foreign_arguments",
    "foreign_markdown",
    "foreign_stem",
    "foreign_tasks",
    "run_foreign_from_args",
    "run_foreign_suite",
    "run_foreign_task",
]

FOREIGN_IMAGE_PX = 640
GROUND_Z_M = 0.12
"""A ball whose centre is below this is on the ground (its radius is 0.11 m)."""


@dataclass(frozen=True)
class ForeignLog:
    """One log's settings in the suite (its seed comes from the set)."""

    robots: int
    rate_hz: float
    drift: tuple[float, float] | None
    """The poses' drift (m, deg); None: exact poses."""
    covariance: bool
    camera: str = "own"
    """"own" (a lookup camera file) or "mirror" (a camera with its height: rays in 3-D)."""
    field: bool = False
    """The camera file names the field: the default fits the poses to the lines."""

    @property
    def label(self) -> str:
        poses = ("exact" if self.drift is None
                 else f"drift {self.drift[0]:g} m/{self.drift[1]:g} deg")
        cov = ", covariance" if self.covariance else ""
        cam = ", mirror camera" if self.camera == "mirror" else ""
        field = ", field named" if self.field else ""
        return f"{poses}{cov}{cam}{field}, {self.robots} robots, {self.rate_hz:g} Hz"

    def options(self, seed: int, duration_s: float) -> ForeignOptions:
        return ForeignOptions(
            seed=seed, robots=self.robots, rate_hz=self.rate_hz, duration_s=duration_s,
            poses="exact" if self.drift is None else "drift",
            drift=self.drift or (0.0, 0.0),
            covariance="honest" if self.covariance else "none", camera=self.camera,
            size_px=FOREIGN_IMAGE_PX, names_field=self.field)


FOREIGN_LOGS: tuple[ForeignLog, ...] = (
    ForeignLog(3, 20.0, None, False),
    ForeignLog(4, 30.0, None, True),
    ForeignLog(2, 20.0, (0.02, 0.5), False),
    ForeignLog(3, 30.0, (0.02, 0.5), True),
    ForeignLog(3, 30.0, (0.05, 1.0), False),
    ForeignLog(4, 20.0, (0.05, 1.0), True),
    ForeignLog(3, 20.0, (0.10, 2.0), False),
    ForeignLog(5, 20.0, (0.10, 2.0), True),
    ForeignLog(3, 20.0, None, False, "mirror"),
    ForeignLog(4, 30.0, (0.05, 1.0), True, "mirror"),
    ForeignLog(3, 20.0, None, False, "mirror", field=True),
    ForeignLog(3, 30.0, (0.10, 2.0), False, "mirror", field=True),
)
"""Every log of the suite, in table order: the settings in one place."""
TUNE_SEEDS: tuple[int, ...] = (1101, 1102, 1103, 1104, 1105, 1106, 1107, 1108, 1109, 1110,
                                1111, 1112)
"""The seeds of the logs a default may be tuned on, one per :data:`FOREIGN_LOGS` entry."""
REPORT_SEEDS: tuple[int, ...] = (2101, 2102, 2103, 2104, 2105, 2106, 2107, 2108, 2109, 2110,
                                  2111, 2112)
"""The seeds of the logs a default is reported on: never tuned on."""
CHECK_SEEDS: tuple[int, ...] = (3101, 3102, 3103, 3104, 3105, 3106, 3107, 3108, 3109, 3110,
                                 3111, 3112)
"""A second report set, for a check that no choice has seen (the report set's figures are
seen each time a default is reported, and a later choice may remember them)."""
FOREIGN_SETS = {"report": REPORT_SEEDS, "tune": TUNE_SEEDS, "check": CHECK_SEEDS}


@dataclass(frozen=True)
class ForeignTask:
    """One log of the suite; :func:`run_foreign_task` is a pure function of it."""

    label: str
    log: Path
    """Drawn there with its camera file (``.cameras.yaml``) when missing, then replayed."""
    options: ForeignOptions

    @property
    def cameras(self) -> Path:
        return self.log.with_suffix(".cameras.yaml")


@dataclass(frozen=True)
class ForeignLogScore:
    """What one log adds to the suite (small, picklable, no timings)."""

    label: str
    seed: int
    scores: Scores
    ground: Scores
    """The steps whose ball is on the ground (its centre below :data:`GROUND_Z_M`)."""
    robots: dict[str, list[float]]
    """robot -> errors of its own estimates [m]."""
    pipeline: str


def _log_name(o: ForeignOptions) -> str:
    drift = "exact" if o.poses == "exact" else f"drift{o.drift[0]:g}m{o.drift[1]:g}deg"
    return (f"foreign-{o.seed}-{o.robots}r-{o.rate_hz:g}hz-{drift}-{o.covariance}-"
            f"{o.duration_s:g}s-{o.size_px}px-{o.image}-{o.camera}"
            f"{'-field' if o.names_field else ''}.mcap")


def foreign_tasks(workdir: Path, *, seeds: Sequence[int], duration_s: float,
                  logs: Sequence[ForeignLog] = FOREIGN_LOGS) -> list[ForeignTask]:
    """One task per log, each with its seed from ``seeds`` (as many as ``logs``)."""
    if len(seeds) != len(logs):
        raise ValueError(f"{len(seeds)} seeds for {len(logs)} logs")
    return [ForeignTask(log.label, workdir / _log_name(o), o)
            for log, seed in zip(logs, seeds, strict=True)
            for o in (log.options(seed, duration_s),)]


def run_foreign_task(task: ForeignTask) -> ForeignLogScore:
    """Draw the log when missing, replay it with the default pipeline, score it."""
    from replay.profiles import options_for
    from replay.runner import replay
    from replay.sinks import ResultsCollector

    if not (task.log.exists() and task.cameras.exists()):
        write_camera_file(task.cameras, task.options, force=True)
        write_foreign_log(task.log, task.options, force=True)
    collected = ResultsCollector()
    summary = replay(task.log, options_for(
        cameras=task.cameras, image_topic=IMAGE_TOPIC, pose_topic=pose_topic(task.options),
        truth_topic=TRUTH_TOPIC, progress=False), sinks=[collected])
    robots: dict[str, list[float]] = {}
    for fr in collected.frames:
        if fr.get("error_m") is not None:
            robots.setdefault(fr["robot"], []).append(float(fr["error_m"]))
    steps = [f for f in collected.fused if not f.get("tick")]
    ground = [f for f in steps if (f.get("truth_z_m") or 0.0) < GROUND_Z_M]
    return ForeignLogScore(task.label, task.options.seed, score_steps(steps, []),
                           score_steps(ground, []), robots, summary.pipeline or "")


Mapper = Callable[[Callable[[ForeignTask], ForeignLogScore], Sequence[ForeignTask]],
                  Sequence[ForeignLogScore]]


def run_foreign_suite(tasks: Sequence[ForeignTask], map_logs: Mapper | None = None
                      ) -> list[ForeignLogScore]:
    """Every task's score, in task order (serially without ``map_logs``)."""
    if map_logs is None:
        return [run_foreign_task(t) for t in tasks]
    return list(map_logs(run_foreign_task, tasks))


def _doc(scores: Sequence[ForeignLogScore], set_name: str, duration_s: float
         ) -> dict[str, Json]:
    pooled, pooled_ground = Scores(), Scores()
    for s in scores:
        pooled.add(s.scores)
        pooled_ground.add(s.ground)
    return rounded_doc({
        "suite": "foreign", "set": set_name, "duration_s": duration_s,
        "image_px": FOREIGN_IMAGE_PX,
        "logs": [{"label": s.label, "seed": s.seed, "pipeline": s.pipeline,
                  "fused": s.scores.stats(), "ground": s.ground.stats(),
                  "robots": {r: Scores(errors=e, steps=len(e)).stats()
                             for r, e in sorted(s.robots.items())}} for s in scores],
        "pooled": pooled.stats(), "pooled_ground": pooled_ground.stats(),
    })


def _fmt(v: Any, nd: int = 4) -> str:
    return "-" if v is None else f"{v:.{nd}f}"


def foreign_markdown(doc: dict[str, Any]) -> str:
    """A row per log (fused errors; the pipeline it ran, by number, without why its detector
    was chosen: the results hold that), then the pooled row."""
    pipelines = list(dict.fromkeys(without_reason(log["pipeline"]) for log in doc["logs"]))
    lines = [f"Foreign logs, the `{doc['set']}` set: {doc['duration_s']:g} s each, "
             f"{doc['image_px']} px images, replayed with the default pipeline.", "",
             "| log | seed | steps | RMSE [m] | median [m] | p95 [m] | velocity median [m/s] "
             "| RMSE, ball on the ground [m] | pipeline |", "|---|---|---|---|---|---|---|---|---|"]
    for log in doc["logs"] + [{"label": "all logs", "seed": "", "fused": doc["pooled"],
                               "ground": doc["pooled_ground"], "pipeline": None}]:
        st = log["fused"]
        which = "" if log["pipeline"] is None else str(
            pipelines.index(without_reason(log["pipeline"])) + 1)
        lines.append(f"| {log['label']} | {log['seed']} | {st['estimates']} | "
                     f"{_fmt(st['rmse_m'])} | {_fmt(st['median_m'])} | {_fmt(st['p95_m'])} | "
                     f"{_fmt(st['velocity_median_m_s'], 3)} | {_fmt(log['ground']['rmse_m'])} "
                     f"| {which} |")
    lines += [""] + [f"{i}. {p}" for i, p in enumerate(pipelines, 1)]
    return "\n".join(lines) + "\n"


def add_foreign_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("--suite foreign")
    g.add_argument("--foreign-set", choices=tuple(FOREIGN_SETS), default="report",
                   help="the logs' seeds: report (default; never tuned on), tune, or check "
                   "(a second held-out set)")


def foreign_stem(args: argparse.Namespace) -> str:
    """The tables' file stem in --out-dir."""
    return f"foreign-{args.foreign_set}-{args.duration or 10.0:g}s"


def run_foreign_from_args(args: argparse.Namespace, workers: Workers, *, progress: bool | None
                          ) -> tuple[str, str, dict[str, Json]]:
    """``dsp-eval --suite foreign``: the file stem, the Markdown table and the JSON doc."""
    given = [flag for flag, on in (("--realism", args.realism != "none"),
                                   ("--localise", args.localise != "none"),
                                   ("--pose-uncertainty", args.pose_uncertainty),
                                   ("--hops", args.hops), ("--calibration", args.calibration))
             if on]
    if given:
        raise UsageError(f"{given[0]}: --suite foreign replays its logs with the default "
                         "pipeline and their own camera files; drop the option")
    duration = 10.0 if args.duration is None else args.duration
    workdir: Path = args.out_dir / "foreign"
    workdir.mkdir(parents=True, exist_ok=True)
    tasks = foreign_tasks(workdir, seeds=FOREIGN_SETS[args.foreign_set], duration_s=duration)
    with progress_bar(len(tasks), "dsp-eval", progress, unit="log") as bar:

        def done(i: int, outcome: Outcome[ForeignLogScore]) -> None:
            bar.update(1)

        def map_logs(fn: Callable[[ForeignTask], ForeignLogScore],
                     todo: Sequence[ForeignTask]) -> list[ForeignLogScore]:
            return [o.unwrap() for o in map_tasks(fn, todo, workers, on_done=done,
                                                  fail_fast=True)]

        scores = run_foreign_suite(tasks, map_logs)
    doc = _doc(scores, args.foreign_set, duration)
    return foreign_stem(args), foreign_markdown(doc), doc
