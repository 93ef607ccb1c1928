"""How much of a replay's error its robots' poses share, and the floor of what the ball can show.

    python scripts/shared_error.py RESULTS.json TRUE.json [RESULTS.json TRUE.json ...]

RESULTS is a ``dsp-replay --out`` of a log (any ``--localise``); TRUE the same log replayed
with its true poses (``--pose-topic '/ground_truth/{robot}/pose'``) and otherwise the same
options, which gives each frame's true pose and the fused error with exact poses. A robot
whose believed pose is off by (dx, dy) and dpsi reports a ball at b from its true pose p at
b + d, d = (dx, dy) + (R(dpsi) - I)(b - p): the yaw's part grows with the range.

The shared part: at each fused step, over the robots whose estimates the track took in the
last ``--window`` seconds (each robot's latest), the mean of their d weighted by the
localisation prior (``--sigma-m`` and ``--sigma-deg``, the realism preset's drifting bias,
by default: 1 / (sigma_m^2 + (range sigma_yaw)^2)).

The gauge, which is the floor: the ball hides less than that mean. Each robot's pose error
is three numbers (dx, dy, dpsi) that drift over seconds, so as the ball moves about a robot
its yaw's part and its position's part are told apart, and the robots' differences show
every part of their errors but one motion of all of them together: the whole picture
turned by one angle phi about the ball and shifted by one c (each robot's pose moved with
it: (dx, dy) += c + phi J (p - b), dpsi += phi), which moves every robot's ball by c and
changes no difference between them. With the prior W (1 / sigma_m^2, 1 / sigma_m^2,
1 / sigma_yaw^2 for each robot), what of the errors lies along that motion is the c of
(G' W G)^-1 G' W beta (beta the taken robots' pose errors stacked, G the motion's three
columns): the best any fusion that learns the poses from the ball can do is to leave it.
The robots' spread pins down part of a turn they share through their positions' prior, so
the gauge is in general below the shared mean (one robot alone: both are its own d). A
fusion that removed everything else would give the replay with the true poses moved by c
at each step: the floor of the fused RMSE from the ball alone.

One Markdown row per pair (and one of them all pooled): the fused steps scored, the replay's
fused RMSE, the RMSE of each taken frame's own d (per robot) and of each step's shared part,
from the believed poses and, when the replay corrected them (``--localise``), from the
corrected ones, and of each step's gauge |c|; then the true-pose replay's fused error plus
the believed poses' c at each step that both scored (the floor).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

Key = tuple[str, int]
"""(robot, stamp [ns]) of a frame."""


@dataclass(frozen=True)
class PoseError:
    """A frame's pose error (believed less true: dx, dy [m], dpsi [rad]) and its robot's
    true position [m]."""

    dx: float
    dy: float
    dpsi: float
    x_m: float
    y_m: float


def pose_error(pose: dict[str, Any], true_pose: dict[str, Any]) -> PoseError:
    return PoseError(float(pose["x_m"]) - float(true_pose["x_m"]),
                     float(pose["y_m"]) - float(true_pose["y_m"]),
                     math.remainder(float(pose["yaw_rad"]) - float(true_pose["yaw_rad"]),
                                    math.tau),
                     float(true_pose["x_m"]), float(true_pose["y_m"]))


@dataclass(frozen=True)
class Offset:
    """What a frame's pose error does to its ball: the offset d [m], the ball's range, and
    the pose error itself."""

    dx: float
    dy: float
    range_m: float
    error: PoseError


def offset(pose: dict[str, Any], true_pose: dict[str, Any], ball: dict[str, Any]) -> Offset:
    """The ball's offset from a pose error (module docstring)."""
    e = pose_error(pose, true_pose)
    bx = float(ball["x_m"]) - e.x_m
    by = float(ball["y_m"]) - e.y_m
    c, s = math.cos(e.dpsi), math.sin(e.dpsi)
    return Offset(e.dx + (c - 1.0) * bx - s * by, e.dy + s * bx + (c - 1.0) * by,
                  math.hypot(bx, by), e)


def gauge(errors: Sequence[PoseError], ball: tuple[float, float], *, sigma_m: float,
          sigma_rad: float) -> tuple[float, float]:
    """The shift c of the robots' ball that no comparison of their views shows (module
    docstring): the motion (c, phi about the ball) of all of them together that lies
    nearest their pose errors under the prior's weights."""
    bx, by = ball
    g = np.zeros((3 * len(errors), 3))
    beta = np.zeros(3 * len(errors))
    for i, e in enumerate(errors):
        g[3 * i:3 * i + 3] = [[1.0, 0.0, -(e.y_m - by)], [0.0, 1.0, e.x_m - bx],
                              [0.0, 0.0, 1.0]]
        beta[3 * i:3 * i + 3] = (e.dx, e.dy, e.dpsi)
    w = np.tile([sigma_m ** -2, sigma_m ** -2, sigma_rad ** -2], len(errors))
    gw = g.T * w
    c = np.linalg.solve(gw @ g, gw @ beta)
    return float(c[0]), float(c[1])


def _read(path: Path) -> dict[str, Any]:
    """A results file, read bounded as ``dsp-compare`` reads one."""
    from dsp.errors import InputError
    from dsp.textfile import read_text_file
    from replay.compare.load import MAX_RESULTS_BYTES, RESULTS_FORMAT

    text = read_text_file(path, MAX_RESULTS_BYTES, what="a results file")
    try:
        doc = json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise InputError(f"{path}: not JSON ({str(exc).splitlines()[0]})") from None
    if not (isinstance(doc, dict) and doc.get("format") == RESULTS_FORMAT
            and isinstance(doc.get("frames"), list) and isinstance(doc.get("fused"), list)):
        raise InputError(f"{path}: not a dsp-replay results file")
    return doc


def _rms(values: Iterable[float]) -> float:
    v = list(values)
    return math.sqrt(sum(x * x for x in v) / len(v)) if v else math.nan


@dataclass(frozen=True)
class Shares:
    """One replay's errors [m], each step's or taken frame's."""

    fused: list[float]
    own: dict[str, list[float]]
    """Per pose kind ("believed", "corrected"): each taken frame's |d|."""
    shared: dict[str, list[float]]
    """Per pose kind: each fused step's shared part."""
    gauge: dict[str, list[float]]
    """Per pose kind: each fused step's gauge |c|."""
    floor: list[float]
    """Each fused step's true-pose replay error moved by c (steps both scored)."""

    def row(self, name: str) -> str:
        cells = []
        for kind in ("believed", "corrected"):
            own, shared, gauge = self.own[kind], self.shared[kind], self.gauge[kind]
            cells.append(f"{_rms(own):.4f} / {_rms(shared):.4f} / {_rms(gauge):.4f}"
                         if own else "-")
        cells.append(f"{_rms(self.floor):.4f} ({len(self.floor)})" if self.floor else "-")
        return (f"| {name} | {len(self.fused)} | {_rms(self.fused):.4f} | "
                + " | ".join(cells) + " |")

    def __add__(self, other: Shares) -> Shares:
        return Shares(self.fused + other.fused,
                      {k: v + other.own[k] for k, v in self.own.items()},
                      {k: v + other.shared[k] for k, v in self.shared.items()},
                      {k: v + other.gauge[k] for k, v in self.gauge.items()},
                      self.floor + other.floor)


def shares(results: dict[str, Any], truth: dict[str, Any], *, window_ns: int,
           sigma_m: float, sigma_rad: float) -> Shares:
    """The module docstring's figures for one replay and its true-pose twin."""
    true_poses = {(f["robot"], int(f["stamp_ns"])): f["pose"] for f in truth["frames"]
                  if f.get("pose")}
    true_errors = {}
    for step in truth["fused"]:
        ball = step.get("truth")
        if not step.get("tick") and step.get("x_m") is not None and ball:
            true_errors[int(step["stamp_ns"])] = (float(step["x_m"]) - float(ball["x_m"]),
                                                 float(step["y_m"]) - float(ball["y_m"]))
    kinds: dict[str, dict[Key, Offset]] = {"believed": {}, "corrected": {}}
    by_stamp: dict[int, list[dict[str, Any]]] = {}
    for f in results["frames"]:
        key = (f["robot"], int(f["stamp_ns"]))
        by_stamp.setdefault(key[1], []).append(f)
        true_pose, ball = true_poses.get(key), f.get("truth")
        if true_pose is None or ball is None or not f.get("pose"):
            continue
        kinds["believed"][key] = offset(f["pose"], true_pose, ball)
        loc = f.get("localisation")
        if loc and loc.get("x_m") is not None:
            kinds["corrected"][key] = offset(loc, true_pose, ball)
    out = Shares([], {k: [] for k in kinds}, {k: [] for k in kinds}, {k: [] for k in kinds},
                 [])
    latest: dict[str, dict[str, tuple[int, Offset]]] = {k: {} for k in kinds}
    for step in results["fused"]:
        if step.get("tick") or step.get("error_m") is None:
            continue
        stamp = int(step["stamp_ns"])
        taken = step.get("fused_robots") or ()
        truth_now = step.get("truth")
        out.fused.append(float(step["error_m"]))
        for kind, offsets in kinds.items():
            for f in by_stamp.get(stamp, ()):
                d = offsets.get((f["robot"], stamp))
                if f["robot"] in taken and d is not None:
                    latest[kind][f["robot"]] = (stamp, d)
                    out.own[kind].append(math.hypot(d.dx, d.dy))
            now = [d for t, d in latest[kind].values() if stamp - t <= window_ns]
            if not now:
                continue
            w = [1.0 / (sigma_m ** 2 + (d.range_m * sigma_rad) ** 2) for d in now]
            total = sum(w)
            out.shared[kind].append(math.hypot(
                sum(wi * d.dx for wi, d in zip(w, now, strict=True)) / total,
                sum(wi * d.dy for wi, d in zip(w, now, strict=True)) / total))
            if not truth_now:
                continue
            ball = (float(truth_now["x_m"]), float(truth_now["y_m"]))
            cx, cy = gauge([d.error for d in now], ball, sigma_m=sigma_m, sigma_rad=sigma_rad)
            out.gauge[kind].append(math.hypot(cx, cy))
            true_error = true_errors.get(stamp)
            if kind == "believed" and true_error is not None:
                out.floor.append(math.hypot(true_error[0] + cx, true_error[1] + cy))
    return out


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0], allow_abbrev=False)
    p.add_argument("pairs", nargs="+", metavar="RESULTS TRUE")
    p.add_argument("--window", type=float, default=0.15, metavar="S",
                   help="a robot's last taken estimate counts this long [s] (0.15)")
    p.add_argument("--sigma-m", type=float, default=0.05, metavar="M",
                   help="the prior's position sigma [m] (0.05)")
    p.add_argument("--sigma-deg", type=float, default=1.0, metavar="DEG",
                   help="the prior's yaw sigma [deg] (1.0)")
    args = p.parse_args(argv)
    if len(args.pairs) % 2:
        p.error("give each results file with its true-pose replay after it")
    if not (args.window >= 0 and args.sigma_m > 0 and args.sigma_deg > 0):
        p.error("--window must be >= 0, --sigma-m and --sigma-deg > 0")
    rows, pooled = [], None
    for results, truth in zip(args.pairs[::2], args.pairs[1::2], strict=True):
        try:
            one = shares(_read(Path(results)), _read(Path(truth)),
                         window_ns=round(args.window * 1e9), sigma_m=args.sigma_m,
                         sigma_rad=math.radians(args.sigma_deg))
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            from dsp.errors import InputError

            raise InputError(f"{results} or {truth}: a frame or step lacks a field, or it is "
                             f"not a number ({exc!r})") from None
        rows.append(one.row(results))
        pooled = one if pooled is None else pooled + one
    if pooled is not None and len(rows) > 1:
        rows.append(pooled.row("all, pooled"))
    print("| results | steps | fused RMSE [m] | believed poses: per robot / shared / gauge [m] "
          "| corrected poses: per robot / shared / gauge [m] | "
          "floor: true-pose replay + gauge [m] (steps) |")
    print("|---|---|---|---|---|---|")
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    from dsp.cli import run_main

    sys.exit(run_main("shared_error.py", main))
