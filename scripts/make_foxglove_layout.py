"""Write docs/foxglove-layout.json: a Foxglove layout for the project's logs.

    python scripts/make_foxglove_layout.py [-o docs/foxglove-layout.json]

Four image panels (robot1..robot4's omni cameras, the contract's image topic), a 3-D panel
following the ``field`` frame with ``/tf`` and the balls (true, fused), and two plots of the
estimates against the truth (x and y over time, by the messages' header stamps, so a log and
its ``dsp-replay --out-mcap`` estimates opened together line up). The topics come from
``dsp.contract`` and the estimates sink, so the layout follows them.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from dsp import contract
from replay.sinks.estimates_mcap import ROBOT_TOPIC

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = ("robot1", "robot2", "robot3", "robot4")


def _image(robot: str) -> dict[str, Any]:
    return {"imageMode": {"imageTopic": contract.topic_for(contract.IMAGE_TOPIC, robot)},
            "foxglovePanelTitle": f"{robot} camera"}


def _plot(axis: str) -> dict[str, Any]:
    paths = [(f"{contract.ESTIMATE_TOPIC}.pose.pose.position.{axis}", "fused"),
             (f"{contract.GT_BALL_TOPIC}.pose.position.{axis}", "truth"),
             *((f"{contract.topic_for(ROBOT_TOPIC, r)}.point.{axis}", r) for r in ROBOTS[:3])]
    return {"paths": [{"value": v, "label": label, "enabled": True,
                       "timestampMethod": "headerStamp"} for v, label in paths],
            "showLegend": True, "legendDisplay": "floating", "xAxisVal": "timestamp",
            "foxglovePanelTitle": f"ball {axis} [m]: estimates and truth"}


def layout() -> dict[str, Any]:
    config: dict[str, Any] = {f"Image!{r}": _image(r) for r in ROBOTS}
    config["3D!field"] = {
        "followTf": "field", "followMode": "follow-pose",
        "topics": {contract.TF_TOPIC: {"visible": True},
                   contract.GT_BALL_TOPIC: {"visible": True},
                   contract.ESTIMATE_TOPIC: {"visible": True},
                   contract.ESTIMATE_ODOMETRY_TOPIC: {"visible": True},
                   contract.ESTIMATE_LANDING_TOPIC: {"visible": True}},
        "transforms": {"showLabel": True},
        "layers": {"grid": {"layerId": "foxglove.Grid", "visible": True, "frameId": "field",
                            "size": 22, "divisions": 22}},
        "cameraState": {"perspective": False, "distance": 25, "phi": 0, "thetaOffset": 0,
                        "target": [0, 0, 0], "targetOffset": [0, 0, 0]},
        "foxglovePanelTitle": "field (/tf)"}
    config["Plot!x"] = _plot("x")
    config["Plot!y"] = _plot("y")
    images = {"direction": "column",
              "first": {"direction": "row", "first": "Image!robot1", "second": "Image!robot2"},
              "second": {"direction": "row", "first": "Image!robot3", "second": "Image!robot4"}}
    right = {"direction": "column", "first": "3D!field", "splitPercentage": 60,
             "second": {"direction": "row", "first": "Plot!x", "second": "Plot!y"}}
    return {"configById": config, "globalVariables": {}, "userNodes": {},
            "playbackConfig": {"speed": 1},
            "layout": {"direction": "row", "first": images, "second": right,
                       "splitPercentage": 45}}


def main() -> None:
    p = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    p.add_argument("-o", type=Path, default=ROOT / "docs" / "foxglove-layout.json")
    args = p.parse_args()
    args.o.write_text(json.dumps(layout(), indent=2, sort_keys=True) + "\n", encoding="utf-8")
    print(f"wrote {args.o}")


if __name__ == "__main__":
    main()
