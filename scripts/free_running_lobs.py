"""The ``ballistic`` fusion on lobs with free-running cameras: 3-D error in flight.

``dsp-eval --suite lobs`` records its scenes with the cameras in sync (every step's rays of
one instant). This records the same scenes (``--scenario lobs``, ideal camera, 4 s, 10 Hz)
with ``--camera-phase random`` (each robot's camera at its own seeded phase, as in a match),
replays each with ``--fusion ballistic`` and scores every fused step whose ball is truly in
flight (centre above 0.3 m) and that two or more robots saw within the last camera period
(0.1 s: one image each, at their own stamps), against the 3-D truth at the step's stamp.
Its steps are not the suite's (those count rays crossed at one instant, which free-running
cameras never give); it also scores the suite's landings (0.3 s ahead)::

    python scripts/free_running_lobs.py --seeds 300 301 302 --out-dir eval/free
    python scripts/free_running_lobs.py --logs eval/free/lobs-300-random.mcap   # no recording

Logs already in ``--out-dir`` are reused. Output: one line per log and the pooled figures.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
from pathlib import Path

FLIGHT_ABOVE_M = 0.3
SEEN_WITHIN_NS = 100_000_000


def record(seed: int, out_dir: Path) -> Path:
    from recorder.omni import DEFAULT_FACE_PX
    from recorder.record import RecordOptions
    from recorder.record import record as record_log

    path = out_dir / f"lobs-{seed}-random.mcap"
    if not path.exists():
        out_dir.mkdir(parents=True, exist_ok=True)
        record_log(path, RecordOptions(scenario="lobs", seed=seed, camera="ideal",
                                       renderer="auto", camera_phase="random", duration_s=4.0,
                                       rate_hz=10.0, face_px=DEFAULT_FACE_PX))
    return path


def score(log: Path) -> tuple[list[float], list[float], list[float], list[float]]:
    """(3-D errors, landing errors, landing leads, z errors) of one log."""
    from replay.evaluate.lobs_track import score_track, true_landings
    from replay.options import ReplayOptions
    from replay.runner import replay
    from replay.sinks import ResultsCollector

    c = ResultsCollector()
    replay(log, ReplayOptions(method="corrected", fusion="ballistic", progress=False),
           sinks=[c])
    seen = [(f["stamp_ns"], f["robot"]) for f in c.frames if f["status"] == "ok"]
    errors, z_errors = [], []
    for s in c.fused:
        z = s.get("truth_z_m")
        if z is None or z <= FLIGHT_ABOVE_M or s.get("error_3d_m") is None:
            continue
        t = s["stamp_ns"]
        if len({r for st, r in seen if t - SEEN_WITHIN_NS < st <= t}) >= 2:
            errors.append(float(s["error_3d_m"]))
            z_errors.append(abs(float(s["z_m"]) - z))
    track = score_track(c.fused, true_landings(log, FLIGHT_ABOVE_M), FLIGHT_ABOVE_M)
    return errors, track.landing_errors, track.landing_leads_s, z_errors


def _line(name: str, errors: list[float], landings: list[float], n_landings: int) -> str:
    rmse = math.sqrt(sum(e * e for e in errors) / len(errors)) if errors else math.nan
    med = statistics.median(errors) if errors else math.nan
    land = statistics.median(landings) if landings else math.nan
    return (f"{name}: in flight, 2+ robots: {len(errors)} steps, 3-D RMSE {rmse:.3f} m, "
            f"median {med:.3f} m; landings predicted {len(landings)}/{n_landings}, "
            f"median error {land:.3f} m")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--seeds", type=int, nargs="*", default=[])
    p.add_argument("--logs", type=Path, nargs="*", default=[])
    p.add_argument("--out-dir", type=Path, default=Path("eval/free-running-lobs"))
    args = p.parse_args(argv)
    logs = [record(seed, args.out_dir) for seed in args.seeds] + list(args.logs)
    for log in logs:
        if not log.is_file():
            print(f"free_running_lobs: {log}: no such log", file=sys.stderr)
            return 2
    from replay.evaluate.lobs_track import true_landings

    pooled: list[float] = []
    landings: list[float] = []
    n_landings = 0
    for log in logs:
        errors, land, _, _ = score(log)
        n = len(true_landings(log, FLIGHT_ABOVE_M))
        print(_line(log.name, errors, land, n))
        pooled += errors
        landings += land
        n_landings += n
    print(_line("pooled", pooled, landings, n_landings))
    return 0


if __name__ == "__main__":
    sys.exit(main())
