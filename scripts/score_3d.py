"""Score a replay's fused ball in 3-D: the estimates MCAP's Odometry (x, y, z) against the
log's ``/ground_truth/ball``, with the results file saying which robots saw the ball.

    dsp-replay LOG --out r.json --out-mcap est.mcap
    python scripts/score_3d.py LOG est.mcap r.json

A step counts as *seen by two* when two or more robots have an estimate within the last
60 ms of it (cameras in sync: at its stamp). Printed: the 2-D RMSE and largest error of the
replay's own summary; the 3-D RMSE **in flight** (true centre above 0.3 m, seen by two, the
lobs suite's rule) and on the ground (seen by one or more); how many steps seen by two are
more than 1 m off in 3-D, and the largest such error with its time.
"""

from __future__ import annotations

import bisect
import json
import math
import sys
from pathlib import Path

import numpy as np
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

FLIGHT_ABOVE_M = 0.3
SEEN_WITHIN_NS = 60_000_000


def _read(path: Path, topic: str) -> list[tuple[int, object]]:
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [(m.log_time, msg) for _s, _c, m, msg in reader.iter_decoded_messages(
            topics=[topic])]


def _position(msg: object) -> tuple[float, float, float]:
    pose = getattr(msg, "pose", None)
    p = pose.pose.position if hasattr(pose, "pose") else (
        pose.position if pose is not None else msg.point)  # type: ignore[attr-defined]
    return float(p.x), float(p.y), float(p.z)


def score(log: Path, estimates: Path, results: Path) -> dict[str, float | int]:
    truth = _read(log, "/ground_truth/ball")
    if not truth:
        raise ValueError(f"{log}: no /ground_truth/ball")
    tt = np.array([t for t, _ in truth], dtype=np.int64)
    tp = np.array([_position(m) for _, m in truth])
    odometry = _read(estimates, "/estimate/ball/odometry")
    doc = json.loads(results.read_text(encoding="utf-8"))
    est = sorted((f["stamp_ns"], f["robot"]) for f in doc["frames"]
                 if f.get("estimate") is not None)
    keys = [t for t, _ in est]
    flight, ground, two = [], [], []
    over, worst, worst_t = 0, 0.0, 0.0
    for t, msg in odometry:
        lo = bisect.bisect_left(keys, t - SEEN_WITHIN_NS)
        hi = bisect.bisect_right(keys, t)
        seen = len({r for _, r in est[lo:hi]}) if hi > lo and keys[hi - 1] == t else 0
        i = int(np.searchsorted(tt, t))
        if i >= len(tt):
            continue
        if tt[i] == t or i == 0:
            q = tp[i]
        else:
            w = (t - tt[i - 1]) / max(int(tt[i] - tt[i - 1]), 1)
            q = tp[i - 1] * (1 - w) + tp[i] * w
        e = math.dist(_position(msg), q)
        if q[2] > FLIGHT_ABOVE_M and seen >= 2:
            flight.append(e)
        elif q[2] <= FLIGHT_ABOVE_M and seen >= 1:
            ground.append(e)
        if seen >= 2:
            two.append(e)
            over += e > 1.0
            if e > worst:
                worst, worst_t = e, t / 1e9

    def rms(a: list[float]) -> float:
        return math.sqrt(sum(x * x for x in a) / len(a)) if a else math.nan

    fused = doc["summary"]["fused"]
    return {"rmse_2d_m": fused["rmse_m"] or math.nan, "max_2d_m": fused["max_error_m"] or math.nan,
            "flight_3d_m": rms(flight), "flight_steps": len(flight),
            "ground_3d_m": rms(ground), "ground_steps": len(ground),
            "seen_by_two_over_1m": over, "worst_seen_by_two_m": worst, "worst_t_s": worst_t}


def main(argv: list[str]) -> int:
    if len(argv) != 3:
        print("usage: python scripts/score_3d.py LOG ESTIMATES.mcap RESULTS.json", file=sys.stderr)
        return 2
    try:
        s = score(*(Path(a) for a in argv))
    except (OSError, ValueError, KeyError, TypeError) as err:
        print(f"score_3d.py: error: {err}", file=sys.stderr)
        return 1
    print(" ".join(f"{k}={v:.4f}" if isinstance(v, float) else f"{k}={v}" for k, v in s.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
