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

import functools
import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from replay.compare.pairing import PairedLog

__all__ = ["CONFIDENCE", "METRICS", "Metric", "MetricResult", "compare_logs",
           "weighted_quantile"]

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
    """``count`` circular block resamples of ``range(n)`` as multiplicities: (count, n), how
    many times each unit is drawn."""
    if n == 0:
        return np.zeros((count, 0))
    length = math.ceil(math.sqrt(n))
    k = math.ceil(n / length)
    starts = rng.integers(0, n, size=(count, k))
    idx = ((starts[:, :, None] + np.arange(length)[None, None, :]) % n).reshape(count, -1)
    flat = idx[:, :n] + (np.arange(count) * n)[:, None]
    return np.bincount(flat.ravel(), minlength=count * n).reshape(count, n).astype(np.float64)


def weighted_quantile(values: np.ndarray, weights: np.ndarray, q: float,
                      counts: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Per row of ``weights``, the q quantile of ``values`` (sorted, finite) each repeated
    as many times as its weight, as ``numpy.percentile`` of the repeated values (NaN: none).

    ``weights`` (R, m) may hold only the m largest values' weights (the last m columns) when
    ``counts`` gives the rows' whole weights: the quantile is counted from the top, so a high
    one needs only the tail. Also returns, per row, whether that tail reached it."""
    n = len(values)
    c = weights.sum(axis=1) if counts is None else counts
    if n == 0:
        return np.full(len(weights), np.nan), np.ones(len(weights), dtype=bool)
    pos = q * np.maximum(c - 1, 0)
    lo = np.floor(pos)
    hi = np.minimum(lo + 1, np.maximum(c - 1, 0))
    rc = np.cumsum(weights[:, ::-1], axis=1)  # counts from the largest value down
    # the first column whose count passes each rank from the top: one search in the rows
    # laid end to end, each row shifted past the one before (counts are whole numbers)
    shift = (rc[:, -1].max() + 1) * np.arange(len(rc))
    flat = (rc + shift[:, None]).ravel()
    base = np.arange(len(rc)) * rc.shape[1]
    last = rc.shape[1] - 1
    top_lo, top_hi = c - 1 - lo, c - 1 - hi
    p_lo = np.minimum(np.searchsorted(flat, top_lo + shift, side="right") - base, last)
    p_hi = np.minimum(np.searchsorted(flat, top_hi + shift, side="right") - base, last)
    w = pos - lo
    out = values[n - 1 - p_lo] * (1 - w) + values[n - 1 - p_hi] * w
    reached = (rc[:, -1] > top_lo) | (c == 0)
    return np.where(c > 0, out, np.nan), reached


def _p95(values: np.ndarray, gather: Callable[[int], np.ndarray],
         counts: np.ndarray) -> np.ndarray:
    """The 95th percentile from the tail of the weights (``gather(m)``: the m largest
    values' weights), the whole where a row's tail is too short."""
    n = len(values)
    out, reached = weighted_quantile(values, gather(min(n, n // 5 + 64)), 0.95, counts)
    if not reached.all():
        full, _ = weighted_quantile(values, gather(n), 0.95, counts)
        out = np.where(reached, out, full)
    return out


@dataclass
class _Sums:
    """One run's sums for a set of replicates (arrays of shape (R,))."""

    sq: np.ndarray
    n_err: np.ndarray
    n_steps: np.ndarray
    vsq: np.ndarray
    n_vel: np.ndarray
    det: np.ndarray
    n_frames: np.ndarray

    def __add__(self, o: _Sums) -> _Sums:
        return _Sums(self.sq + o.sq, self.n_err + o.n_err, self.n_steps + o.n_steps,
                     self.vsq + o.vsq, self.n_vel + o.n_vel, self.det + o.det,
                     self.n_frames + o.n_frames)

    def values(self, p95: np.ndarray) -> dict[str, np.ndarray]:
        with np.errstate(invalid="ignore", divide="ignore"):
            return {
                "rmse_m": np.sqrt(self.sq / self.n_err),
                "p95_m": p95,
                "fused_rate": self.n_err / self.n_steps,
                "detection_rate": self.det / self.n_frames,
                "velocity_rmse_m_s": np.sqrt(self.vsq / self.n_vel),
            }


@dataclass(frozen=True)
class _Side:
    """One run's paired units of one log, as vectors the multiplicities multiply."""

    sq: np.ndarray
    has: np.ndarray
    vsq: np.ndarray
    vhas: np.ndarray
    det: np.ndarray
    order: np.ndarray
    """The steps with an error, by error."""
    sorted_errors: np.ndarray

    @staticmethod
    def of(error: np.ndarray, velocity: np.ndarray, detected: np.ndarray) -> _Side:
        has, vhas = np.isfinite(error), np.isfinite(velocity)
        order = np.flatnonzero(has)[np.argsort(error[has], kind="stable")]
        return _Side(np.where(has, error * error, 0.0), has.astype(np.float64),
                     np.where(vhas, velocity * velocity, 0.0), vhas.astype(np.float64),
                     detected.astype(np.float64), order, error[order])

    def sums(self, steps: np.ndarray, frames: np.ndarray) -> _Sums:
        return _Sums(steps @ self.sq, steps @ self.has, steps.sum(axis=1), steps @ self.vsq,
                     steps @ self.vhas, frames @ self.det, frames.sum(axis=1))


@dataclass(frozen=True)
class _Pool:
    """The steps with an error of all logs, by error, for the pooled percentile."""

    values: np.ndarray
    log: np.ndarray
    unit: np.ndarray

    @staticmethod
    def of(sides: Sequence[_Side]) -> _Pool:
        values = np.concatenate([s.sorted_errors for s in sides])
        order = np.argsort(values, kind="stable")
        log = np.concatenate([np.full(len(s.order), i) for i, s in enumerate(sides)])
        unit = np.concatenate([s.order for s in sides])
        return _Pool(values[order], log[order].astype(np.intp), unit[order])

    def p95(self, steps: Sequence[np.ndarray], counts: np.ndarray) -> np.ndarray:
        def gather(m: int) -> np.ndarray:
            out = np.empty((len(counts), m))
            log, unit = self.log[len(self.log) - m:], self.unit[len(self.unit) - m:]
            for i, w in enumerate(steps):
                mask = log == i
                out[:, mask] = w[:, unit[mask]]
            return out

        return _p95(self.values, gather, counts)


def _tail(weights: np.ndarray, order: np.ndarray, m: int) -> np.ndarray:
    """The weights of the m largest errors (``order``: the units by error)."""
    return weights[:, order[len(order) - m:]]


def _replicates(sides: Sequence[tuple[_Side, _Side]], pools: tuple[_Pool, _Pool],
                steps: Sequence[np.ndarray],
                frames: Sequence[np.ndarray]) -> Iterator[dict[str, np.ndarray]]:
    """Per log, then the total: {"a.metric": (R,), "b.metric": (R,)} for these
    multiplicities."""
    totals: dict[int, _Sums] = {}
    for pair, ws, wf in zip(sides, steps, frames, strict=True):
        out: dict[str, np.ndarray] = {}
        for i, side in enumerate(pair):
            s = side.sums(ws, wf)
            totals[i] = totals[i] + s if i in totals else s
            p95 = _p95(side.sorted_errors, functools.partial(_tail, ws, side.order), s.n_err)
            for k, v in s.values(p95).items():
                out[f"{'ab'[i]}.{k}"] = v
        yield out
    total: dict[str, np.ndarray] = {}
    for i in (0, 1):
        p95 = pools[i].p95(steps, totals[i].n_err)
        for k, v in totals[i].values(p95).items():
            total[f"{'ab'[i]}.{k}"] = v
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
    sides = [(_Side.of(p.error_a, p.velocity_a, p.detected_a),
              _Side.of(p.error_b, p.velocity_b, p.detected_b)) for p in pairs]
    sizes = [(len(p.error_a), len(p.detected_a)) for p in pairs]
    pools = (_Pool.of([a for a, _ in sides]), _Pool.of([b for _, b in sides]))
    points = list(_replicates(sides, pools, [np.ones((1, n)) for n, _ in sizes],
                              [np.ones((1, m)) for _, m in sizes]))
    rngs = [(np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(i, 0))),
             np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(i, 1))))
            for i in range(len(pairs))]
    diffs: list[dict[str, list[np.ndarray]]] = [{m.key: [] for m in METRICS} for _ in points]
    done = 0
    while done < replicates:
        count = min(CHUNK, replicates - done)
        ws = [_blocks(rs, n, count) for (n, _), (rs, _) in zip(sizes, rngs, strict=True)]
        wf = [_blocks(rf, m, count) for (_, m), (_, rf) in zip(sizes, rngs, strict=True)]
        for slot, rep in zip(diffs, _replicates(sides, pools, ws, wf), strict=True):
            for m in METRICS:
                slot[m.key].append(rep[f"b.{m.key}"] - rep[f"a.{m.key}"])
        done += count
    return [{m.key: _result(m, point, np.concatenate(slot[m.key]))
             for m in METRICS} for point, slot in zip(points, diffs, strict=True)]
