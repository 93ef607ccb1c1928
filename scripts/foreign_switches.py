"""The default beside the switches the tool offers, on the logs of ``dsp-eval --suite foreign``.

::

    python scripts/foreign_switches.py OUT_DIR [--set report|tune|check] [--workers 2]
                                       [--default-only]

Draws the suite's ten logs of a seed set into ``OUT_DIR/foreign`` (where ``dsp-eval --suite
foreign --out-dir OUT_DIR`` draws them, so a run of either reuses the other's logs), replays
each with no switches and with each of :data:`VARIANTS`, and prints, per log, each
variant's RMSE while the ball is on the ground (the suite's own: its centre below
``GROUND_Z_M``), its ratio to the best of them, and the fused velocity's median error. The
``tune`` set is what defaults may be chosen on; the ``report`` set is what they are
reported on. ``--default-only``: the default alone, its RMSE over every step, with the ball
on the ground and in the air (pooled over the set's steps too).
"""

from __future__ import annotations

import argparse
import math
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from replay.evaluate.foreign import (  # noqa: E402
    IMAGE_TOPIC,
    TRUTH_TOPIC,
    pose_topic,
    write_camera_file,
    write_foreign_log,
)
from replay.evaluate.foreign_suite import (  # noqa: E402
    FOREIGN_SETS,
    GROUND_Z_M,
    ForeignTask,
    foreign_tasks,
)
from replay.evaluate.match_score import score_steps  # noqa: E402

VARIANTS: dict[str, dict[str, Any]] = {
    "default": {},
    "believed, no uncertainty": {"localise": "none", "pose_uncertainty": False},
    "believed, learnt uncertainty": {"localise": "none"},
    "believed, --pose-sigma 0.05,1": {"localise": "none", "pose_sigma_m": 0.05,
                                      "pose_sigma_deg": 1.0},
    "ball, learnt": {"localise": "ball"},
    "ball, --pose-sigma 0.05,1": {"localise": "ball", "pose_sigma_m": 0.05,
                                  "pose_sigma_deg": 1.0},
    "lines, no uncertainty": {"localise": "lines", "pose_uncertainty": False},
    "lines, --pose-sigma 0.05,1": {"localise": "lines", "pose_sigma_m": 0.05,
                                   "pose_sigma_deg": 1.0},
}
"""The switch sets compared (options of :func:`replay.profiles.options_for`); all keep the
3-D track, whose steps carry the ball's true height that tells the ground. The line fit's
run only where the camera file names the field ("-" elsewhere)."""


def _steps(task: ForeignTask, variant: str) -> list[dict[str, Any]]:
    """The steps (no clock ticks) of one log replayed with one of :data:`VARIANTS`."""
    from replay.profiles import options_for
    from replay.runner import replay
    from replay.sinks import ResultsCollector

    collected = ResultsCollector()
    replay(task.log, options_for(cameras=task.cameras, image_topic=IMAGE_TOPIC,
                                 pose_topic=pose_topic(task.options), truth_topic=TRUTH_TOPIC,
                                 progress=False, quiet=True, threads=1, **VARIANTS[variant]),
           sinks=[collected])
    return [f for f in collected.fused if not f.get("tick")]


def _on_ground(step: dict[str, Any]) -> bool:
    return bool((step.get("truth_z_m") or 0.0) < GROUND_Z_M)


def _run(job: tuple[ForeignTask, str]) -> tuple[str, str, float | None, float | None]:
    task, variant = job
    if VARIANTS[variant].get("localise") == "lines" and not task.options.names_field:
        return task.label, variant, None, None  # no field named: no line fit
    steps = _steps(task, variant)
    st = score_steps([f for f in steps if _on_ground(f)], []).stats()
    return task.label, variant, st["rmse_m"], score_steps(steps, []).stats()[
        "velocity_median_m_s"]


def _errors(task: ForeignTask) -> tuple[str, list[float], list[float]]:
    """The default's step errors on one log, the ball on the ground and in the air."""
    steps = [f for f in _steps(task, "default") if f.get("error_m") is not None]
    return (task.label, [f["error_m"] for f in steps if _on_ground(f)],
            [f["error_m"] for f in steps if not _on_ground(f)])


def _rms(v: list[float]) -> str:
    return f"{math.sqrt(sum(x * x for x in v) / len(v)):.4f}" if v else "-"


def _default_only(tasks: list[ForeignTask], workers: int, name: str) -> int:
    with ProcessPoolExecutor(workers) as pool:
        results = list(pool.map(_errors, tasks))
    print(f"Foreign logs, the `{name}` set: the default's RMSE [m] over every step, with the "
          "ball on the ground and in the air (steps)\n")
    print("| log | all | ground | air |\n|---|---|---|---|")
    everything: tuple[list[float], list[float]] = ([], [])
    for label, ground, air in results:
        everything[0].extend(ground)
        everything[1].extend(air)
        print(f"| {label} | {_rms(ground + air)} | {_rms(ground)} | {_rms(air)} ({len(air)}) |")
    g, a = everything
    print(f"| pooled | {_rms(g + a)} | {_rms(g)} | {_rms(a)} ({len(a)}) |")
    return 0


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    p.add_argument("out_dir", type=Path)
    p.add_argument("--set", choices=tuple(FOREIGN_SETS), default="report")
    p.add_argument("--duration", type=float, default=10.0)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--default-only", action="store_true",
                   help="the default alone: RMSE over every step, on the ground, in the air")
    args = p.parse_args()
    folder = args.out_dir / "foreign"
    folder.mkdir(parents=True, exist_ok=True)
    tasks = foreign_tasks(folder, seeds=FOREIGN_SETS[args.set], duration_s=args.duration)
    for t in tasks:
        if not (t.log.exists() and t.cameras.exists()):
            write_camera_file(t.cameras, t.options, force=True)
            write_foreign_log(t.log, t.options, force=True)
    if args.default_only:
        return _default_only(tasks, args.workers, args.set)
    jobs = [(t, v) for t in tasks for v in VARIANTS]
    with ProcessPoolExecutor(args.workers) as pool:
        results = list(pool.map(_run, jobs))
    table: dict[str, dict[str, tuple[float | None, float | None]]] = {}
    for label, variant, rmse, vel in results:
        table.setdefault(label, {})[variant] = (rmse, vel)
    names = list(VARIANTS)
    print(f"Foreign logs, the `{args.set}` set: RMSE with the ball on the ground [m] (its "
          "ratio to the best switch set), fused velocity median error [m/s]\n")
    print("| log | " + " | ".join(names) + " |")
    print("|---|" + "---|" * len(names))
    for label, row in table.items():
        best = min(r for r, _ in row.values() if r is not None)  # (the default always runs)
        cells = [f"{r:.4f} ({r / best:.2f}x), {v:.3f}" if r is not None and v is not None
                 else "-" for r, v in (row[n] for n in names)]
        print(f"| {label} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
