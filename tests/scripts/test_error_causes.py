"""scripts/error_causes.py: each fused step's squared error put down to its first cause."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("error_causes",
                                               ROOT / "scripts" / "error_causes.py")
assert _spec is not None and _spec.loader is not None
error_causes = importlib.util.module_from_spec(_spec)
sys.modules["error_causes"] = error_causes  # dataclasses look their module up by name
_spec.loader.exec_module(error_causes)

MS = 1_000_000
R = 0.11


def _doc(errors: list[float], frame_errors: list[float], taken: list[bool]) -> dict[str, Any]:
    """One robot's image every 50 ms, each a fused step with that error."""
    frames = [{"stamp_ns": k * 50 * MS, "robot": "robot1", "error_m": e}
              for k, e in enumerate(frame_errors)]
    fused = [{"stamp_ns": k * 50 * MS, "error_m": e, "fused_robots": ["robot1"] if t else []}
             for k, (e, t) in enumerate(zip(errors, taken, strict=True))]
    return {"frames": frames, "fused": fused}


def test_each_step_goes_to_the_first_cause_that_holds() -> None:
    # the ball: on the ground, kicked (1 -> 4 m/s) at 0.5 s, in the air 0.75-0.85 s
    truth = [(t * MS, R + (0.05 if 750 <= t <= 850 else 0.0), 1.0 if t < 500 else 4.0, 0.0)
             for t in range(0, 1500, 10)]
    errors = [0.3, 0.01, 0.01, 0.01, 0.01, 0.02, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01,
              0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01,
              0.01, 0.01, 0.01, 0.01]
    errors[10] = 0.1  # 0.5 s: the kick
    errors[16] = 0.2  # 0.8 s: in the air
    errors[17] = 0.2  # 0.85 s: just landed
    errors[24] = 0.4  # 1.2 s: a distractor taken at 1.1 s
    frame_errors = [0.01] * 30
    frame_errors[22] = 6.0
    taken = [True] * 30
    causes = error_causes.Causes(_doc(errors, frame_errors, taken), truth, 100 * MS)
    assert [causes.of(i) for i in (0, 1, 2, 10, 12, 16, 17, 19, 22, 24, 26)] == [
        "start-up", "start-up", "other", "kick", "kick", "in the air", "in the air", "in the air",
        "distractor", "distractor", "other"]
    n, rmse, share = causes.shares()
    total = sum(e * e for e in errors)
    assert n == 30 and rmse == pytest.approx((total / 30) ** 0.5)
    assert share["distractor"] == pytest.approx((0.4**2 + 3 * 0.01**2) / total)
    assert sum(share.values()) == pytest.approx(1.0)
    # a distractor the track refused is none of its error
    taken[22] = False
    refused = error_causes.Causes(_doc(errors, frame_errors, taken), truth, 100 * MS)
    assert refused.of(24) == "other"
