"""The ``match`` suite: seeded matches scored for the tracker against window fusion.

Each match (:mod:`recorder.match`: three robots driving, the ball kicked and passed at 2-8
m/s, each camera free-running at its own phase, orange distractors beside the field) is
recorded once with random camera phases and, for the first ``sync_count`` seeds, once more
with the cameras in sync. Every log is replayed with the corrected estimator and each
fusion method (``track`` when the estimator has it, and the window fusions mean, weighted
and robust). Scored over every fused step of every match:

- position error [m] to the truth at the step's stamp: RMSE, p95, max (and per robot, from
  the robots' own estimates);
- velocity error [m/s] (the norm of the difference to the true velocity), median and p95,
  for the fusions that estimate a velocity;
- distractor captures: a run of at least :data:`CAPTURE_STEPS` consecutive fused steps
  whose estimate is more than :data:`CAPTURE_ERROR_M` from the ball and within
  :data:`CAPTURE_RADIUS_M` of a distractor counts as one capture.

The steps are at the images' stamps, which differ between the phases: synchronised cameras
give one step per frame time, each with fresh estimates; free-running ones three, the other
two predicted from older estimates. So the tracker is also read on a common clock, at every
tick of :data:`CLOCK_HZ` (``replay --clock``, the row :data:`CLOCK_ROW`): the same instants
in either phase, as a robot's control loop would read it.

With ``localise="lines"`` every replay runs twice, with the poses the robots believe and
with each corrected from its image's field lines (``replay --localise lines``): each row
(and robot) is scored both ways, the second labelled :data:`LINES_SUFFIX`. With
``pose_uncertainty`` every replay weighs the robots by their own pose's covariance
(``replay --pose-uncertainty``).

:func:`run_match_task` is a function of one :class:`MatchTask` (seed, camera phase,
options) alone, so logs can be scored in any order, in a process pool or as Ray tasks;
:func:`run_match_suite` folds them in task order.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dsp import contract
from dsp.jsonio import Json
from dsp.metadata import MetadataError, ScenarioMetadata
from dsp.realism import realism_preset
from estimator.fusion import FUSION_METHODS
from replay.evaluate.match_score import (
    CAPTURE_ERROR_M,
    CAPTURE_RADIUS_M,
    CAPTURE_STEPS,
    Scores,
    captures,
    score_steps,
)
from replay.evaluate.scenes import prepare_log, serial_map
from replay.evaluate.suites import rounded_doc
from replay.options import ReplayOptions
from replay.profiles import options_for
from replay.runner import replay
from replay.sinks import ResultsCollector

__all__ = [
    "CAPTURE_ERROR_M",
    "CAPTURE_RADIUS_M",
    "CAPTURE_STEPS",
    "CLOCK_HZ",
    "CLOCK_ROW",
    "DEFAULT_ROW",
    "LINES_SUFFIX",
    "MATCH_FUSIONS",
    "MatchLogScore",
    "MatchOptions",
    "MatchRecorder",
    "MatchSuite",
    "MatchTask",
    "TaskMapper",
    "captures",
    "match_log_name",
    "match_markdown",
    "match_tasks",
    "run_match_suite",
    "run_match_task",
    "score_match_log",
    "score_rows",
    "serial_map",
]

DEFAULT_ROW = "default"
"""The row of ``dsp-replay LOG`` with no switches: the best profile (:mod:`replay.profiles`),
its line fit, pose uncertainty and hops decided from the log."""
MATCH_FUSIONS = (*(f for f in ("track", "mean", "weighted", "robust") if f in FUSION_METHODS),
                 DEFAULT_ROW)
"""The fusions the suite compares (``track`` first when the estimator has it), and the
default pipeline last."""
PHASES = ("random", "sync")
CLOCK_HZ = 100.0
"""The common clock the tracker is also scored on (``dsp-replay --clock``)."""
CLOCK_ROW = "track, 100 Hz clock"
LINES_SUFFIX = " + lines"
"""A row's (or robot's) label suffix when its poses were corrected from the field lines
(``--localise ball``: " + ball")."""


def pose_label(row: str, localise: str) -> str:
    """The label of ``row`` replayed with ``--localise localise``."""
    return row if localise == "none" else f"{row} + {localise}"


def replays_with(fusion: str, localise: str) -> bool:
    """Whether ``fusion`` is replayed with ``--localise localise``: "ball" learns the biases
    from the tracker, so only ``track`` is."""
    if fusion == DEFAULT_ROW:  # the profile settles its own poses
        return localise == "none"
    return localise != "ball" or fusion == "track"


def score_rows(fusions: Sequence[str], localise: str = "none") -> tuple[str, ...]:
    """The table's rows: each fusion, and the tracker on the clock after ``track``; with
    ``localise``, each of them with the believed poses, then with the corrected ones."""
    def rows(mode: str) -> tuple[str, ...]:
        return tuple(r for f in fusions if replays_with(f, mode)
                     for r in ((f, CLOCK_ROW) if f == "track" else (f,)))
    return tuple(pose_label(r, mode) for mode in pose_modes(localise) for r in rows(mode))


def pose_modes(localise: str) -> tuple[str, ...]:
    """The ``--localise`` modes each log is replayed with: the believed poses, and the
    corrected ones when ``localise`` asks for them."""
    return ("none",) if localise == "none" else ("none", localise)


@dataclass(frozen=True)
class MatchOptions:
    """How the suite's matches are recorded and replayed."""

    camera: str = "ideal"
    duration_s: float = 10.0
    rate_hz: float | None = None
    """Camera rate; None: the match scenario's (20 Hz)."""
    face_px: int | None = None
    """Render resolution; None: the recorder's default."""
    distractors: int = 3
    renderer: str = "auto"
    calibration: Path | None = None
    realism: str = "none"
    """The recorder's preset of localisation error and camera effects (:mod:`dsp.realism`);
    ``distractors`` stays as given."""
    localise: str = "none"
    """"lines": each log also replayed with its poses corrected from the field lines."""
    pose_uncertainty: bool = False
    """Every replay weighs the robots by their pose's covariance (``--pose-uncertainty``)."""
    hops: bool = False
    """The tracker's rows replayed with ``--hops`` (its position from a 3-D track beside
    it while the ball hops, :mod:`estimator.hops`)."""

    def log_name(self, seed: int, phase: str) -> str:
        return match_log_name(seed, phase, self)


def match_log_name(seed: int, phase: str, options: MatchOptions) -> str:
    """The log's file name: every option that changes the recording is in it, so a log is
    reused only by a run that would record the same one."""
    rate = "" if options.rate_hz is None else f"-r{options.rate_hz:g}"
    face = "" if options.face_px is None else f"-f{options.face_px}"
    realism = "" if options.realism == "none" else f"-{options.realism}"
    return (f"match-{seed}-{phase}-{options.camera}-d{options.distractors}"
            f"-{options.duration_s:g}s{rate}{face}{realism}.mcap")


@dataclass(frozen=True)
class MatchRecorder:
    """Records one match log with pybullet (a class, so a task pickles to other processes)."""

    options: MatchOptions
    phase: str

    def __call__(self, path: Path, seed: int) -> None:
        from recorder.omni import DEFAULT_FACE_PX  # lazy: replay alone needs no pybullet
        from recorder.record import RecordOptions, record

        o = self.options
        effects = dataclasses.replace(realism_preset(o.realism), distractors=o.distractors)
        record(path, RecordOptions(
            scenario="match", seed=seed, camera=o.camera, renderer=o.renderer,
            camera_phase=self.phase, duration_s=o.duration_s, rate_hz=o.rate_hz,
            face_px=DEFAULT_FACE_PX if o.face_px is None else o.face_px).with_realism(effects))


@dataclass(frozen=True)
class MatchTask:
    """One match log of the suite; :func:`run_match_task` is a pure function of it."""

    seed: int
    phase: str
    log: Path
    """Recorded there when missing (an existing log is reused), then replayed."""
    options: MatchOptions
    fusions: tuple[str, ...] = MATCH_FUSIONS


@dataclass(frozen=True)
class MatchLogScore:
    """What one match log adds to the suite (small, picklable, no timings)."""

    seed: int
    phase: str
    fused: dict[str, Scores]
    """fusion -> scores."""
    robots: dict[str, list[float]]
    """robot -> errors of its own estimates."""


TaskMapper = Callable[[Callable[[MatchTask], MatchLogScore], Sequence[MatchTask]],
                      Iterable[MatchLogScore]]
"""map(run_match_task, tasks): the results in task order (serially, a pool, Ray)."""


def _distractors(log: Path) -> list[tuple[float, float]]:
    """The distractors' (x, y) from the log's scenario metadata (none when it names none)."""
    from mcap.reader import make_reader

    with open(log, "rb") as f:
        for m in make_reader(f).iter_metadata():
            if m.name == contract.SCENARIO_METADATA:
                play = ScenarioMetadata.from_metadata(m.metadata).scene.get("play") or {}
                try:
                    return [(float(d["x_m"]), float(d["y_m"]))
                            for d in play.get("distractors", [])]
                except (KeyError, TypeError, ValueError) as err:
                    raise MetadataError(f"{log.name}: unreadable distractors: {err}") from err
    return []


def run_match_task(task: MatchTask) -> MatchLogScore:
    """Record the match when its log is missing (else check the log there is it), replay it
    with each fusion, score it."""
    prepare_log(task.log, "match", task.seed,
                lambda: MatchRecorder(task.options, task.phase)(task.log, task.seed))
    return score_match_log(task)


def score_match_log(task: MatchTask) -> MatchLogScore:
    """Replay the log at ``task.log`` with each fusion and score it (whatever scene it is)."""
    distractors = _distractors(task.log)
    fused: dict[str, Scores] = {}
    robots: dict[str, list[float]] = {}
    o = task.options
    for mode, fusion in ((m, f) for m in pose_modes(o.localise) for f in task.fusions
                         if replays_with(f, m)):
        collected = ResultsCollector()
        clock = CLOCK_HZ if fusion == "track" else None
        options = (options_for(calibration=o.calibration, progress=False)
                   if fusion == DEFAULT_ROW else
                   ReplayOptions(method="corrected", fusion=fusion, clock_hz=clock,
                                 calibration=o.calibration, localise=mode,
                                 pose_uncertainty=o.pose_uncertainty,
                                 hops=o.hops and fusion == "track", progress=False))
        replay(task.log, options, sinks=[collected])
        fused[pose_label(fusion, mode)] = score_steps(
            [f for f in collected.fused if not f.get("tick")], distractors)
        if clock is not None:  # the ticks: steps without images
            fused[pose_label(CLOCK_ROW, mode)] = score_steps(
                [f for f in collected.fused if f.get("tick")], distractors)
        if fusion == task.fusions[0]:  # the robots' own: the same under every fusion
            for fr in collected.frames:
                if fr.get("error_m") is not None:
                    robots.setdefault(pose_label(fr["robot"], mode), []).append(
                        float(fr["error_m"]))
    return MatchLogScore(task.seed, task.phase, fused, robots)


@dataclass
class MatchSuite:
    options: MatchOptions
    count: int
    seed: int
    fusions: tuple[str, ...]
    logs: list[MatchLogScore] = field(default_factory=list)

    def pooled(self, phase: str, seeds: set[int] | None = None) -> dict[str, Scores]:
        out = {f: Scores() for f in score_rows(self.fusions, self.options.localise)}
        for log in self.logs:
            if log.phase == phase and (seeds is None or log.seed in seeds):
                for fusion, s in log.fused.items():
                    out[fusion].add(s)
        return out

    def robot_stats(self) -> dict[str, dict[str, Any]]:
        pooled: dict[str, list[float]] = {}
        for log in self.logs:
            if log.phase == "random":
                for robot, errs in log.robots.items():
                    pooled.setdefault(robot, []).extend(errs)
        return {r: Scores(errors=e, steps=len(e)).stats() for r, e in sorted(pooled.items())}

    def sync_seeds(self) -> set[int]:
        return {log.seed for log in self.logs if log.phase == "sync"}

    def to_dict(self) -> dict[str, Json]:
        both = self.sync_seeds()
        doc = {
            "suite": "match", "count": self.count, "seed": self.seed,
            "options": {"camera": self.options.camera, "duration_s": self.options.duration_s,
                        "rate_hz": self.options.rate_hz, "face_px": self.options.face_px,
                        "distractors": self.options.distractors,
                        **({"realism": self.options.realism}
                           if self.options.realism != "none" else {}),
                        **({"localise": self.options.localise}
                           if self.options.localise != "none" else {}),
                        **({"pose_uncertainty": True} if self.options.pose_uncertainty
                           else {}),
                        **({"hops": True} if self.options.hops else {}),
                        "calibration": (self.options.calibration.name
                                        if self.options.calibration else None)},
            "capture": {"error_m": CAPTURE_ERROR_M, "radius_m": CAPTURE_RADIUS_M,
                        "steps": CAPTURE_STEPS},
            "fused": {f: s.stats() for f, s in self.pooled("random").items()},
            "robots": self.robot_stats(),
            "phase_comparison": {
                "seeds": sorted(both),
                "random": {f: s.stats() for f, s in self.pooled("random", both).items()},
                "sync": {f: s.stats() for f, s in self.pooled("sync", both).items()},
            },
        }
        return rounded_doc(doc)


def match_tasks(workdir: Path, options: MatchOptions, *, count: int, seed: int = 0,
                sync_count: int | None = None,
                fusions: Sequence[str] = MATCH_FUSIONS) -> list[MatchTask]:
    """``count`` matches from ``seed`` with random camera phases, then the first
    ``sync_count`` (default all) again with the cameras in sync."""
    sync_count = count if sync_count is None else min(sync_count, count)
    return [MatchTask(seed + i, phase, workdir / options.log_name(seed + i, phase), options,
                      tuple(fusions))
            for phase, n in (("random", count), ("sync", sync_count)) for i in range(n)]


def run_match_suite(workdir: Path, options: MatchOptions, *, count: int, seed: int = 0,
                    sync_count: int | None = None, fusions: Sequence[str] = MATCH_FUSIONS,
                    map_tasks: TaskMapper = serial_map) -> MatchSuite:
    """The suite: :func:`match_tasks` mapped through :func:`run_match_task`, folded in
    task order (so the tables are the same whatever ``map_tasks`` runs them on)."""
    suite = MatchSuite(options, count, seed, tuple(fusions))
    tasks = match_tasks(workdir, options, count=count, seed=seed, sync_count=sync_count,
                        fusions=fusions)
    suite.logs.extend(map_tasks(run_match_task, tasks))
    return suite


def _fmt(v: float | None, nd: int = 4) -> str:
    return "-" if v is None else f"{v:.{nd}f}"


def _poses_note(o: MatchOptions) -> str:
    """How the poses were taken, for the table's heading."""
    how = {"lines": "from the field lines", "ball": "by each robot's bias the tracker learns"}
    note = ("" if o.localise == "none" else
            f"; rows `+ {o.localise}`: poses corrected {how.get(o.localise, '')} "
            f"(`--localise {o.localise}`), the others as the robots believe them")
    note += ("; each robot weighed by its pose's covariance (`--pose-uncertainty`)"
             if o.pose_uncertainty else "")
    return note + ("; the track's position from a 3-D track while the ball hops (`--hops`)"
                   if o.hops else "")


def match_markdown(suite: MatchSuite) -> str:
    """The fused errors per method, the robots' own errors and the phase comparison."""
    o = suite.options
    rate = "20" if o.rate_hz is None else f"{o.rate_hz:g}"
    lines = [f"{suite.count} matches from seed {suite.seed}: {o.duration_s:g} s each, camera "
             f"`{o.camera}` at {rate} Hz per robot, random phases, {o.distractors} "
             "distractors" + ("" if o.realism == "none" else
                              f", localisation error and camera effects `--realism {o.realism}`")
             + _poses_note(o) + ".", "",
             "| fusion | steps | RMSE [m] | median [m] | p95 [m] | max [m] | "
             "velocity median [m/s] | velocity p95 [m/s] | captures (matches) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for fusion, s in suite.pooled("random").items():
        st = s.stats()
        lines.append(f"| {fusion} | {st['estimates']} | {_fmt(st['rmse_m'])} | "
                     f"{_fmt(st['median_m'])} | {_fmt(st['p95_m'])} | {_fmt(st['max_m'])} | "
                     f"{_fmt(st['velocity_median_m_s'], 3)} | {_fmt(st['velocity_p95_m_s'], 3)} "
                     f"| {st['captures']} ({st['matches_captured']}) |")
    lines += ["", "Each robot's own estimates:", "",
              "| robot | estimates | RMSE [m] | median [m] | p95 [m] | max [m] |",
              "|---|---|---|---|---|---|"]
    for robot, st in suite.robot_stats().items():
        lines.append(f"| {robot} | {st['estimates']} | {_fmt(st['rmse_m'])} | "
                     f"{_fmt(st['median_m'])} | {_fmt(st['p95_m'])} | {_fmt(st['max_m'])} |")
    both = suite.sync_seeds()
    if both:
        rnd, syn = suite.pooled("random", both), suite.pooled("sync", both)
        lines += ["", f"Random vs synchronised camera phases, the same {len(both)} matches:", "",
                  "| fusion | RMSE random [m] | RMSE sync [m] | random / sync |",
                  "|---|---|---|---|"]
        for fusion in score_rows(suite.fusions, o.localise):
            a, b = rnd[fusion].stats()["rmse_m"], syn[fusion].stats()["rmse_m"]
            ratio = "-" if a is None or not b else f"{a / b:.2f}"
            lines.append(f"| {fusion} | {_fmt(a)} | {_fmt(b)} | {ratio} |")
    lines += ["", f"A capture: >= {CAPTURE_STEPS} consecutive fused steps more than "
              f"{CAPTURE_ERROR_M:g} m from the ball and within {CAPTURE_RADIUS_M:g} m of a "
              f"distractor. `{CLOCK_ROW}`: the tracker read at every tick of a "
              f"{CLOCK_HZ:g} Hz clock (the same instants in both phases) instead of at the "
              "images' stamps."]
    return "\n".join(lines) + "\n"
