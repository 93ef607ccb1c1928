"""Where a replay's fused error comes from: each step's squared error put down to one cause.

    python scripts/error_causes.py LOG.mcap RESULTS.json [LOG.mcap RESULTS.json ...]

One Markdown row per results file (a ``dsp-replay --out`` of that log): its fused steps'
RMSE and the share of their summed squared error at steps of each cause, the first that
holds (the ball's height and velocity from the log's ground truth):

- **start-up**: within ``--startup`` seconds (0.5) of the first fused step;
- **in the air**: the ball's centre above R + 1 cm at the step or in the 0.1 s before it
  (a hop: robots place it farther out along their rays, the track lags its landing);
- **distractor**: an estimate more than 0.5 m off the ball that the track took in the last
  0.15 s (ten images);
- **kick**: the ball's true velocity changed by more than 1 m/s over the last 0.15 s;
- **other**.
"""

from __future__ import annotations

import argparse
import bisect
import json
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dsp import contract
from estimator.constants import BALL_RADIUS_M, NS_PER_S
from replay.errors import ReplayError
from replay.log import LogReader, TruthMessage

CAUSES = ("start-up", "in the air", "distractor", "kick", "other")
AIR_M = 0.01
"""The ball is in the air above R + this [m]."""
LOOK_BACK_NS = 150_000_000
"""How far back a taken distractor or a kick still counts [ns]."""
AIR_LAG_NS = 100_000_000
"""How long after the ball lands its hop still counts [ns]."""
OFF_M = 0.5
"""A taken estimate this far off the ball is a distractor [m]."""
KICK_M_S = 1.0

Truth = tuple[int, float, float, float]
"""(stamp [ns], z [m], vx, vy [m/s]) of the ball."""


@dataclass
class Causes:
    """A results file's fused steps against the ball's truth (module docstring)."""

    doc: dict[str, Any]
    truth: Sequence[Truth]
    startup_ns: int

    def __post_init__(self) -> None:
        self.stamps = [s for s, *_ in self.truth]
        self.frames: dict[int, list[dict[str, Any]]] = {}
        for frame in self.doc["frames"]:
            self.frames.setdefault(int(frame["stamp_ns"]), []).append(frame)
        self.steps = [i for i, s in enumerate(self.doc["fused"])
                      if s.get("error_m") is not None and not s.get("tick")]

    def _at(self, t_ns: int) -> Truth:
        return self.truth[min(bisect.bisect_left(self.stamps, t_ns), len(self.truth) - 1)]

    def of(self, i: int) -> str:
        """The cause of fused step ``i``'s error."""
        fused = self.doc["fused"]
        t = int(fused[i]["stamp_ns"])
        if t - int(fused[self.steps[0]]["stamp_ns"]) < self.startup_ns:
            return "start-up"
        if any(self._at(t - k)[1] > BALL_RADIUS_M + AIR_M
               for k in range(0, AIR_LAG_NS + 1, AIR_LAG_NS // 10)):
            return "in the air"
        for j in range(i, -1, -1):
            if t - int(fused[j]["stamp_ns"]) > LOOK_BACK_NS:
                break
            taken = fused[j].get("fused_robots") or ()
            if any(f["robot"] in taken and (f.get("error_m") or 0.0) > OFF_M
                   for f in self.frames.get(int(fused[j]["stamp_ns"]), ())):
                return "distractor"
        _, _, vx0, vy0 = self._at(t - LOOK_BACK_NS)
        _, _, vx1, vy1 = self._at(t)
        return "kick" if math.hypot(vx1 - vx0, vy1 - vy0) > KICK_M_S else "other"

    def shares(self) -> tuple[int, float, dict[str, float]]:
        """(steps, RMSE [m], each cause's share of the summed squared error)."""
        sums = {c: 0.0 for c in CAUSES}
        for i in self.steps:
            sums[self.of(i)] += float(self.doc["fused"][i]["error_m"]) ** 2
        total = sum(sums.values())
        n = len(self.steps)
        return n, math.sqrt(total / n) if n else 0.0, {
            c: v / total if total > 0 else 0.0 for c, v in sums.items()}


def read_truth(log: Path) -> list[Truth]:
    """The ball's true height and velocity over the log, in stamp order."""
    out = []
    with LogReader(log, truth_topic=contract.GT_BALL_TOPIC) as reader:
        for m in reader.messages():
            if isinstance(m, TruthMessage):
                out.append((m.stamp_ns, BALL_RADIUS_M if m.z_m is None else m.z_m,
                            m.vx_m_s or 0.0, m.vy_m_s or 0.0))
    return sorted(out)


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0], allow_abbrev=False)
    p.add_argument("pairs", nargs="+", metavar="LOG RESULTS")
    p.add_argument("--startup", type=float, default=0.5, metavar="S")
    args = p.parse_args(argv)
    if len(args.pairs) % 2:
        p.error("give each results file after its log")
    print("| results | steps | fused RMSE [m] | " + " | ".join(CAUSES) + " |")
    print("|---|---|---|" + "---|" * len(CAUSES))
    for log, results in zip(args.pairs[::2], args.pairs[1::2], strict=True):
        try:
            doc = json.loads(Path(results).read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            print(f"{results}: not a readable results file ({exc})", file=sys.stderr)
            return 1
        try:
            truth = read_truth(Path(log))
        except ReplayError as exc:
            print(exc, file=sys.stderr)
            return 1
        if not truth:
            print(f"{log}: no ground truth of the ball ({contract.GT_BALL_TOPIC})",
                  file=sys.stderr)
            return 1
        n, rmse, share = Causes(doc, truth, round(args.startup * NS_PER_S)).shares()
        print(f"| {results} | {n} | {rmse:.4f} | "
              + " | ".join(f"{100 * share[c]:.0f} %" for c in CAUSES) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
