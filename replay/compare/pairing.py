"""Pairing two runs: their logs (by the log's sha256), then each log's frames and steps.

Logs pair by the sha256 in the results header: a run of other logs is refused unless
``allow_different_logs``, which pairs them by the log's file name instead (and two single
files with each other). Within a pair of results of one log, frames pair by ``(stamp_ns,
robot)`` and fused steps by ``(stamp_ns, tick)``, in stamp order; what only one run has is
counted (``unpaired``), not scored. Steps are kept only when they have a truth.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from dsp.errors import InputError
from replay.compare.load import ResultsRun, StepScore

__all__ = ["PairedLog", "pair_runs"]


@dataclass(frozen=True)
class PairedLog:
    """One log's two results, as aligned arrays (NaN: no value in that run)."""

    log: str
    a: ResultsRun
    b: ResultsRun
    error_a: np.ndarray
    error_b: np.ndarray
    """Fused position error per paired step [m]."""
    velocity_a: np.ndarray
    velocity_b: np.ndarray
    """Fused velocity error per paired step [m/s]."""
    detected_a: np.ndarray
    detected_b: np.ndarray
    """Per paired frame (bool)."""
    unpaired_steps: tuple[int, int]
    """Steps with a truth only A has, only B has."""
    unpaired_frames: tuple[int, int]

    @property
    def same_log(self) -> bool:
        return self.a.sha256 == self.b.sha256


def _value(s: StepScore, velocity: bool) -> float:
    v = s.velocity_error_m_s if velocity else s.error_m
    return np.nan if v is None else v


def _pair(a: ResultsRun, b: ResultsRun) -> PairedLog:
    steps = sorted(a.steps.keys() & b.steps.keys())
    frames = sorted(a.frames.keys() & b.frames.keys())

    def col(run: ResultsRun, velocity: bool) -> np.ndarray:
        return np.array([_value(run.steps[k], velocity) for k in steps], dtype=np.float64)

    return PairedLog(
        a.log_file if a.log_file == b.log_file else f"{a.log_file} / {b.log_file}", a, b,
        col(a, False), col(b, False), col(a, True), col(b, True),
        np.array([a.frames[k] for k in frames], dtype=bool),
        np.array([b.frames[k] for k in frames], dtype=bool),
        (len(a.steps) - len(steps), len(b.steps) - len(steps)),
        (len(a.frames) - len(frames), len(b.frames) - len(frames)))


def _by(runs: Sequence[ResultsRun], source: str, *, key: str) -> dict[str, ResultsRun]:
    out: dict[str, ResultsRun] = {}
    for run in runs:
        k = run.sha256 if key == "sha256" else run.log_file
        if k in out:
            raise InputError(f"{run.path}: {source} holds two results of the log "
                             f"{run.log_file} (also {out[k].path.name}); compare one of them")
        out[k] = run
    return out


def pair_runs(a: Sequence[ResultsRun], b: Sequence[ResultsRun], *, a_name: str, b_name: str,
              allow_different_logs: bool = False) -> tuple[list[PairedLog], list[str]]:
    """The paired logs (by log name) and the logs left out (only with
    ``allow_different_logs``: logs one run has and the other has not)."""
    if len(a) == 1 and len(b) == 1:
        ra, rb = a[0], b[0]
        if ra.sha256 != rb.sha256 and not allow_different_logs:
            raise InputError(f"{rb.path}: results of another log than {ra.path} ({rb.log_file} "
                             f"sha256 {rb.sha256[:12]}..., {ra.log_file} {ra.sha256[:12]}...): "
                             "give --allow-different-logs to compare them anyway")
        return [_pair(ra, rb)], []
    key = "log_file" if allow_different_logs else "sha256"
    by_a, by_b = _by(a, a_name, key=key), _by(b, b_name, key=key)
    if not allow_different_logs:
        for mine, theirs, name in ((by_a, by_b, b_name), (by_b, by_a, a_name)):
            for k, run in mine.items():
                if k not in theirs:
                    raise InputError(
                        f"{run.path}: {name} has no results of its log {run.log_file} "
                        f"(sha256 {k[:12]}...): give --allow-different-logs to compare the "
                        "logs both hold")
    pairs = [_pair(by_a[k], by_b[k]) for k in by_a if k in by_b]
    if not pairs:
        raise InputError(f"{b_name}: no log in common with {a_name}")
    left = sorted({r.log_file for k, r in (*by_a.items(), *by_b.items())
                   if k not in by_a or k not in by_b})
    return sorted(pairs, key=lambda p: (p.log, p.a.sha256)), left
