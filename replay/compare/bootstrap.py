"""The metrics of two paired runs, their difference and its paired bootstrap interval.

Metrics (:data:`METRICS`), each for run A, run B and B - A, per log and in total:

- ``rmse_m``: the fused position error's RMSE over the paired steps (with a truth) where
  the run has a fused estimate; ``p95_m`` its 95th percentile (linear interpolation, as
  ``numpy.percentile``); ``fused_rate``: the share of paired steps with a fused estimate;
- ``detection_rate``: the share of paired frames with a detection;
- ``velocity_rmse_m_s``: the fused velocity error's RMSE, where both the estimate and the
  truth have a velocity (only ``--fusion track``, on logs with the ball's true velocity).

The interval is a paired, stratified, circular block bootstrap: every replicate resamples
each log's paired steps (and, apart, its paired frames) in blocks of ``ceil(sqrt(n))``
consecutive units (errors a few steps apart are not independent), the same indices for A
and B, and the totals pool the logs' replicates (the logs are fixed: the question is about
these logs). The interval is the 2.5 and 97.5 percentiles of the replicates' B - A. A
metric is ``better`` when the whole interval lies on B's good side of 0, ``worse`` on the
bad side, ``no difference`` otherwise, ``n/a`` when a run has no value. Replicates come from
``numpy.random.Generator`` s seeded by ``seed`` and the log's place, so the same inputs
give the same numbers, bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from replay.compare.pairing import PairedLog

__all__ = ["CONFIDENCE", "METRICS", "Metric", "MetricResult", "compare_logs"]

CONFIDENCE = 0.95
CHUNK = 100
"""Replicates computed at once (bounds memory: CHUNK x all paired units)."""


@dataclass(frozen=True)
class Metric:
    key: str
    label: str
    lower_is_better: bool


METRICS = (
    Metric("rmse_m", "fused RMSE [m]", True),
    Metric("p95_m", "fused p95 [m]", True),
    Metric("fused_rate", "steps with a fused estimate", False),
    Metric("detection_rate", "frames with a detection", False),
    Metric("velocity_rmse_m_s", "velocity RMSE [m/s]", True),
)


@dataclass(frozen=True)
class MetricResult:
    a: float | None
    b: float | None
    diff: float | None
    ci: tuple[float, float] | None
    verdict: str


def _blocks(rng: np.random.Generator, n: int, count: int) -> np.ndarray:
    """``count`` circular block resamples of ``range(n)``, shape (count, n)."""
    if n == 0:
        return np.zeros((count, 0), dtype=np.intp)
    length = math.ceil(math.sqrt(n))
    k = math.ceil(n / length)
    starts = rng.integers(0, n, size=(count, k))
    idx = (starts[:, :, None] + np.arange(length)[None, None, :]) % n
    return idx.reshape(count, k * length)[:, :n]


def _quantile(rows: np.ndarray, q: float) -> np.ndarray:
    """Per row, the q quantile of its finite values (NaN where none), as numpy.percentile."""
    s = np.sort(rows, axis=1)  # NaN last
    c = np.isfinite(s).sum(axis=1)
    pos = q * np.maximum(c - 1, 0)
    lo = np.floor(pos).astype(np.intp)
    hi = np.minimum(lo + 1, np.maximum(c - 1, 0))
    r = np.arange(len(s))
    if s.shape[1] == 0:
        return np.full(len(s), np.nan)
    w = pos - lo
    out = s[r, lo] * (1 - w) + s[r, hi] * w
    return np.where(c > 0, out, np.nan)


@dataclass
class _Sums:
    """One run's sums for a set of replicates (arrays of shape (R,))."""

    sq: np.ndarray
    n_err: np.ndarray
    n_steps: int
    vsq: np.ndarray
    n_vel: np.ndarray
    det: np.ndarray
    n_frames: int

    def __add__(self, o: _Sums) -> _Sums:
        return _Sums(self.sq + o.sq, self.n_err + o.n_err, self.n_steps + o.n_steps,
                     self.vsq + o.vsq, self.n_vel + o.n_vel, self.det + o.det,
                     self.n_frames + o.n_frames)

    def values(self, p95: np.ndarray) -> dict[str, np.ndarray]:
        with np.errstate(invalid="ignore", divide="ignore"):
            return {
                "rmse_m": np.sqrt(self.sq / self.n_err),
                "p95_m": p95,
                "fused_rate": self.n_err / self.n_steps if self.n_steps else _nan(self.sq),
                "detection_rate": (self.det / self.n_frames if self.n_frames
                                   else _nan(self.sq)),
                "velocity_rmse_m_s": np.sqrt(self.vsq / self.n_vel),
            }


def _nan(like: np.ndarray) -> np.ndarray:
    return np.full(like.shape, np.nan)


def _sums(error: np.ndarray, velocity: np.ndarray, detected: np.ndarray,
          steps: np.ndarray, frames: np.ndarray) -> tuple[_Sums, np.ndarray]:
    e, v = error[steps], velocity[steps]
    fe, fv = np.isfinite(e), np.isfinite(v)
    sums = _Sums(np.where(fe, e * e, 0.0).sum(axis=1), fe.sum(axis=1), steps.shape[1],
                 np.where(fv, v * v, 0.0).sum(axis=1), fv.sum(axis=1),
                 detected[frames].sum(axis=1), frames.shape[1])
    return sums, e


def _replicates(pairs: Sequence[PairedLog], steps: Sequence[np.ndarray],
                frames: Sequence[np.ndarray]) -> Iterator[dict[str, np.ndarray]]:
    """Per log, then the total: {"a.metric": (R,), "b.metric": (R,)} for these indices."""
    totals: dict[str, _Sums] = {}
    rows: dict[str, list[np.ndarray]] = {"a": [], "b": []}
    for pair, si, fi in zip(pairs, steps, frames, strict=True):
        out: dict[str, np.ndarray] = {}
        for side in ("a", "b"):
            s, e = _sums(getattr(pair, f"error_{side}"), getattr(pair, f"velocity_{side}"),
                         getattr(pair, f"detected_{side}"), si, fi)
            totals[side] = totals[side] + s if side in totals else s
            rows[side].append(e)
            for k, v in s.values(_quantile(e, 0.95)).items():
                out[f"{side}.{k}"] = v
        yield out
    total: dict[str, np.ndarray] = {}
    for side in ("a", "b"):
        p95 = _quantile(np.concatenate(rows[side], axis=1), 0.95)
        for k, v in totals[side].values(p95).items():
            total[f"{side}.{k}"] = v
    yield total


def _verdict(m: Metric, ci: tuple[float, float] | None) -> str:
    if ci is None:
        return "n/a"
    lo, hi = ci
    good, bad = (hi < 0, lo > 0) if m.lower_is_better else (lo > 0, hi < 0)
    return "better" if good else "worse" if bad else "no difference"


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _result(m: Metric, point: dict[str, np.ndarray], reps: np.ndarray) -> MetricResult:
    a, b = _finite(point[f"a.{m.key}"][0]), _finite(point[f"b.{m.key}"][0])
    if a is None or b is None:
        return MetricResult(a, b, None, None, "n/a")
    diffs = reps[np.isfinite(reps)]
    if len(diffs) == 0:
        return MetricResult(a, b, b - a, None, "n/a")
    tail = 100 * (1 - CONFIDENCE) / 2
    lo, hi = np.percentile(diffs, [tail, 100 - tail])
    ci = (float(lo), float(hi))
    return MetricResult(a, b, b - a, ci, _verdict(m, ci))


def compare_logs(pairs: Sequence[PairedLog], *, replicates: int = 1000,
                 seed: int = 0) -> list[dict[str, MetricResult]]:
    """Per paired log (in order), then the total: metric key -> result."""
    full_s = [np.arange(len(p.error_a))[None, :] for p in pairs]
    full_f = [np.arange(len(p.detected_a))[None, :] for p in pairs]
    points = list(_replicates(pairs, full_s, full_f))
    rngs = [(np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(i, 0))),
             np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(i, 1))))
            for i in range(len(pairs))]
    diffs: list[dict[str, list[np.ndarray]]] = [{m.key: [] for m in METRICS} for _ in points]
    done = 0
    while done < replicates:
        count = min(CHUNK, replicates - done)
        si = [_blocks(rs, len(p.error_a), count) for p, (rs, _) in zip(pairs, rngs, strict=True)]
        fi = [_blocks(rf, len(p.detected_a), count)
              for p, (_, rf) in zip(pairs, rngs, strict=True)]
        for slot, rep in zip(diffs, _replicates(pairs, si, fi), strict=True):
            for m in METRICS:
                slot[m.key].append(rep[f"b.{m.key}"] - rep[f"a.{m.key}"])
        done += count
    return [{m.key: _result(m, point, np.concatenate(slot[m.key]) if slot[m.key]
                            else np.zeros(0))
             for m in METRICS} for point, slot in zip(points, diffs, strict=True)]
