"""``dsp-compare``'s report: one document, written as JSON, CSV and Markdown.

JSON (``format`` "dsp-compare", ``version`` 1)::

    {"a": {"source", "logs", "options", "parts"}, "b": {...},
     "differences": {name: [A's, B's]},     # options and estimator parts that differ
     "bootstrap": {"replicates", "seed", "confidence", "block"},
     "logs": [{"log", "sha256_a", "sha256_b", "steps", "frames",
               "unpaired": {"steps": [only A, only B], "frames": [...]},
               "metrics": {key: {"a", "b", "diff", "ci": [lo, hi] | null, "verdict"}}}],
     "total": {"logs", "steps", "frames", "metrics": {...}},
     "left_out": [log names only one run has]}

Floats are rounded as in the results files; nothing depends on the machine or the time
(sources are named as given), so the same inputs give the same bytes. The CSV has one row
per log and metric (``log`` = "total" last); the Markdown the totals, then every log.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from dsp.jsonio import Json
from replay.compare.bootstrap import CONFIDENCE, METRICS, MetricResult
from replay.compare.load import ResultsRun
from replay.compare.pairing import PairedLog
from replay.sinks.results_json import normalise

__all__ = ["FORMAT", "Report", "differences"]

FORMAT = "dsp-compare"
VERSION = 1


def _flat(prefix: str, value: Json) -> dict[str, Json]:
    if isinstance(value, dict):
        out: dict[str, Json] = {}
        for k, v in value.items():
            out.update(_flat(f"{prefix}.{k}" if prefix else str(k), v))
        return out
    return {prefix: value}


def _side(runs: Sequence[ResultsRun]) -> tuple[dict[str, Json], dict[str, Json]]:
    """The options and parts all of a run's files share (the first file's)."""
    return runs[0].options, runs[0].parts


def differences(a: Sequence[ResultsRun], b: Sequence[ResultsRun]) -> dict[str, list[Json]]:
    """Options and parts (``parts.fusion.version``, ...) whose values differ, A's and B's."""
    fa = {**_flat("", _side(a)[0]), **_flat("parts", _side(a)[1])}
    fb = {**_flat("", _side(b)[0]), **_flat("parts", _side(b)[1])}
    return {k: [fa.get(k), fb.get(k)] for k in sorted(fa.keys() | fb.keys())
            if fa.get(k) != fb.get(k)}


def _metric(r: MetricResult) -> dict[str, Json]:
    return {"a": r.a, "b": r.b, "diff": r.diff,
            "ci": None if r.ci is None else list(r.ci), "verdict": r.verdict}


@dataclass(frozen=True)
class Report:
    a_name: str
    b_name: str
    a: Sequence[ResultsRun]
    b: Sequence[ResultsRun]
    pairs: Sequence[PairedLog]
    results: Sequence[Mapping[str, MetricResult]]
    """Per pair, then the total."""
    left_out: Sequence[str]
    replicates: int
    seed: int

    @property
    def total(self) -> Mapping[str, MetricResult]:
        return self.results[-1]

    @property
    def worse(self) -> list[str]:
        """The metrics worse in total."""
        return [k for k, r in self.total.items() if r.verdict == "worse"]

    def to_dict(self) -> dict[str, Json]:
        logs: list[Json] = []
        for p, res in zip(self.pairs, self.results, strict=False):
            logs.append({"log": p.log, "sha256_a": p.a.sha256, "sha256_b": p.b.sha256,
                         "results_a": p.a.path.name, "results_b": p.b.path.name,
                         "steps": len(p.error_a), "frames": len(p.detected_a),
                         "unpaired": {"steps": list(p.unpaired_steps),
                                      "frames": list(p.unpaired_frames)},
                         "metrics": {k: _metric(r) for k, r in res.items()}})
        oa, pa = _side(self.a)
        ob, pb = _side(self.b)
        return {
            "format": FORMAT, "version": VERSION,
            "a": {"source": self.a_name, "logs": len(self.a), "options": oa, "parts": pa},
            "b": {"source": self.b_name, "logs": len(self.b), "options": ob, "parts": pb},
            "differences": {k: v for k, v in differences(self.a, self.b).items()},
            "bootstrap": {"replicates": self.replicates, "seed": self.seed,
                          "confidence": CONFIDENCE,
                          "block": "circular blocks of ceil(sqrt(n)) consecutive units"},
            "logs": logs,
            "total": {"logs": len(self.pairs), "steps": sum(len(p.error_a) for p in self.pairs),
                      "frames": sum(len(p.detected_a) for p in self.pairs),
                      "metrics": {k: _metric(r) for k, r in self.total.items()}},
            "left_out": list(self.left_out),
        }

    def to_json(self) -> str:
        return json.dumps(normalise(self.to_dict()), sort_keys=True, indent=2,
                          allow_nan=False) + "\n"

    def _rows(self) -> list[list[str]]:
        names = [p.log for p in self.pairs] + ["total"]
        rows = []
        for name, res in zip(names, self.results, strict=True):
            for m in METRICS:
                r = res[m.key]
                ci = ("", "") if r.ci is None else (_num(r.ci[0]), _num(r.ci[1]))
                rows.append([name, m.key, _num(r.a), _num(r.b), _num(r.diff), *ci, r.verdict])
        return rows

    def to_csv(self) -> str:
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["log", "metric", "a", "b", "b_minus_a", "ci_low", "ci_high", "verdict"])
        w.writerows(self._rows())
        return buf.getvalue()

    def to_markdown(self) -> str:
        diff = differences(self.a, self.b)
        what = ", ".join(f"{k}: {_show(v[0])} -> {_show(v[1])}" for k, v in diff.items())
        steps = sum(len(p.error_a) for p in self.pairs)
        frames = sum(len(p.detected_a) for p in self.pairs)
        lines = [f"A = {self.a_name}, B = {self.b_name}: {len(self.pairs)} logs paired, "
                 f"{steps} steps with a truth, {frames} frames.",
                 f"What differs: {what or 'no option, no part'}.", "",
                 f"| metric | A | B | B - A | {CONFIDENCE:.0%} interval | verdict (B) |",
                 "|---|---|---|---|---|---|"]
        for m in METRICS:
            r = self.total[m.key]
            lines.append(f"| {m.label} | {_num(r.a) or '-'} | {_num(r.b) or '-'} | "
                         f"{_num(r.diff) or '-'} | {_ci(r)} | {r.verdict} |")
        lines += ["", "Per log:", "", "| log | metric | A | B | B - A | interval | verdict |",
                  "|---|---|---|---|---|---|---|"]
        for row in self._rows()[:-len(METRICS)]:
            name, key, a, b, d, lo, hi, verdict = row
            ci = f"[{lo}, {hi}]" if lo else "-"
            lines.append(f"| {_cell(name)} | {key} | {a or '-'} | {b or '-'} | {d or '-'} | "
                         f"{ci} | {verdict} |")
        if self.left_out:
            lines += ["", "Left out (results in one run only): " + ", ".join(self.left_out)]
        lines += ["", f"Intervals: paired block bootstrap, {self.replicates} replicates, seed "
                  f"{self.seed}; a verdict says whether B is better or worse than A with "
                  "the whole interval on one side of 0."]
        return "\n".join(lines) + "\n"


def _num(v: float | None) -> str:
    n = normalise(v)
    return "" if n is None else repr(n)


def _ci(r: MetricResult) -> str:
    return "-" if r.ci is None else f"[{_num(r.ci[0])}, {_num(r.ci[1])}]"


def _show(v: Json) -> str:
    return json.dumps(v)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ") or "-"
