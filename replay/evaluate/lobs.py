"""The ``lobs`` suite: balls in the air, placed in 3-D by crossing the robots' rays.

Each seed records a ``lobs`` scene (:mod:`recorder.match`: every kick a lob, 20-50 deg,
6-10 m/s, 1-3 m high, bounces and rolling after) with the cameras in sync (``--camera-phase
sync``: the rays of one step are of one instant; rays of a ball that moved between two
images do not cross where it is), replays it with the corrected estimator and the
``triangulate`` fusion and, beside it, the ground-plane ``robust`` fusion, and scores every
fused step against the 3-D truth at its stamp:

- **in flight**: steps whose true height is above :data:`FLIGHT_ABOVE_M` and that two or
  more robots saw (their rays crossed): 3-D RMSE, the median of |z - z_true|, and how many
  of the steps in flight two robots saw;
- **on the ground**: steps whose true height is within :data:`GROUND_WITHIN_M` of the
  ball's radius: the 3-D RMSE;
- the ground-plane fusion on the same steps: its 3-D error with the ball assumed at z = R
  (expected: metres in flight);
- per robot: the RMSE of its own ground-plane estimates in flight.

With ``camera_phase="random"`` (free-running cameras, as in a match: ``dsp-eval``'s default)
the scenes are recorded so and only the ``ballistic`` fusion is replayed and scored, by the
rule of :mod:`replay.evaluate.lobs_free` (the table and JSON say which rule and why); with
no rate asked, one set of logs at each of :data:`FREE_RUNNING_RATES_HZ`
(:func:`lobs_rates`, :func:`lobs_sets_doc`, :func:`lobs_sets_markdown`).
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from dsp.jsonio import Json
from estimator.constants import BALL_RADIUS_M
from replay.evaluate.lobs_free import FREE_RUNNING_RULE, FREE_RUNNING_WHY, score_free_running
from replay.evaluate.lobs_track import LEAD_S, TrackScore, score_track, true_landings
from replay.evaluate.scenes import prepare_log
from replay.evaluate.suites import rounded_doc
from replay.options import ReplayOptions
from replay.runner import replay
from replay.sinks import ResultsCollector

__all__ = [
    "CAMERA_PHASES",
    "FLIGHT_ABOVE_M",
    "FREE_RUNNING_RATES_HZ",
    "GROUND_WITHIN_M",
    "SYNC_RATE_HZ",
    "LobsOptions",
    "LobsScore",
    "LobsSuite",
    "lobs_log_name",
    "lobs_markdown",
    "lobs_rates",
    "lobs_sets_doc",
    "lobs_sets_markdown",
    "run_lobs_suite",
    "score_lobs",
]

FLIGHT_ABOVE_M = 0.3
"""A step is in flight when the ball's centre is truly higher than this [m]."""
GROUND_WITHIN_M = 0.01
"""A step is on the ground when the true height is within this of the ball's radius [m]."""
CAMERA_PHASES = ("sync", "random")
"""The recorder's ``--camera-phase``: in sync or free-running (``dsp-eval``'s default)."""
SYNC_RATE_HZ = 10.0
"""The camera rate of a synchronised suite when none is asked [Hz]."""
FREE_RUNNING_RATES_HZ = (20.0, 40.0)
"""A free-running suite with no rate asked records a set of logs at each: a match's camera
rate, and twice it [Hz]."""


@dataclass(frozen=True)
class LobsOptions:
    camera: str = "ideal"
    duration_s: float = 4.0
    rate_hz: float = SYNC_RATE_HZ
    renderer: str = "auto"
    calibration: Path | None = None
    camera_phase: str = "sync"
    width_range: bool = False
    """Every replay with ``--width-range`` (a ball the blob's width shows in the air
    placed under itself, :mod:`estimator.width`); the logs are the same."""


def lobs_log_name(seed: int, options: LobsOptions) -> str:
    """The log's name: every option that changes the recording is in it."""
    o = options
    return f"lobs-{seed}-{o.camera_phase}-{o.camera}-{o.duration_s:g}s-r{o.rate_hz:g}.mcap"


def _record(path: Path, seed: int, o: LobsOptions) -> None:
    from recorder.omni import DEFAULT_FACE_PX  # lazy: replay alone needs no pybullet
    from recorder.record import RecordOptions, record

    record(path, RecordOptions(scenario="lobs", seed=seed, camera=o.camera, renderer=o.renderer,
                               camera_phase=o.camera_phase, duration_s=o.duration_s,
                               rate_hz=o.rate_hz, face_px=DEFAULT_FACE_PX))


@dataclass
class LobsScore:
    """Errors pooled over steps (and seeds)."""

    flight_3d: list[float] = field(default_factory=list)
    flight_z: list[float] = field(default_factory=list)
    flight_steps: int = 0
    """Steps in flight (with a truth), whether two robots saw them or not."""
    ground_3d: list[float] = field(default_factory=list)
    plane_flight_3d: list[float] = field(default_factory=list)
    """The ground-plane fusion on the steps of ``flight_3d``, at z = R."""
    plane_ground_3d: list[float] = field(default_factory=list)
    robots_flight: dict[str, list[float]] = field(default_factory=dict)
    track: TrackScore = field(default_factory=TrackScore)
    """The ``ballistic`` fusion's steps (:mod:`replay.evaluate.lobs_track`)."""

    def add(self, other: LobsScore) -> None:
        self.track.add(other.track)
        self.flight_3d += other.flight_3d
        self.flight_z += other.flight_z
        self.flight_steps += other.flight_steps
        self.ground_3d += other.ground_3d
        self.plane_flight_3d += other.plane_flight_3d
        self.plane_ground_3d += other.plane_ground_3d
        for robot, errs in other.robots_flight.items():
            self.robots_flight.setdefault(robot, []).extend(errs)

    def to_dict(self) -> dict[str, Json]:
        return {
            "flight": {"steps": self.flight_steps, "triangulated": len(self.flight_3d),
                       "rmse_3d_m": _rmse(self.flight_3d),
                       "median_abs_z_error_m": _median_abs(self.flight_z),
                       "ground_plane_rmse_3d_m": _rmse(self.plane_flight_3d)},
            "ground": {"steps": len(self.ground_3d), "rmse_3d_m": _rmse(self.ground_3d),
                       "ground_plane_rmse_3d_m": _rmse(self.plane_ground_3d)},
            "robots_flight_rmse_3d_m": {r: _rmse(e) for r, e in sorted(self.robots_flight.items())},
            "track": {"flight_rmse_3d_m": _rmse(self.track.flight_3d),
                      "landings": self.track.landings,
                      "landings_predicted": len(self.track.landing_errors),
                      "landing_median_error_m": _median_abs(self.track.landing_errors),
                      "landing_median_lead_s": _median_abs(self.track.landing_leads_s)},
        }


def _rmse(errors: Sequence[float]) -> float | None:
    return math.sqrt(sum(e * e for e in errors) / len(errors)) if errors else None


def _median_abs(errors: Sequence[float]) -> float | None:
    return statistics.median(abs(e) for e in errors) if errors else None


def _plane_error(step: dict[str, Any]) -> float | None:
    if step.get("error_m") is None or step.get("truth_z_m") is None:
        return None
    return math.hypot(float(step["error_m"]), BALL_RADIUS_M - float(step["truth_z_m"]))


def score_lobs(triangulated: Sequence[dict[str, Any]], plane: Sequence[dict[str, Any]],
               frames: Sequence[dict[str, Any]]) -> LobsScore:
    """One log's score from its results (``fused`` lists of the triangulate and ground-plane
    replays, step for step, and the frames)."""
    score = LobsScore()
    plane_at = {s["stamp_ns"]: s for s in plane}
    truth_z: dict[int, float] = {}
    for s in triangulated:
        z_true = s.get("truth_z_m")
        if z_true is None or s.get("truth") is None:
            continue
        truth_z[s["stamp_ns"]] = float(z_true)
        other = plane_at.get(s["stamp_ns"])
        plane_err = None if other is None else _plane_error(
            dict(other, truth_z_m=z_true))
        if z_true > FLIGHT_ABOVE_M:
            score.flight_steps += 1
            if s.get("triangulated") and s.get("error_3d_m") is not None:
                score.flight_3d.append(float(s["error_3d_m"]))
                score.flight_z.append(float(s["z_error_m"]))
                if plane_err is not None:
                    score.plane_flight_3d.append(plane_err)
        elif z_true - BALL_RADIUS_M < GROUND_WITHIN_M and s.get("error_3d_m") is not None:
            score.ground_3d.append(float(s["error_3d_m"]))
            if plane_err is not None:
                score.plane_ground_3d.append(plane_err)
    for fr in frames:
        z = truth_z.get(fr["stamp_ns"])
        if z is not None and z > FLIGHT_ABOVE_M and fr.get("error_m") is not None:
            score.robots_flight.setdefault(fr["robot"], []).append(
                math.hypot(float(fr["error_m"]), BALL_RADIUS_M - z))
    return score


def _replay(log: Path, fusion: str, calibration: Path | None,
            width_range: bool) -> ResultsCollector:
    collected = ResultsCollector()
    replay(log, ReplayOptions(method="corrected", fusion=fusion, calibration=calibration,
                              width_range=width_range or None, progress=False),
           sinks=[collected])
    return collected


def score_lobs_log(log: Path, calibration: Path | None = None,
                   camera_phase: str = "sync", *, width_range: bool = False) -> LobsScore:
    """Replay one lobs log with ``triangulate``, ``robust`` and ``ballistic`` (each with
    ``--width-range`` when asked); score it. Free-running cameras: ``ballistic`` alone, by
    :func:`score_free_running`."""
    if camera_phase != "sync":
        tracked = _replay(log, "ballistic", calibration, width_range)
        return LobsScore(track=score_free_running(
            tracked.fused, tracked.frames, true_landings(log, FLIGHT_ABOVE_M), FLIGHT_ABOVE_M))
    tri = _replay(log, "triangulate", calibration, width_range)
    plane = _replay(log, "robust", calibration, width_range)
    score = score_lobs(tri.fused, plane.fused, tri.frames)
    tracked = _replay(log, "ballistic", calibration, width_range)
    score.track = score_track(tracked.fused, true_landings(log, FLIGHT_ABOVE_M),
                              FLIGHT_ABOVE_M)
    return score


@dataclass
class LobsSuite:
    options: LobsOptions
    seeds: tuple[int, ...]
    per_seed: dict[int, LobsScore] = field(default_factory=dict)

    def pooled(self) -> LobsScore:
        out = LobsScore()
        for seed in self.seeds:
            out.add(self.per_seed[seed])
        return out

    @property
    def free_running(self) -> bool:
        return self.options.camera_phase != "sync"

    def to_dict(self) -> dict[str, Json]:
        score = _free_dict if self.free_running else LobsScore.to_dict
        doc: dict[str, Json] = {
            "suite": "lobs", "camera": self.options.camera,
            "duration_s": self.options.duration_s, "rate_hz": self.options.rate_hz,
            "seeds": list(self.seeds), "pooled": score(self.pooled()),
            "per_seed": {str(s): score(self.per_seed[s]) for s in self.seeds},
        }
        if self.options.width_range:  # only when asked: documents without it stay
            doc["width_range"] = True
        if self.free_running:  # the synchronised document stays as it was
            doc |= {"camera_phase": self.options.camera_phase,
                    "rule": FREE_RUNNING_RULE.format(above=FLIGHT_ABOVE_M),
                    "triangulate": FREE_RUNNING_WHY}
        return rounded_doc(doc)


def _free_dict(score: LobsScore) -> dict[str, Json]:
    """A free-running score: the ``ballistic`` fusion's alone (:mod:`lobs_free`)."""
    t = score.track
    return {"flight": {"steps": t.flight_steps, "seen_by_two": len(t.flight_3d),
                       "rmse_3d_m": _rmse(t.flight_3d),
                       "median_3d_error_m": _median_abs(t.flight_3d),
                       "median_abs_z_error_m": _median_abs(t.flight_z)},
            "track": {"landings": t.landings, "landings_predicted": len(t.landing_errors),
                      "landing_median_error_m": _median_abs(t.landing_errors),
                      "landing_median_lead_s": _median_abs(t.landing_leads_s)}}


def run_lobs_suite(out_dir: Path, options: LobsOptions, *, count: int, seed: int) -> LobsSuite:
    """Record (when missing) and score ``count`` lobs logs from ``seed`` on."""
    seeds = tuple(range(seed, seed + count))
    suite = LobsSuite(options, seeds)
    for s in seeds:
        log = out_dir / lobs_log_name(s, options)
        prepare_log(log, "lobs", s, lambda: _record(log, s, options))  # noqa: B023 (called here)
        suite.per_seed[s] = score_lobs_log(log, options.calibration, options.camera_phase,
                                           width_range=options.width_range)
    return suite


def lobs_rates(camera_phase: str, rate_hz: float | None) -> tuple[float, ...]:
    """The camera rates of the sets of logs: the one asked, else :data:`SYNC_RATE_HZ` in
    sync and :data:`FREE_RUNNING_RATES_HZ` free-running."""
    if rate_hz is not None:
        return (rate_hz,)
    return (SYNC_RATE_HZ,) if camera_phase == "sync" else FREE_RUNNING_RATES_HZ


def lobs_sets_doc(suites: Sequence[LobsSuite]) -> dict[str, Json]:
    """One set's document as it is; several sets' in a list, by rate."""
    if len(suites) == 1:
        return suites[0].to_dict()
    return {"suite": "lobs", "sets": [s.to_dict() for s in suites]}


def lobs_sets_markdown(suites: Sequence[LobsSuite]) -> str:
    """One set's tables as they are; several sets' each under its rate."""
    if len(suites) == 1:
        return lobs_markdown(suites[0])
    return "\n".join(f"### {s.options.rate_hz:g} Hz\n\n{lobs_markdown(s)}" for s in suites)


_WIDTH_NOTE = "; every replay with `--width-range` (a ball in the air by its blob's width)"


def _fmt(v: float | None) -> str:
    return "-" if v is None else f"{v:.3f}"


def lobs_markdown(suite: LobsSuite) -> str:
    if suite.free_running:
        return _free_markdown(suite)
    p = suite.pooled()
    d = p.to_dict()
    flight, ground = d["flight"], d["ground"]
    assert isinstance(flight, dict) and isinstance(ground, dict)
    seeds = ", ".join(str(s) for s in suite.seeds)
    lines = [
        f"Camera `{suite.options.camera}`, cameras in sync at {suite.options.rate_hz:g} Hz, "
        f"{suite.options.duration_s:g} s of lobs per seed; seeds {seeds}"
        f"{_WIDTH_NOTE if suite.options.width_range else ''}.", "",
        "| | steps | 3-D RMSE [m] | median abs z error [m] | ground-plane fusion, 3-D RMSE [m] |",
        "|---|---|---|---|---|",
        f"| in flight (z > {FLIGHT_ABOVE_M} m), two or more robots' rays crossed | "
        f"{len(p.flight_3d)} of {p.flight_steps} | {_fmt(_rmse(p.flight_3d))} | "
        f"{_fmt(_median_abs(p.flight_z))} | {_fmt(_rmse(p.plane_flight_3d))} |",
        f"| on the ground | {len(p.ground_3d)} | {_fmt(_rmse(p.ground_3d))} | | "
        f"{_fmt(_rmse(p.plane_ground_3d))} |",
    ]
    t = p.track
    lines.append(
        f"| `ballistic` (the tracker on those points) in flight | {len(t.flight_3d)} | "
        f"{_fmt(_rmse(t.flight_3d))} | | |")
    lines += ["", _landing_line(t)]
    robots = ", ".join(f"{r} {_fmt(_rmse(e))}" for r, e in sorted(p.robots_flight.items()))
    lines += ["", f"Each robot's own ground-plane estimates in flight, 3-D RMSE [m]: {robots}."]
    return "\n".join(lines) + "\n"


def _landing_line(t: TrackScore) -> str:
    return (f"Landing point predicted {LEAD_S:g} s ahead (median lead "
            f"{_fmt(_median_abs(t.landing_leads_s))} s): median error "
            f"{_fmt(_median_abs(t.landing_errors))} m over {len(t.landing_errors)} of "
            f"{t.landings} landings (the others: no prediction then).")


def _free_markdown(suite: LobsSuite) -> str:
    t = suite.pooled().track
    seeds = ", ".join(str(s) for s in suite.seeds)
    o = suite.options
    return "\n".join([
        f"Camera `{o.camera}`, free-running cameras (`--camera-phase {o.camera_phase}`: each "
        f"robot's at its own seeded phase) at {o.rate_hz:g} Hz, {o.duration_s:g} s of lobs "
        f"per seed; seeds {seeds}{_WIDTH_NOTE if o.width_range else ''}.", "",
        f"Scored: {FREE_RUNNING_RULE.format(above=FLIGHT_ABOVE_M)}. No `triangulate` rows: "
        f"{FREE_RUNNING_WHY}.", "",
        "| | steps | 3-D RMSE [m] | median 3-D error [m] | median abs z error [m] |",
        "|---|---|---|---|---|",
        f"| `ballistic` in flight (z > {FLIGHT_ABOVE_M} m), two or more robots within 0.1 s | "
        f"{len(t.flight_3d)} of {t.flight_steps} | {_fmt(_rmse(t.flight_3d))} | "
        f"{_fmt(_median_abs(t.flight_3d))} | {_fmt(_median_abs(t.flight_z))} |",
        "", _landing_line(t)]) + "\n"
