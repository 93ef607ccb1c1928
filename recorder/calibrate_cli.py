"""``dsp-calibrate``: the paper's pixel-to-metre calibration, run in simulation (thin CLI).

    dsp-calibrate --camera ideal -o calib.json [--plot calib.png] [--directions 0,90,180,-90]

Writes the best calibration model (chosen on held-out samples) with its fit quality to the
JSON file that ``dsp-replay --calibration`` takes, and a PNG like the paper's Fig. 10.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from estimator.calibration import calibration_to_json
from estimator.camera import CAMERA_MODELS, make_camera
from recorder.calibrate import PAPER_FIT, CalibrationRun, calibrate, distances_m, plot_png
from recorder.calibrate import sample_ranges as _sample_ranges
from recorder.errors import OutputExistsError, RecorderError, UsageError
from recorder.omni import DEFAULT_FACE_PX

__all__ = ["build_parser", "format_report", "main"]


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="dsp-calibrate",
        description="Fit the pixel-radius -> range calibration of a camera model the way the "
        "paper does (ball in front of a robot, 0.4 to 9.0 m in 0.1 m steps), in simulation.",
    )
    p.add_argument("--camera", choices=CAMERA_MODELS, default="ideal",
                   help="camera model (default %(default)s)")
    p.add_argument("-o", "--output", type=Path, required=True, metavar="JSON",
                   help="calibration file to write (dsp-replay --calibration reads it)")
    p.add_argument("--plot", type=Path, metavar="PNG",
                   help="figure of samples, fits and residuals (default: OUTPUT with .png)")
    p.add_argument("--no-plot", action="store_true", help="write no figure")
    p.add_argument("--start", type=float, default=0.4, metavar="M", help="first range (0.4 m)")
    p.add_argument("--stop", type=float, default=9.0, metavar="M", help="last range (9.0 m)")
    p.add_argument("--step", type=float, default=0.1, metavar="M", help="range step (0.1 m)")
    p.add_argument("--directions", default="0,90,180,-90,45", metavar="DEG,...",
                   help="ball directions in the robot frame, 0 = forward, 90 = left "
                   "(default %(default)s; the paper used 0 only)")
    p.add_argument("--renderer", choices=("auto", "egl", "tiny"), default="auto",
                   help="pybullet renderer (default: EGL when it loads)")
    p.add_argument("--face-px", type=int, default=DEFAULT_FACE_PX,
                   help="cube face size rendered per direction (default %(default)s)")
    p.add_argument("--force", action="store_true", help="overwrite existing outputs")
    return p


def _directions(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise UsageError(f"--directions {text!r}: give degrees separated by commas") from None
    if not values:
        raise UsageError("--directions is empty; give at least one direction, e.g. 0")
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


def _write_atomic(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        tmp.write_bytes(data)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    out: Path = args.output
    plot: Path | None = None if args.no_plot else (args.plot or out.with_suffix(".png"))
    try:
        for path in (out, plot):
            if path is not None and path.exists() and not args.force:
                raise OutputExistsError(f"{path}: already exists; pass --force to overwrite")
            if path is not None and not path.parent.is_dir():
                raise UsageError(f"{path}: folder {path.parent} does not exist")
        camera = make_camera(args.camera)
        directions = _directions(args.directions)
        distances = distances_m(args.start, args.stop, args.step)
        total = len(directions) * len(distances)
        bar = None
        if sys.stderr.isatty():
            from tqdm import tqdm

            bar = tqdm(total=total, unit="img", desc="calibrating", file=sys.stderr)
        t0 = time.perf_counter()
        try:
            samples, renderer = _sample_ranges(
                camera, distances, directions, renderer=args.renderer, face_px=args.face_px,
                on_sample=(lambda _s: bar.update(1)) if bar is not None else None,
            )
        finally:
            if bar is not None:
                bar.close()
        run = calibrate(camera, samples)
        doc = json.loads(calibration_to_json(run.best.model, run.best))
        doc["source_camera"] = run.camera
        doc["samples"] = {"n": len(samples), "detected": run.detected,
                          "directions_deg": directions,
                          "start_m": args.start, "stop_m": args.stop, "step_m": args.step}
        doc["holdout_rms_m"] = round(run.holdout_rms_m[run.best.model.name], 6)
        _write_atomic(out, (json.dumps(doc, sort_keys=True, indent=2) + "\n").encode())
        if plot is not None:
            _write_atomic(plot, plot_png(run))
    except (RecorderError, ValueError) as err:
        print(f"dsp-calibrate: error: {err}", file=sys.stderr)
        return getattr(err, "exit_code", 2)
    except KeyboardInterrupt:
        print("dsp-calibrate: interrupted; nothing written", file=sys.stderr)
        return 130
    print(format_report(run, renderer))
    wrote = f"wrote {out}" + (f" and {plot}" if plot is not None else "")
    print(f"{wrote} in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
