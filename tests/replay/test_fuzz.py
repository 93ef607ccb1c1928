"""A bounded, seeded fuzz run (the long campaign is ``scripts/fuzz_replay.py``): mutated golden
logs never cost a traceback, a hang, a silently wrong result or 1 GiB of memory, and the cases
that say what they must give (the frames before a cut with ``--recover``, fused steps despite
far or reversed stamps) give it."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _campaign_module():  # type: ignore[no-untyped-def]
    path = ROOT / "scripts" / "fuzz_replay.py"
    spec = importlib.util.spec_from_file_location("fuzz_replay", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["fuzz_replay"] = module
    spec.loader.exec_module(module)
    return module


def test_bounded_fuzz_run() -> None:
    fr = _campaign_module()
    report = fr.campaign(150, seed=20261122, timeout_s=30.0)
    total = report["total"]
    assert total["cases"] == 150
    assert not fr.failed(report), fr.format_report(report) + "\n" + "\n".join(
        f"{f['kind']} ({f['what']}): {f['status']}: {f['message']}" for f in report["findings"])
    # the run exercised every kind, and most cases ended in a one-line error
    assert set(report["by_kind"]) >= {"flip_any", "flip_chunk", "truncate", "length", "summary",
                                      "image", "pose", "stamps", "salvage", "far_stamps"}
    assert total.get("error", 0) > total["cases"] // 3
