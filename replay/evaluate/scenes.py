"""One scene of an evaluation suite as a task that can run anywhere.

A suite (``dsp-eval --suite paper|random|...``) is a list of :class:`SceneTask` s mapped
through :func:`run_scene` by a :data:`SceneMapper` (one after the other, a process pool or
Ray tasks: :func:`replay.parallel.map_tasks`) and folded back in scene order. A task is
frozen and picklable and :func:`run_scene` depends on nothing else, so the suite's tables
are the same bytes whatever the worker count::

    task = SceneTask(score_random_scene, "random", 7, Path("eval/random-7-ideal.mcap"), rec)
    scene = run_scene(task)   # records the log when missing, replays each config, scores

A suite adds itself by writing a scorer (:data:`SceneScorer`, a module-level function that
reduces the scene's replays to a small picklable record without timings) and the loop that
makes its tasks and folds their results.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Generic, Protocol, TypeVar

from dsp.errors import InputError
from dsp.text import printable
from estimator.fusion import FUSION_METHODS
from replay.log import LogReader
from replay.options import ReplayOptions
from replay.profiles import options_for
from replay.runner import replay
from replay.sinks import ResultsCollector

__all__ = [
    "CONFIGS",
    "Config",
    "Recorder",
    "Replays",
    "SceneMapper",
    "SceneScorer",
    "SceneTask",
    "check_reused",
    "configs_for",
    "prepare_log",
    "replay_results",
    "run_scene",
    "serial_map",
]

T = TypeVar("T")
R = TypeVar("R")
S = TypeVar("S")
"""What a suite's scorer makes of one scene."""


@dataclass(frozen=True)
class Config:
    method: str
    fusion: str
    localise: str = "none"
    """The replay's ``--localise``: "lines" corrects the poses from the field lines, "ball"
    by the robots' biases the tracker learns (``track`` only)."""

    @property
    def label(self) -> str:
        poses = "" if self.localise == "none" else f" + {self.localise}"
        return f"{self.method}/{self.fusion}{poses}"


DEFAULT_METHOD = "default"
"""A config whose method is this replays a whole profile (its ``fusion`` names it), as
``dsp-replay LOG --profile NAME`` does: ``default/best`` is ``dsp-replay LOG``."""
CONFIGS = (Config("paper", "mean"),
           *(Config("corrected", f) for f in FUSION_METHODS if f != "ballistic"),
           Config(DEFAULT_METHOD, "best"))
"""The paper and random suites' replays, and the default pipeline's last. Not
``ballistic``: on their still and rolling balls it is ``triangulate`` behind a filter;
``dsp-eval --suite lobs`` scores it."""


def configs_for(localise: str = "none") -> tuple[Config, ...]:
    """:data:`CONFIGS`; with ``localise`` ("lines") each corrected one again after them,
    its poses corrected (labelled ``corrected/FUSION + lines``)."""
    if localise == "none":
        return CONFIGS
    return CONFIGS + tuple(Config(c.method, c.fusion, localise) for c in CONFIGS
                           if c.method == "corrected" and (localise != "ball"
                                                           or c.fusion == "track"))

Recorder = Callable[[Path, str, int], None]
"""record(path, scenario, seed): writes one log. To run scenes in other processes it must
pickle: an instance of a module-level class, not a closure."""

Replays = Iterator[tuple[Config, dict[str, Any]]]
"""A scene's replays, one per config, made lazily: (config, frames and fused steps)."""


@dataclass(frozen=True)
class SceneTask(Generic[S]):
    """One scene of a suite; :func:`run_scene` is a pure function of it."""

    score: Callable[[SceneTask[S], Replays], S]
    """The suite's :data:`SceneScorer` (a module-level function, so the task pickles)."""
    scenario: str
    """The scenario name the recorder is given."""
    seed: int
    log: Path
    """Recorded there when missing (an existing log is reused), then replayed."""
    record: Recorder
    calibration: Path | None = None
    configs: tuple[Config, ...] = CONFIGS
    pose_uncertainty: bool = False
    """Every replay weighs the robots by their pose's covariance (``--pose-uncertainty``)."""


SceneScorer = Callable[[SceneTask[S], Replays], S]
"""Scores one scene from its replays; returns a small picklable record (no timings)."""


class SceneMapper(Protocol):
    """map(run_scene, tasks): the results in task order (serial, a process pool, Ray)."""

    def __call__(self, fn: Callable[[SceneTask[S]], S],
                 tasks: Sequence[SceneTask[S]]) -> Iterable[S]: ...


def serial_map(fn: Callable[[T], R], tasks: Sequence[T]) -> list[R]:
    """The default :data:`SceneMapper` (and the match suite's mapper): one task after the
    other, in this process."""
    return [fn(task) for task in tasks]


def replay_results(log: Path, config: Config, calibration: Path | None, *,
                   pose_uncertainty: bool = False) -> dict[str, Any]:
    """The replay's frames and fused steps, as its results file would hold them."""
    collected = ResultsCollector()
    if config.method == DEFAULT_METHOD:
        options = options_for(config.fusion, calibration=calibration, progress=False)
    else:
        options = ReplayOptions(method=config.method, fusion=config.fusion,
                                calibration=calibration, localise=config.localise,
                                pose_uncertainty=pose_uncertainty, progress=False)
    replay(log, options, sinks=[collected])
    return {"frames": collected.frames, "fused": collected.fused}


def check_reused(log: Path, scenario: str, seed: int) -> None:
    """Refuse a log already at ``log`` (about to be reused instead of recorded) whose
    scenario metadata is not ``scenario`` with ``seed``: another scene's log with the
    expected name would be scored as this one."""
    with LogReader(log) as reader:
        found = reader.info.scenario
    if found is None or (found.name, found.seed) != (scenario, seed):
        what = ("no dsp.scenario metadata" if found is None
                else f"{printable(found.name)[:40]} seed {found.seed}")
        raise InputError(f"{log}: reused as {scenario} seed {seed}, but the log is {what}; "
                         "remove it (it is recorded again) or choose another --out-dir")


def prepare_log(log: Path, scenario: str, seed: int, record: Callable[[], None]) -> None:
    """Record the scene at ``log`` when it is missing, else check the log there is it."""
    if log.exists():
        check_reused(log, scenario, seed)
    else:
        record()


def run_scene(task: SceneTask[S]) -> S:
    """Record the scene's log when it is missing, replay it under each config, score it."""
    prepare_log(task.log, task.scenario, task.seed,
                lambda: task.record(task.log, task.scenario, task.seed))
    replays = ((c, replay_results(task.log, c, task.calibration,
                                  pose_uncertainty=task.pose_uncertainty))
               for c in task.configs)
    return task.score(task, replays)
