"""Results files made up for the comparison tests (the form of replay.sinks.results_json)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

ROBOTS = ("robot1", "robot2", "robot3")


def results_doc(errors: Sequence[float | None], *, sha: str = "a" * 64,
                log: str = "run.mcap", fusion: str = "mean",
                velocity: Sequence[float] | None = None,
                detected: Sequence[bool] | None = None, period_ns: int = 50_000_000,
                parts: dict[str, Any] | None = None) -> dict[str, Any]:
    """A results file with one fused step per error (None: no fused estimate) and one frame
    per robot and step (``detected``: per frame, robot-major within a step)."""
    fused, frames = [], []
    for i, e in enumerate(errors):
        step: dict[str, Any] = {"step": i, "stamp_ns": i * period_ns, "t_s": i * period_ns / 1e9,
                                "robots": [], "x_m": None if e is None else 0.0,
                                "y_m": None if e is None else 0.0,
                                "truth": {"x_m": 0.0, "y_m": 0.0}, "error_m": e}
        if velocity is not None:
            step["velocity_error_m_s"] = velocity[i]
        fused.append(step)
        for j, robot in enumerate(ROBOTS):
            k = i * len(ROBOTS) + j
            seen = True if detected is None else bool(detected[k])
            frames.append({"frame": k, "robot": robot, "stamp_ns": i * period_ns + j,
                           "detection": {"cx_px": 1.0} if seen else None})
    doc = {"format": "dsp-replay-results", "version": 1,
           "log": {"file": log, "sha256": sha, "robots": list(ROBOTS), "recovered": None},
           "options": {"method": "corrected", "fusion": fusion}, "frames": frames,
           "fused": fused, "summary": {}}
    if parts is not None:
        doc["parts"] = parts
    return doc


def write(path: Path, doc: dict[str, Any]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


def noisy_errors(seed: int, n: int, scale: float = 0.05) -> list[float]:
    rng = np.random.default_rng(seed)
    return [float(v) for v in np.abs(rng.normal(0.0, scale, n))]
