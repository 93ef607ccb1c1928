"""The paper's experiment, reproduced end to end: record scenes, replay them, score them.

Two suites:

- ``paper``: the paper's four scenarios (docs/method.md). Each is recorded, then replayed with
  paper mode (eq. 3-14, mean fusion) and with the corrected estimator under each fusion
  method. As in the paper's Table 1, a scenario's estimate is the mean of its fused
  estimates, its square error the squared distance of that mean to the ball, and the RMSE
  ``sqrt(mean(SE))`` over the four scenarios (eq. 19).
- ``random``: N seeded random scenes. Per-robot errors by distance band (the robot's true
  range to the ball), the detection rate, and per fusion method the fused errors over the
  scenes whose ball is within 9 m of at least two robots (the "dual sight" the method needs).

Everything here is deterministic given the logs: the tables hold no timings.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dsp.jsonio import Json
from replay.evaluate.scenes import (
    CONFIGS,
    Config,
    Recorder,
    Replays,
    SceneMapper,
    SceneTask,
    run_scene,
    serial_map,
)
from replay.sinks.results_json import DECIMALS

__all__ = [
    "CONFIGS",
    "DISTANCE_BANDS_M",
    "PAPER_RMSE_M",
    "PAPER_SCENARIOS",
    "PAPER_TABLE1",
    "PAPER_TRUTH",
    "Config",
    "PaperSuite",
    "RandomScene",
    "RandomSuite",
    "ScenarioScore",
    "paper_markdown",
    "random_markdown",
    "run_paper_suite",
    "run_random_suite",
    "score_paper_scenario",
    "score_paper_scene",
    "score_random_scene",
]

PAPER_SCENARIOS = ("scenario1", "scenario2", "scenario3", "scenario4")
PAPER_TRUTH = {"scenario1": (0.0, 0.0), "scenario2": (0.0, 3.0), "scenario3": (0.0, -3.0),
               "scenario4": (0.0, 0.0)}
PAPER_TABLE1 = {
    "scenario1": {"x_m": 0.07279, "y_m": 0.2948, "se_m2": 0.294},
    "scenario2": {"x_m": 0.04137, "y_m": 3.2447, "se_m2": 0.061},
    "scenario3": {"x_m": 0.01252, "y_m": -2.652, "se_m2": 0.121},
    "scenario4": {"x_m": 0.149655, "y_m": 0.2995, "se_m2": 0.112},
}
"""The paper's Table 1 as printed (row 1's SE is its y error, see docs/method.md)."""
PAPER_RMSE_M = 0.383
DISTANCE_BANDS_M = ((0.0, 3.0), (3.0, 6.0), (6.0, 9.0), (9.0, math.inf))
DUAL_SIGHT_RANGE_M = 9.0


@dataclass(frozen=True)
class ScenarioScore:
    scenario: str
    truth: tuple[float, float]
    estimate: tuple[float, float] | None
    """Mean of the scenario's fused estimates; None when nothing was fused."""
    fused_steps: int
    detections: int
    frames: int

    @property
    def se_m2(self) -> float | None:
        if self.estimate is None:
            return None
        return (self.estimate[0] - self.truth[0]) ** 2 + (self.estimate[1] - self.truth[1]) ** 2


@dataclass
class PaperSuite:
    camera: str
    calibration: str
    scores: dict[str, list[ScenarioScore]] = field(default_factory=dict)
    """Config label -> one score per paper scenario."""

    def rmse_m(self, label: str) -> float | None:
        se = [s.se_m2 for s in self.scores[label]]
        if not se or any(v is None for v in se):
            return None
        return math.sqrt(sum(v for v in se if v is not None) / len(se))  # eq. 19

    def best(self) -> str:
        """The corrected configuration with the lowest RMSE; on a tie, the first run."""
        ranked = [(r, i, lbl) for i, lbl in enumerate(self.scores)
                  if (r := self.rmse_m(lbl)) is not None and lbl.startswith("corrected/")]
        return min(ranked)[2] if ranked else ""

    def to_dict(self) -> dict[str, Json]:
        return rounded_doc({
            "suite": "paper", "camera": self.camera, "calibration": self.calibration,
            "paper": {"table1": PAPER_TABLE1, "rmse_m": PAPER_RMSE_M},
            "configs": {
                lbl: {"rmse_m": self.rmse_m(lbl), "scenarios": [
                    {"scenario": s.scenario, "truth": list(s.truth),
                     "estimate": list(s.estimate) if s.estimate else None,
                     "se_m2": s.se_m2, "fused_steps": s.fused_steps,
                     "detections": s.detections, "frames": s.frames}
                    for s in scores]}
                for lbl, scores in self.scores.items()},
            "best": self.best(),
        })


def rounded_doc(doc: Mapping[str, object]) -> dict[str, Json]:
    """A table's document with its floats rounded (non-finite: None)."""
    return {k: _rounded(v) for k, v in doc.items()}


def _rounded(obj: object) -> Json:
    if isinstance(obj, float):
        return round(obj, DECIMALS) if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _rounded(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_rounded(v) for v in obj]
    if obj is None or isinstance(obj, (bool, int, str)):
        return obj
    item = getattr(obj, "item", None)
    if item is not None:  # a numpy scalar: as the JSON writer would take it
        return _rounded(item())
    raise TypeError(f"cannot write {type(obj).__name__} to a table")


def score_paper_scenario(name: str, results: dict[str, Any]) -> ScenarioScore:
    """A scenario's Table 1 row from a replay's results."""
    fused = [f for f in results["fused"] if f.get("x_m") is not None]
    frames = results["frames"]
    estimate = None
    if fused:
        estimate = (float(np.mean([f["x_m"] for f in fused])),
                    float(np.mean([f["y_m"] for f in fused])))
    return ScenarioScore(
        scenario=name, truth=PAPER_TRUTH[name], estimate=estimate, fused_steps=len(fused),
        detections=sum(1 for f in frames if f.get("detection")), frames=len(frames))


def score_paper_scene(task: SceneTask[list[tuple[str, ScenarioScore]]],
                      replays: Replays) -> list[tuple[str, ScenarioScore]]:
    """A paper scenario's Table 1 row under each config: (config label, score)."""
    return [(config.label, score_paper_scenario(task.scenario, results))
            for config, results in replays]


def run_paper_suite(record: Recorder, workdir: Path, *, camera: str,
                    calibration: Path | None = None, seed: int = 0,
                    configs: Sequence[Config] = CONFIGS,
                    map_scenes: SceneMapper = serial_map,
                    pose_uncertainty: bool = False) -> PaperSuite:
    suite = PaperSuite(camera=camera,
                       calibration=calibration.name if calibration else "camera metadata")
    tasks = [SceneTask(score_paper_scene, name, seed, workdir / f"{name}-{camera}.mcap", record,
                       calibration, tuple(configs), pose_uncertainty)
             for name in PAPER_SCENARIOS]
    for scores in map_scenes(run_scene, tasks):
        for label, score in scores:
            suite.scores.setdefault(label, []).append(score)
    return suite


def _fmt(v: float | None, nd: int = 4) -> str:
    return "-" if v is None else f"{v:.{nd}f}"


def _xy(v: tuple[float, float] | None) -> str:
    return "-" if v is None else f"({v[0]:.4f}, {v[1]:.4f})"


def _se(v: float | None) -> str:
    return "-" if v is None else f"{v:.3g}"


def paper_markdown(suite: PaperSuite) -> str:
    """Table 1: the paper's row beside paper mode's and the best corrected configuration's,
    then the RMSE of every configuration."""
    best = suite.best()
    shown = [lbl for lbl in ("paper/mean", best) if lbl in suite.scores]
    lines = [f"Camera `{suite.camera}`, calibration: {suite.calibration}.", "",
             "| scenario | ball | paper's Table 1 | SE | "
             + " | ".join(f"ours, {lbl} | SE" for lbl in shown) + " |",
             "|---" * (4 + 2 * len(shown)) + "|"]
    for i, name in enumerate(PAPER_SCENARIOS):
        p = PAPER_TABLE1[name]
        row = [name, "({:g}, {:g})".format(*PAPER_TRUTH[name]),
               _xy((p["x_m"], p["y_m"])), f"{p['se_m2']:.3f}"]
        for lbl in shown:
            s = suite.scores[lbl][i]
            row += [_xy(s.estimate), _se(s.se_m2)]
        lines.append("| " + " | ".join(row) + " |")
    lines.append("| RMSE [m] | | | 0.383 | "
                 + " | ".join(f"| {_fmt(suite.rmse_m(lbl))}" for lbl in shown) + " |")
    lines += ["", "| estimator/fusion | RMSE over the 4 scenarios [m] |", "|---|---|",
              "| paper's Table 1 (as printed) | 0.383 |",
              "| paper's Table 1 (row 1's SE corrected, docs/method.md) | 0.311 |"]
    lines += [f"| {lbl} | {_fmt(suite.rmse_m(lbl))} |" for lbl in suite.scores]
    return "\n".join(lines) + "\n"


# --- the random suite ------------------------------------------------------------------------
@dataclass
class RandomSuite:
    camera: str
    calibration: str
    count: int
    seed: int
    robot_errors: list[tuple[float, float]] = field(default_factory=list)
    """(true range [m], error [m]) of every per-robot estimate (corrected estimator)."""
    robot_frames: list[tuple[float, bool]] = field(default_factory=list)
    """(true range [m], detected) of every image."""
    fused_errors: dict[str, list[float]] = field(default_factory=dict)
    """Fusion label -> per-scene error [m] of the scene's mean fused estimate, for the
    scenes whose ball is within 9 m of at least two robots."""
    dual_sight_scenes: int = 0

    def bands(self) -> list[dict[str, Any]]:
        out = []
        for lo, hi in DISTANCE_BANDS_M:
            errs = np.array([e for d, e in self.robot_errors if lo <= d < hi])
            seen = [det for d, det in self.robot_frames if lo <= d < hi]
            out.append({
                "band_m": [lo, hi if math.isfinite(hi) else None],
                "images": len(seen),
                "detection_rate": (sum(seen) / len(seen)) if seen else None,
                "estimates": len(errs),
                "median_m": float(np.median(errs)) if len(errs) else None,
                "p95_m": float(np.percentile(errs, 95)) if len(errs) else None,
                "max_m": float(errs.max()) if len(errs) else None,
            })
        return out

    def fused_stats(self) -> dict[str, dict[str, Any]]:
        out = {}
        for label, errs in self.fused_errors.items():
            e = np.array(errs)
            out[label] = {
                "scenes": len(e),
                "rmse_m": float(np.sqrt(np.mean(e**2))) if len(e) else None,
                "median_m": float(np.median(e)) if len(e) else None,
                "p95_m": float(np.percentile(e, 95)) if len(e) else None,
                "max_m": float(e.max()) if len(e) else None,
            }
        return out

    def to_dict(self) -> dict[str, Json]:
        return rounded_doc({
            "suite": "random", "camera": self.camera, "calibration": self.calibration,
            "count": self.count, "seed": self.seed,
            "dual_sight_scenes": self.dual_sight_scenes,
            "bands": self.bands(), "fused": self.fused_stats(),
        })


@dataclass(frozen=True)
class RandomScene:
    """What one random scene adds to the suite."""

    dual_sight: bool
    robot_errors: tuple[tuple[float, float], ...]
    robot_frames: tuple[tuple[float, bool], ...]
    fused_errors: tuple[tuple[str, float], ...]
    """(config label, error [m] of the scene's mean fused estimate), dual-sight scenes only."""


def score_random_scene(task: SceneTask[RandomScene], replays: Replays) -> RandomScene:
    dual_sight = False
    errors: list[tuple[float, float]] = []
    frames: list[tuple[float, bool]] = []
    fused_errors: list[tuple[str, float]] = []
    for config, res in replays:
        if config == task.configs[0]:  # which robots see the ball: the same for all
            dual_sight = _scene_has_dual_sight(res)
        if config == Config("corrected", "mean"):
            _collect_robot_errors(errors, frames, res)
        if dual_sight:
            fused = [f for f in res["fused"] if f.get("error_m") is not None]
            if fused:
                ex = float(np.mean([f["x_m"] - f["truth"]["x_m"] for f in fused]))
                ey = float(np.mean([f["y_m"] - f["truth"]["y_m"] for f in fused]))
                fused_errors.append((config.label, math.hypot(ex, ey)))
    return RandomScene(dual_sight, tuple(errors), tuple(frames), tuple(fused_errors))


def run_random_suite(record: Recorder, workdir: Path, *, camera: str, count: int, seed: int,
                     calibration: Path | None = None,
                     configs: Sequence[Config] = CONFIGS,
                     map_scenes: SceneMapper = serial_map,
                     pose_uncertainty: bool = False) -> RandomSuite:
    suite = RandomSuite(camera=camera,
                        calibration=calibration.name if calibration else "camera metadata",
                        count=count, seed=seed)
    tasks = [SceneTask(score_random_scene, "random", seed + i,
                       workdir / f"random-{seed + i}-{camera}.mcap", record, calibration,
                       tuple(configs), pose_uncertainty) for i in range(count)]
    for scene in map_scenes(run_scene, tasks):
        suite.dual_sight_scenes += int(scene.dual_sight)
        suite.robot_errors.extend(scene.robot_errors)
        suite.robot_frames.extend(scene.robot_frames)
        for label, err in scene.fused_errors:
            suite.fused_errors.setdefault(label, []).append(err)
    return suite


def _ranges(res: dict[str, Any]) -> list[tuple[dict[str, Any], float]]:
    """Each frame with a pose and a true ball, beside the robot's true range to the ball."""
    out = []
    for f in res["frames"]:
        pose, truth = f.get("pose"), f.get("truth")
        if pose is not None and truth is not None:
            out.append((f, math.hypot(truth["x_m"] - pose["x_m"], truth["y_m"] - pose["y_m"])))
    return out


def _scene_has_dual_sight(res: dict[str, Any]) -> bool:
    """True when at least two robots are within 9 m of the ball."""
    return len({f["robot"] for f, d in _ranges(res) if d <= DUAL_SIGHT_RANGE_M}) >= 2


def _collect_robot_errors(errors: list[tuple[float, float]], frames: list[tuple[float, bool]],
                          res: dict[str, Any]) -> None:
    for f, d in _ranges(res):
        frames.append((d, f.get("detection") is not None))
        if f.get("error_m") is not None:
            errors.append((d, float(f["error_m"])))


def random_markdown(suite: RandomSuite) -> str:
    lines = [f"Camera `{suite.camera}`, calibration: {suite.calibration}; {suite.count} "
             f"random scenes from seed {suite.seed}.", "",
             "Per-robot estimates (corrected estimator) by the robot's true range to the ball:",
             "", "| range [m] | images | detection rate | estimates | median [m] | p95 [m] | "
             "max [m] |", "|---|---|---|---|---|---|---|"]
    for b in suite.bands():
        lo, hi = b["band_m"]
        rng = f"{lo:g}-{hi:g}" if hi is not None else f">= {lo:g}"
        rate = "-" if b["detection_rate"] is None else f"{100 * b['detection_rate']:.1f}%"
        lines.append(f"| {rng} | {b['images']} | {rate} | {b['estimates']} | "
                     f"{_fmt(b['median_m'])} | {_fmt(b['p95_m'])} | {_fmt(b['max_m'])} |")
    fused_scenes = max((len(e) for e in suite.fused_errors.values()), default=0)
    missed = suite.dual_sight_scenes - fused_scenes
    lines += ["", f"Fused, over the {suite.dual_sight_scenes} scenes whose ball is within "
              f"{DUAL_SIGHT_RANGE_M:g} m of at least two robots"
              + (f" ({missed} of them with no estimate to fuse: every robot missed the "
                 "ball)" if missed else "") + ":", "",
              "| method | scenes | RMSE [m] | median [m] | p95 [m] | max [m] |",
              "|---|---|---|---|---|---|"]
    for label, s in suite.fused_stats().items():
        lines.append(f"| {label} | {s['scenes']} | {_fmt(s['rmse_m'])} | {_fmt(s['median_m'])} "
                     f"| {_fmt(s['p95_m'])} | {_fmt(s['max_m'])} |")
    return "\n".join(lines) + "\n"

