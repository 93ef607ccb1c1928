"""``dsp-calibrate``: a camera's pixel-radius -> range calibration (thin CLI).

    dsp-calibrate --camera mirror -o cal.json                  (simulated: the paper's procedure)
    dsp-calibrate --from-measurements points.csv --image-size 1280x1024 -o cameras.yaml
    dsp-calibrate --from-log calib.mcap --ball-at 0,0 -o cameras.yaml [--image-topic ...]
    dsp-calibrate --ball-from frames/ -o ball.json          (the ball model, labelled frames)
    dsp-calibrate --ball-from sim.mcap -o ball.json         (... or a simulated log's truth)
    dsp-calibrate --ball-generic -o ball.json               (... or none: the generic one)

Without ``--from-*`` the simulated procedure runs (:mod:`recorder.calibrate_cli`). With
them a real camera is calibrated (:mod:`replay.calibrate.run`): the image centre and the
mounting rotation fitted, every model ranked on held-out samples as the simulated procedure
ranks them, the camera file written with its residual figure (default: OUT with .png).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from collections.abc import Sequence
from contextlib import ExitStack
from pathlib import Path

from dsp import contract
from dsp.atomic import atomic_output, check_distinct, declare_files
from dsp.ball_file import ball_file_text, shipped_generic
from dsp.camera_file import CAMERA_FILE_SUFFIXES
from dsp.checks import check_number, check_suffix, check_topic_pattern
from dsp.cli import echo, run_main
from dsp.errors import UsageError
from dsp.field import FIELD_ALIASES, FIELDS
from dsp.field_file import FieldDescriptionError, field_from_json
from dsp.plotting import FIGURE_SUFFIXES, save
from dsp.textfile import TEXT_ERRORS
from estimator.constants import BALL_RADIUS_M
from recorder import calibrate_cli as simulated
from replay.calibrate.ball import fit_ball, format_fit
from replay.calibrate.figure import measured_figure
from replay.calibrate.from_log import samples_from_log
from replay.calibrate.measurements import read_measurements
from replay.calibrate.run import MeasuredRun, calibrate_measured, camera_file, format_measured

__all__ = ["build_parser", "main"]

PROG = simulated.PROG


def _numbers(flag: str, text: str | None, count: int, sep: str = ",") -> list[float] | None:
    if text is None:
        return None
    try:
        values = [float(v) for v in text.split(sep)]
    except ValueError:
        values = []
    if len(values) != count:
        raise UsageError(f"{flag} {text!r}: give {count} numbers separated by {sep!r}")
    for v in values:
        check_number(flag, v, low=-1e6, high=1e6)
    return values


def build_parser() -> argparse.ArgumentParser:
    p = simulated.build_parser()
    p.description = ("Calibrate a camera's pixel radius -> range: in simulation, the way the "
                     "paper does (the default), or a real camera from measured points "
                     "(--from-measurements) or from a log with the ball at a known place "
                     "(--from-log).")
    real = p.add_argument_group("a real camera")
    source = real.add_mutually_exclusive_group()
    source.add_argument("--from-measurements", type=Path, metavar="CSV",
                        help="measured points: robot (optional), u_px, v_px (or r_px, "
                        "bearing_deg), range_m, angle_deg (robot frame: 0 forward, 90 left)")
    source.add_argument("--from-log", type=Path, metavar="MCAP",
                        help="a log with the ball at a known place (--ball-at) or on a truth "
                        "topic (--truth-topic), seen by the robots as they move")
    real.add_argument("--ball-at", metavar="X,Y", help="with --from-log: the ball's place [m]")
    real.add_argument("--truth-topic", metavar="TOPIC",
                      help="with --from-log: the ball's true position over time")
    real.add_argument("--image-topic", default=contract.IMAGE_TOPIC, metavar="PATTERN",
                      help="with --from-log: the image topic pattern (default %(default)s)")
    real.add_argument("--pose-topic", default=contract.POSE_TOPIC, metavar="PATTERN",
                      help="with --from-log: the pose topic pattern (default %(default)s)")
    real.add_argument("--image-size", metavar="WxH",
                      help="with --from-measurements: the images' size in pixels")
    real.add_argument("--centre", metavar="CU,CV",
                      help="the image centre, when it is known (default: fitted, from balls "
                      "seen all around the robot)")
    real.add_argument("--usable-radius", type=float, metavar="PX",
                      help="balls seen farther from the centre are out of range (default: just "
                      "past the farthest sample: the calibration says nothing beyond)")
    real.add_argument("--map-to-field", metavar="X,Y,YAW",
                      help="the poses' frame in the field (m, m, deg), written to the file "
                      "(and, with --from-log, applied to the poses)")
    real.add_argument("--camera-height", type=float, metavar="M",
                      help="the camera's optical centre above the floor [m], written to the "
                      "file (height_m): with it the calibration is a projection model, and the "
                      "default fits the field lines and crosses rays in 3-D")
    real.add_argument("--field", metavar="NAME",
                      help="the field the robots play on (18x12, 22x14, msl), written to the "
                      "file: with it the default fits the field lines")
    ball = p.add_argument_group("a ball model (the real-ball detector)")
    ball.add_argument("--ball-from", type=Path, metavar="DIR|LOG.mcap",
                      help="fit the ball model (-o ball.json, dsp-replay --ball reads it) from "
                      "a folder of images with YOLO labels beside them (NAME.txt), or from a "
                      "simulated log (.mcap), the ball's boxes drawn from its ground truth")
    ball.add_argument("--ball-generic", action="store_true",
                      help="write the generic ball model (fitted on many venues' images, no "
                      "venue head): a working detector before a frame of the venue is "
                      "labelled; ten labelled frames and --ball-from do better")
    ball.add_argument("--ball-class", type=int, default=0, metavar="N",
                      help="with --ball-from DIR: the labels' class of the ball (default 0)")
    ball.add_argument("--train-count", type=int, metavar="N",
                      help="with --ball-from: the first N labelled images by name, or a log's "
                      "first N images by stamp (default all)")
    ball.add_argument("--no-head", action="store_true",
                      help="with --ball-from: no venue head on the shared check")
    declare_files(p, inputs=("--from-measurements", "--from-log", "--ball-from"),
                  outputs=("--out", "--plot"))
    return p


def _run_ball(args: argparse.Namespace) -> int:
    out: Path = args.out
    check_suffix("-o/--out", out, (".json",))
    if args.plot is not None:
        which = "--ball-generic" if args.ball_generic else "--ball-from"
        raise UsageError(f"--plot draws a camera calibration; {which} writes a ball model, "
                         "which has no figure (leave --plot out)")
    if args.ball_generic:
        if args.ball_from is not None or args.train_count is not None or args.no_head:
            raise UsageError("--ball-generic fits nothing: --ball-from, --train-count and "
                             "--no-head do not go with it")
    else:
        check_distinct([("--out", out)], [("the input", args.ball_from)])
    with atomic_output(out, force=args.force, label="--out") as tmp:
        model = shipped_generic() if args.ball_generic else fit_ball(
            args.ball_from, ball_class=args.ball_class, train_count=args.train_count,
            head=not args.no_head)
        tmp.write_text(ball_file_text(model), encoding="utf-8", errors=TEXT_ERRORS)
    echo(args, format_fit(model))
    echo(args, f"wrote {out}")
    return 0


def _image_size(text: str | None) -> tuple[int, int] | None:
    if text is None:
        return None
    parts = text.lower().split("x")
    if len(parts) != 2 or not all(p.isdigit() and 0 < int(p) <= 100_000 for p in parts):
        raise UsageError(f"--image-size {text!r}: give WIDTHxHEIGHT in pixels, e.g. 1280x1024")
    return int(parts[0]), int(parts[1])


def _measure(args: argparse.Namespace) -> MeasuredRun:
    centre = _numbers("--centre", args.centre, 2)
    transform = _numbers("--map-to-field", args.map_to_field, 3)
    check_number("--usable-radius", args.usable_radius, low=0, high=1e6, low_open=True,
                 unit="px")
    check_number("--camera-height", args.camera_height, low=BALL_RADIUS_M, high=10.0,
                 low_open=True, unit="m")
    if args.field is not None:
        try:
            field_from_json(args.field, "--field")
        except FieldDescriptionError:
            known = ", ".join([*FIELDS, *FIELD_ALIASES])
            raise UsageError(f"--field {args.field!r} is not a field's name (known: {known}); "
                             "a field of other dimensions goes in the camera file's field key "
                             "(docs/cameras.md)") from None
    size = _image_size(args.image_size)
    mtf = None if transform is None else (transform[0], transform[1], transform[2])
    if args.from_measurements is not None:
        for flag in ("ball_at", "truth_topic"):
            if getattr(args, flag) is not None:
                raise UsageError(f"--{flag.replace('_', '-')} goes with --from-log")
        if size is None:
            raise UsageError("--from-measurements needs --image-size WxH (the images' size)")
        measurements = read_measurements(args.from_measurements)
        sizes = {"default": size}
    else:
        check_topic_pattern("--image-topic", args.image_topic)
        check_topic_pattern("--pose-topic", args.pose_topic)
        ball = _numbers("--ball-at", args.ball_at, 2)
        measurements, sizes = samples_from_log(
            args.from_log, ball_at=None if ball is None else (ball[0], ball[1]),
            truth_topic=args.truth_topic, image_topic=args.image_topic,
            pose_topic=args.pose_topic, map_to_field=mtf)
        if size is not None:
            sizes = dict.fromkeys(sizes, size)
    run = calibrate_measured(measurements, image_sizes=sizes,
                             centre_px=None if centre is None else (centre[0], centre[1]),
                             usable_radius_px=args.usable_radius, map_to_field=mtf)
    return dataclasses.replace(run, height_m=args.camera_height, field=args.field)


def _run_measured(args: argparse.Namespace) -> int:
    out: Path = args.out
    check_suffix("-o/--out", out, CAMERA_FILE_SUFFIXES)
    plot: Path | None = None if args.no_plot else (args.plot or out.with_suffix(".png"))
    check_suffix("--plot", plot, FIGURE_SUFFIXES)
    source = args.from_measurements or args.from_log
    check_distinct([("--out", out), ("--plot", plot)], [("the input", source)])
    outputs = [(f, p) for f, p in (("--out", out), ("--plot", plot)) if p is not None]
    with ExitStack() as stack:
        tmp = [stack.enter_context(atomic_output(p, force=args.force, label=f))
               for f, p in outputs]
        run = _measure(args)
        tmp[0].write_text(camera_file(run, out.suffix.lower()), encoding="utf-8",
                          errors=TEXT_ERRORS)
        if plot is not None:
            save(measured_figure(run.cameras, Path(run.source).name), tmp[1],
                 fmt=plot.suffix.lower().lstrip("."))
    echo(args, format_measured(run))
    echo(args, f"wrote {out}" + (f" and {plot}" if plot is not None else ""))
    return 0


def _main(argv: Sequence[str] | None) -> int:
    args = build_parser().parse_args(argv)
    if args.ball_from is not None or args.ball_generic:
        if args.from_measurements is not None or args.from_log is not None:
            raise UsageError("--ball-from fits a ball model; calibrate the camera apart")
        return _run_ball(args)
    if args.train_count is not None or args.no_head:
        raise UsageError("--train-count and --no-head go with --ball-from")
    if args.from_measurements is None and args.from_log is None:
        given = [f"--{k.replace('_', '-')}" for k in ("ball_at", "truth_topic", "image_size",
                                                       "centre", "usable_radius", "map_to_field",
                                                       "camera_height", "field")
                 if getattr(args, k) is not None]
        if given:
            raise UsageError(f"{', '.join(given)} go with --from-measurements or --from-log")
        return simulated.run_simulated(args)
    return _run_measured(args)


def main(argv: Sequence[str] | None = None) -> int:
    return run_main(PROG, _main, argv)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
