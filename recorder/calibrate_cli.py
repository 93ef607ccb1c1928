"""``dsp-calibrate``: the paper's pixel-to-metre calibration, run in simulation (thin CLI).

    dsp-calibrate --camera ideal -o calib.json [--plot calib.png] [--directions 0,90,180,-90]

Writes the best calibration model (chosen on held-out samples) with its fit quality to the
JSON file that ``dsp-replay --calibration`` takes, and a PNG like the paper's Fig. 10. The
command's entry point is :mod:`replay.calibrate.cli`, which adds the real camera's modes
(``--from-measurements``, ``--from-log``) and runs this one otherwise.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Sequence
from contextlib import ExitStack
from pathlib import Path

from dsp.atomic import atomic_output, check_distinct, declare_files
from dsp.checks import MAX_FACE_PX, check_int, check_number, check_suffix
from dsp.cli import Parser, add_common_arguments, echo, progress_enabled, run_main
from dsp.errors import UsageError
from dsp.jsonio import dumps as strict_json
from dsp.plotting import FIGURE_SUFFIXES, save
from dsp.progress import progress_bar
from estimator.calibration import calibration_to_json
from estimator.camera import make_camera
from recorder.calibrate import PAPER_FIT, CalibrationRun, calibrate, distances_m
from recorder.calibrate import sample_ranges as _sample_ranges
from recorder.calibrate_figure import calibration_figure
from recorder.omni import DEFAULT_FACE_PX

__all__ = ["build_parser", "format_report", "main", "run_simulated"]

PROG = "dsp-calibrate"
MAX_RANGE_M = 30.0
"""The farthest placement [m]: beyond the longest field's diagonal."""
MAX_PLACEMENTS = 10_000
"""Ranges per direction at most (each is a render)."""


def build_parser() -> argparse.ArgumentParser:
    p = Parser(
        prog=PROG,
        allow_abbrev=False,
        description="Fit the pixel-radius -> range calibration of a camera model the way the "
        "paper does (ball in front of a robot, 0.4 to 9.0 m in 0.1 m steps), in simulation.",
    )
    p.add_argument("-o", "--out", type=Path, required=True, metavar="JSON",
                   help="calibration JSON to write (dsp-replay --calibration reads it); with "
                   "--from-measurements or --from-log the camera file, .yaml or .json "
                   "(dsp-replay --cameras reads it)")
    p.add_argument("--plot", type=Path, metavar="PNG",
                   help="figure of samples, fits and residuals, .png or .svg "
                   "(default: OUT with .png)")
    p.add_argument("--no-plot", action="store_true", help="write no figure")
    p.add_argument("--start-m", type=float, default=0.4, metavar="M",
                   help="first range in metres (default %(default)s)")
    p.add_argument("--stop-m", type=float, default=9.0, metavar="M",
                   help="last range in metres (default %(default)s)")
    p.add_argument("--step-m", type=float, default=0.1, metavar="M",
                   help="range step in metres (default %(default)s)")
    p.add_argument("--directions", default="0,90,180,-90,45", metavar="DEG,...",
                   help="ball directions in the robot frame, 0 = forward, 90 = left "
                   "(default %(default)s; the paper used 0 only)")
    p.add_argument("--face-px", type=int, default=DEFAULT_FACE_PX, metavar="PX",
                   help="cube face size rendered per direction (default %(default)s)")
    add_common_arguments(p, camera="ideal", renderer=True, force=True)
    declare_files(p, outputs=("--out", "--plot"))
    return p


MAX_DIRECTIONS = 36
"""The most ball directions one calibration sweeps (every 10 degrees)."""


def _directions(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise UsageError(f"--directions {text!r}: give degrees separated by commas") from None
    if not values:
        raise UsageError("--directions is empty; give at least one direction, e.g. 0")
    if len(values) > MAX_DIRECTIONS:
        raise UsageError(f"--directions: {len(values)} directions; give at most "
                         f"{MAX_DIRECTIONS} (each is a sweep of renders)")
    for v in values:
        check_number("--directions", v, low=-360, high=360, unit="deg")
    # forward first: the paper's own fit uses it
    return sorted(set(values), key=lambda v: (v != 0.0, values.index(v)))


def format_report(run: CalibrationRun, renderer: str) -> str:
    pp = run.paper_procedure
    lines = [
        f"camera {run.camera.get('model')}, renderer {renderer}: "
        f"{run.detected} of {len(run.samples)} placements detected",
        "",
        "paper's procedure (forward samples, linear d = a r + b):",
        f"  {'':10} {'a [m/px]':>10} {'b [m]':>9} {'R^2':>8}",
        f"  {'paper':10} {PAPER_FIT['a_m_per_px']:>10.4f} {PAPER_FIT['b_m']:>9.4f} "
        f"{PAPER_FIT['r2']:>8.4f}",
    ]
    a = getattr(pp.model, "a_m_per_px", math.nan)
    b = getattr(pp.model, "b_m", math.nan)
    lines.append(f"  {'ours':10} {a:>10.4f} {b:>9.4f} {pp.r2:>8.4f}")
    lines += ["", "isotropy (linear fit per direction):",
              f"  {'direction':>9} {'a [m/px]':>10} {'b [m]':>9} {'RMS [m]':>8}"]
    for direction, fit in run.per_direction.items():
        a = getattr(fit.model, "a_m_per_px", math.nan)
        b = getattr(fit.model, "b_m", math.nan)
        lines.append(f"  {direction:>9g} {a:>10.5f} {b:>9.4f} {fit.rms_m:>8.4f}")
    lines += ["", "models on all samples (ranked by held-out RMS):",
              f"  {'model':8} {'R^2':>8} {'RMS [m]':>8} {'max [m]':>8} {'held-out RMS':>13}"]
    for fit in run.fits:
        lines.append(f"  {fit.model.name:8} {fit.r2:>8.5f} {fit.rms_m:>8.4f} "
                     f"{fit.max_abs_m:>8.4f} {run.holdout_rms_m[fit.model.name]:>13.4f}")
    lines.append(f"best: {run.best.model.name}")
    return "\n".join(lines)


def _check(args: argparse.Namespace) -> None:
    """Refuse bad numbers before rendering anything."""
    for flag, value in (("--start-m", args.start_m), ("--stop-m", args.stop_m),
                        ("--step-m", args.step_m)):
        check_number(flag, value, low=0, high=MAX_RANGE_M, low_open=True, unit="m")
    if args.stop_m < args.start_m:
        raise UsageError(f"--stop-m {args.stop_m} is below --start-m {args.start_m}")
    if (args.stop_m - args.start_m) / args.step_m >= MAX_PLACEMENTS:
        raise UsageError(f"--step-m {args.step_m}: more than {MAX_PLACEMENTS} ranges from "
                         f"{args.start_m} to {args.stop_m} m; give a larger step")
    check_int("--face-px", args.face_px, low=16, high=MAX_FACE_PX)


def _main(argv: Sequence[str] | None) -> int:
    return run_simulated(build_parser().parse_args(argv))


def run_simulated(args: argparse.Namespace) -> int:
    """The simulated procedure with parsed arguments (``dsp-calibrate`` without --from-*)."""
    out: Path = args.out
    check_suffix("-o/--out", out, (".json",))
    plot: Path | None = None if args.no_plot else (args.plot or out.with_suffix(".png"))
    check_suffix("--plot", plot, FIGURE_SUFFIXES)
    check_distinct([("--out", out), ("--plot", plot)])
    _check(args)
    directions = _directions(args.directions)
    outputs = [out] if plot is None else [out, plot]
    with ExitStack() as stack:
        # claim the outputs before the long rendering: a refusal comes first, not last
        tmp = [stack.enter_context(atomic_output(path, force=args.force, label=flag))
               for flag, path in zip(("--out", "--plot"), outputs, strict=False)]
        camera = make_camera(args.camera)
        distances = distances_m(args.start_m, args.stop_m, args.step_m)
        t0 = time.perf_counter()
        with progress_bar(len(directions) * len(distances), "calibrating",
                          progress_enabled(args), unit="img") as bar:
            samples, renderer = _sample_ranges(
                camera, distances, directions, renderer=args.renderer, face_px=args.face_px,
                on_sample=lambda _s: bar.update(1),
            )
        run = calibrate(camera, samples)
        doc = json.loads(calibration_to_json(run.best.model, run.best))
        doc["source_camera"] = run.camera
        doc["samples"] = {"n": len(samples), "detected": run.detected,
                          "directions_deg": directions, "start_m": args.start_m,
                          "stop_m": args.stop_m, "step_m": args.step_m}
        doc["holdout_rms_m"] = round(run.holdout_rms_m[run.best.model.name], 6)
        tmp[0].write_bytes((strict_json(doc, sort_keys=True, indent=2) + "\n").encode())
        if plot is not None:
            save(calibration_figure(run), tmp[1], fmt=plot.suffix.lower().lstrip("."))
    echo(args, format_report(run, renderer))
    wrote = f"wrote {out}" + (f" and {plot}" if plot is not None else "")
    echo(args, f"{wrote} in {time.perf_counter() - t0:.1f} s")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    return run_main(PROG, _main, argv)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
