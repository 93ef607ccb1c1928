"""docs/foxglove-layout.json: what scripts/make_foxglove_layout.py writes, four camera
panels on the contract's image topics, a 3-D panel with /tf, plots of topics that exist."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path
from typing import Any

from dsp import contract
from replay.sinks.estimates_mcap import FUSED_TOPIC, ROBOT_TOPIC

ROOT = Path(__file__).resolve().parents[2]
LAYOUT = ROOT / "docs" / "foxglove-layout.json"


def _script() -> Any:
    spec = importlib.util.spec_from_file_location("make_foxglove_layout",
                                                  ROOT / "scripts" / "make_foxglove_layout.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _leaves(node: Any) -> list[str]:
    if isinstance(node, str):
        return [node]
    return _leaves(node["first"]) + _leaves(node["second"])


def test_the_file_is_the_scripts() -> None:
    doc = json.loads(LAYOUT.read_text(encoding="utf-8"))
    assert doc == _script().layout()


def test_panels_and_topics() -> None:
    doc = json.loads(LAYOUT.read_text(encoding="utf-8"))
    config = doc["configById"]
    assert sorted(_leaves(doc["layout"])) == sorted(config)  # every panel placed, once
    images = [c["imageMode"]["imageTopic"] for k, c in config.items() if k.startswith("Image!")]
    assert images == [contract.topic_for(contract.IMAGE_TOPIC, f"robot{i}") for i in (1, 2, 3, 4)]
    (three_d,) = [c for k, c in config.items() if k.startswith("3D!")]
    assert three_d["topics"][contract.TF_TOPIC]["visible"] and three_d["followTf"] == "field"
    known = {contract.GT_BALL_TOPIC, FUSED_TOPIC, contract.ESTIMATE_TOPIC,
             *(contract.topic_for(ROBOT_TOPIC, f"robot{i}") for i in (1, 2, 3))}
    plots = [p["value"] for k, c in config.items() if k.startswith("Plot!") for p in c["paths"]]
    assert len(plots) >= 4
    for path in plots:
        topic = path.split(".")[0]
        assert topic in known, path
