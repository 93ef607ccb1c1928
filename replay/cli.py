"""``dsp-replay``: replay a log through the estimator (thin: parse, call, report).

    dsp-replay run.mcap [--rerun | --save out.rrd | --connect URL
                         | --serve [--bind 127.0.0.1] [--port 9090] [--grpc-port 9876]]
               [--method paper|corrected] [--fusion mean|nearest|weighted|robust|track]
               [--out results.json] [--out-mcap estimates.mcap] [--out-csv estimates.csv]
               [--plot replay.png] [--force] ...
    dsp-replay LOG|FOLDER [...] --out-dir DIR [--out-mcap] [--workers N | --ray]   (batch)

Known problems end in one line on stderr and an exit code, without a traceback
(:func:`dsp.cli.run_main`: 1 bad input, 2 usage, 3 output exists, 130 interrupted).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path

from dsp import contract
from dsp.atomic import declare_files
from dsp.checks import check_rrd, check_suffix
from dsp.cli import Parser, add_common_arguments, echo, progress_enabled, run_main
from dsp.errors import EXIT_INTERRUPTED, UsageError
from dsp.plotting import FIGURE_SUFFIXES
from dsp.text import printable
from estimator.fusion import FUSION_METHODS
from replay.batch.cli import add_batch_arguments, check_single, is_batch, run_batch
from replay.beliefs import describe_belief
from replay.log.catalogue import check_mcap_file
from replay.memory import keep_image_buffers
from replay.options import (
    LOCALISE_MODES,
    METHODS,
    NOISE_MODELS,
    ReplayOptions,
    RerunTarget,
)
from replay.profiles import DEFAULT_PROFILE, PROFILE_CHOICES, PROFILES, options_for
from replay.runner import replay
from replay.sinks.rerun.live import DEFAULT_BIND, DEFAULT_GRPC_PORT, DEFAULT_WEB_PORT
from replay.stats import ReplaySummary

__all__ = ["build_parser", "format_summary", "main", "warn"]

PROG = "dsp-replay"


ESSENTIAL = frozenset({
    "help", "help_all", "profile", "rerun", "save", "connect", "serve",
    "out", "out_mcap", "out_csv", "plot", "force", "cameras", "ball", "image_topic",
    "pose_topic", "out_dir", "quiet"})
"""The options ``--help`` shows (by ``dest``); ``--help-all`` shows every one."""


def build_parser(*, all_options: bool = True) -> argparse.ArgumentParser:
    """The parser; ``all_options`` False hides the researchers' switches from ``--help``
    (they parse all the same)."""
    p = Parser(
        prog=PROG,
        usage="%(prog)s LOG [--profile best|fast|paper] [--rerun | --connect URL | --serve] "
        "[--save RRD] [--out JSON] [--out-mcap MCAP] [...]\n"
        "       %(prog)s LOG|FOLDER [...] --out-dir DIR [--estimates] [--workers N | --ray]",
        description="Find the ball in every image of a log, locate and fuse it, score it "
        "against the log's truth and show it in Rerun: the best pipeline the log allows.",
        epilog=None if all_options else "Researchers' switches: dsp-replay --help-all.",
        add_help=False,
    )
    p.add_argument("-h", "--help", action="help", help="show the essential options and exit")
    p.add_argument("--help-all", action="store_true",
                   help="show every option and exit")
    p.add_argument("log", type=Path, nargs="+",
                   help="the MCAP log (with --out-dir: logs and folders)")
    p.add_argument("--profile", choices=PROFILE_CHOICES, default=DEFAULT_PROFILE,
                   help="; ".join(f"{n}: {PROFILES[n].summary}" for n in PROFILE_CHOICES)
                   if all_options else "best (default), fast (no line fit) or paper (the "
                   "paper exactly)")
    _add_essential_arguments(p)
    add_batch_arguments(p)
    add_common_arguments(p, force=True)
    _add_researcher_arguments(p, all_options)
    declare_files(p, inputs=("log", "--ball", "--cameras", "--calibration"),
                  outputs=("--out", "--out-mcap", "--out-csv", "--plot", "--save"),
                  output_dirs=("--out-dir",), names=("paper",))
    if not all_options:
        for action in p._actions:
            if action.dest not in ESSENTIAL:
                action.help = argparse.SUPPRESS
    return p


def _add_essential_arguments(p: argparse.ArgumentParser) -> None:
    """Viewing, outputs and what describes a team's own log: what ``--help`` shows."""
    viewer = p.add_argument_group("viewing (Rerun)")
    live = viewer.add_mutually_exclusive_group()
    live.add_argument("--rerun", action="store_true", help="spawn a Rerun viewer")
    live.add_argument("--connect", metavar="URL", help="connect to a running viewer")
    live.add_argument("--serve", action="store_true",
                      help="serve the web viewer (prints its URL)")
    viewer.add_argument("--save", type=Path, metavar="RRD",
                        help="save a Rerun .rrd file (also while viewing live)")
    out = p.add_argument_group("outputs")
    out.add_argument("--out", type=Path, metavar="JSON",
                     help="write the results JSON")
    out.add_argument("--out-mcap", type=Path, metavar="MCAP",
                     help="write the estimates as MCAP (Foxglove, ros2 bag)")
    out.add_argument("--out-csv", type=Path, metavar="CSV",
                     help="write the estimates as CSV, one row each")
    out.add_argument("--plot", type=Path, metavar="PNG",
                     help="draw error over time and the track (.png/.svg)")
    team = p.add_argument_group("your own robots' log")
    team.add_argument("--cameras", metavar="FILE",
                      help="camera file (.yaml/.json); default: the log's own")
    team.add_argument("--ball", type=Path, metavar="BALL.json",
                      help="ball model for the real-ball detector")
    team.add_argument("--image-topic", default=contract.IMAGE_TOPIC, metavar="TOPIC",
                      help="image topic, {robot} = robot name (default %(default)s)")
    team.add_argument("--pose-topic", default=contract.POSE_TOPIC, metavar="TOPIC",
                      help="pose topic pattern (default %(default)s)")


def _add_researcher_arguments(p: argparse.ArgumentParser, all_options: bool) -> None:
    """Each switch overrides one choice of the profile (``--help-all`` shows them)."""
    expert = p.add_argument_group(
        "researchers' switches", "each overrides one choice of the profile; choices that "
        "cannot go with it fall away (--fusion mean drops the hops)" if all_options else None)
    expert.add_argument("--method", choices=METHODS, default=None,
                        help="paper: eq. 3-14 as published; corrected: calibration on the "
                        "range (the profile's: corrected, paper for --profile paper)")
    expert.add_argument("--fusion", metavar="|".join(FUSION_METHODS),
                        help="how the robots' estimates are fused (the profile's: track, a "
                        "Kalman filter giving position and velocity at every image stamp; "
                        "mean for --profile paper); triangulate and ballistic place the ball "
                        "in 3-D, ballistic tracking its flight and predicting its landing; "
                        "or a fusion from outside: an installed dual_sight.fusions entry "
                        "point's name, or package.module:Class")
    expert.add_argument("--noise", choices=NOISE_MODELS, default="cambada",
                        help="the window fusions' covariance per estimate: cambada (a fixed "
                        "range law, default) or calibrated (from the calibration, as track "
                        "uses)")
    _add_track_arguments(expert)
    _add_input_arguments(expert)
    _add_localise_arguments(expert)
    expert.add_argument("--pose-tolerance", type=float, default=0.1, metavar="S",
                        help="skip an image whose nearest pose is further away (default 0.1 s)")
    expert.add_argument("--window", type=float, default=0.05, metavar="S",
                        help="fusion window grouping the robots' images (default 0.05 s)")
    expert.add_argument("--recover", action="store_true",
                        help="replay every complete chunk of a truncated or damaged log")
    expert.add_argument("--max-chunk-mib", type=float, default=128.0, metavar="MIB",
                        help="refuse chunks larger than this, compressed or not (default 128)")
    expert.add_argument("--max-image-mpx", type=float, default=40.0, metavar="MPX",
                        help="skip images whose header declares more megapixels (default 40)")
    expert.add_argument("--threads", type=int, metavar="N",
                        help="threads decoding and detecting images ahead (default: the "
                        "cores; 1: serial); the outputs are the same whatever N")
    expert.add_argument("--strict", action="store_true",
                        help="make every warning an error (a robot that saw no ball, balls "
                        "out of range, skipped messages or images): exit 1, write nothing")
    expert.add_argument("--bind", metavar="ADDR",
                        help=f"with --serve: the address to serve on (default {DEFAULT_BIND}, "
                        "this machine only; 0.0.0.0 for every interface)")
    expert.add_argument("--port", type=int, metavar="PORT",
                        help=f"with --serve: the web viewer's port (default "
                        f"{DEFAULT_WEB_PORT}; 0 picks a free one)")
    expert.add_argument("--grpc-port", type=int, metavar="PORT",
                        help=f"with --serve: the data (gRPC) port (default "
                        f"{DEFAULT_GRPC_PORT}; 0 picks a free one)")


def _add_track_arguments(p: argparse._ActionsContainer) -> None:
    """``--smooth``, ``--hops``, ``--width-range`` and ``--clock``."""
    p.add_argument("--smooth", action="store_true",
                   help="offline: smooth the track over the whole log (RTS smoother) instead "
                   "of the causal estimate a robot would have live (--fusion track)")
    p.add_argument("--hops", action=argparse.BooleanOptionalAction, default=None,
                   help="--fusion track: the position from a 3-D track beside the tracker, "
                   "so a hop or a lob is placed where it is (the profile's: on with two or "
                   "more robots, off for --profile paper)")
    p.add_argument("--width-range", action=argparse.BooleanOptionalAction, default=None,
                   help="also range each blob by its width across the bearing, which a ball "
                   "in the air does not change: a blob wider than a ball on the ground at its "
                   "range is a ball in the air, placed under itself; the corrected method "
                   "(default: the blobs of robots whose camera has no model, a range table "
                   "alone; --no-width-range: none)")
    p.add_argument("--clock", type=float, metavar="HZ", dest="clock_hz",
                   help="also a step at every tick of a HZ clock, with no image: the "
                   "tracker's estimate then (as a robot's control loop reads it), scored "
                   "against the truth at the tick; only ticks within the pose tolerance "
                   "(at least one tick) of an image are made: those across a longer gap "
                   "without images are skipped, and the replay says how many")


def _add_localise_arguments(p: argparse._ActionsContainer) -> None:
    """``--localise``, ``--pose-sigma`` and ``--pose-uncertainty``."""
    p.add_argument("--localise", choices=LOCALISE_MODES, default=None,
                   help="lines: correct each frame's pose from the field lines in its image "
                   "(the field from the log's scenario metadata; about 7 ms more per frame "
                   "on one core); auto: lines where the log names its field and a camera "
                   "(the profile's, but none for fast and paper); ball: correct each "
                   "robot's pose by its drifting bias, estimated from how its ball disagrees "
                   "with the tracked one (--fusion track); none: the believed poses")
    p.add_argument("--pose-sigma", metavar="M,DEG", type=_pose_sigma, default=None,
                   help="the believed pose's standard deviation, position in metres and yaw "
                   "in degrees, for every robot: the line fit's prior (a fit that moves the "
                   "pose further than this allows is refused); with --localise ball, the "
                   "spread of each robot's bias; with --pose-uncertainty, the pose's "
                   "covariance when neither the lines nor the log give one (default: each "
                   "learnt from the log as it replays, from each robot's line fits or from "
                   "how its ball disagrees with the others')")
    p.add_argument("--pose-uncertainty", action=argparse.BooleanOptionalAction, default=None,
                   help="weigh each robot's estimate by its own pose's uncertainty too: the "
                   "line fit's covariance, else the log pose's (PoseWithCovarianceStamped), "
                   "else --pose-sigma's, else one learnt from the log (the profile's: on, off for "
                   "--profile paper)")


def _pose_sigma(text: str) -> tuple[float, float]:
    """``--pose-sigma M,DEG``."""
    try:
        m, deg = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: give the position's and the yaw's standard deviation as M,DEG, "
            "e.g. 0.05,1") from None
    return m, deg


def _time_arg(text: str) -> tuple[float, bool]:
    """``S`` (seconds from the log's start) or ``@S`` (an absolute stamp): (seconds, absolute)."""
    absolute = text.startswith("@")
    try:
        return float(text[1:] if absolute else text), absolute
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: give seconds (e.g. 2.5) or @ and an absolute stamp (@1733068801.5)"
        ) from None


def _input(text: str | None) -> Path | str | None:
    """A file option that also takes the name 'paper'."""
    return None if text is None else (text if text == "paper" else Path(text))


def _add_input_arguments(p: argparse._ActionsContainer) -> None:
    """What describes the log: its cameras, its topics, the robots and times to replay."""
    p.add_argument("--detector", metavar="paper|real|NAME|package.module:Class", default=None,
                   help="how the ball is found in an image: 'paper' (the paper's colour "
                   "chain), 'real' (the real-ball detector with --ball's model, else the camera "
                   "file's, else the generic one), or a "
                   "detector from outside: an installed dual_sight.detectors entry point's "
                   "name, or package.module:Class (docs/compare.md); default: chosen "
                   "from the log (a camera file's ball model, a dsp-record log's orange "
                   "ball, else the one that finds a clear ball in its first images; "
                   "docs/detection.md), the colour chain with --profile paper")
    p.add_argument("--calibration", metavar="FILE",
                   help="calibration JSON for every robot, replacing its camera's; 'paper' "
                   "for the paper's eq. 4 (and its image centre where the log names no camera)")
    p.add_argument("--calibration-model", metavar="NAME|package.module:Class",
                   help="a calibration model from outside for every robot, replacing its "
                   "camera's: an installed dual_sight.calibrations entry point's name, or "
                   "package.module:Class (docs/compare.md)")
    p.add_argument("--truth-topic", metavar="TOPIC",
                   help="the ball's true position, to score against (PoseStamped, "
                   f"PointStamped or Odometry; default {contract.GT_BALL_TOPIC})")
    p.add_argument("--robots", help="comma-separated subset of robots (default all)")
    p.add_argument("--start", metavar="S", type=_time_arg,
                   help="first second to replay, counted from the log's start (sim time for "
                   "a dsp-record log, else from its first message); @S: an absolute stamp in "
                   "seconds (e.g. @1733068801.5)")
    p.add_argument("--end", metavar="S", type=_time_arg,
                   help="last second to replay, as --start counts (@S: absolute)")


def options_from_args(args: argparse.Namespace, serve_url: str | None = None) -> ReplayOptions:
    """The replay's options; ``serve_url`` is the gRPC URL of the server ``--serve`` runs."""
    check_rrd("--save", args.save)
    check_suffix("--out", args.out, (".json",))
    check_suffix("--out-mcap", args.out_mcap, (".mcap",))
    check_suffix("--out-csv", args.out_csv, (".csv",))
    check_suffix("--plot", args.plot, FIGURE_SUFFIXES)
    rerun, also_save = None, None
    if args.rerun:
        rerun = RerunTarget("spawn")
    elif args.connect is not None:
        rerun = RerunTarget("connect", args.connect)
    elif args.serve:
        rerun = RerunTarget("serve", serve_url)
    if args.save is not None:
        if rerun is None:
            rerun = RerunTarget("save", str(args.save))
        else:
            also_save = args.save
    robots = None
    if args.robots:
        robots = tuple(r.strip() for r in args.robots.split(",") if r.strip())
    start, start_absolute = args.start or (None, False)
    end, end_absolute = args.end or (None, False)
    return options_for(
        args.profile, method=args.method, detector=args.detector, ball=args.ball,
        fusion=args.fusion, calibration=_input(args.calibration),
        calibration_model=args.calibration_model,
        cameras=_input(args.cameras), smooth=args.smooth, hops=args.hops, noise=args.noise,
        width_range=args.width_range, clock_hz=args.clock_hz, localise=args.localise,
        pose_sigma_m=None if args.pose_sigma is None else args.pose_sigma[0],
        pose_sigma_deg=None if args.pose_sigma is None else args.pose_sigma[1],
        pose_uncertainty=args.pose_uncertainty,
        image_topic=args.image_topic, pose_topic=args.pose_topic,
        truth_topic=args.truth_topic, robots=robots, start_s=start, end_s=end,
        start_absolute=start_absolute, end_absolute=end_absolute,
        strict=args.strict, pose_tolerance_s=args.pose_tolerance,
        window_s=args.window, recover=args.recover, out=args.out, out_mcap=args.out_mcap,
        out_csv=args.out_csv, plot=args.plot, force=args.force, rerun=rerun, rerun_save=also_save,
        threads=args.threads,
        progress=progress_enabled(args),
        max_chunk_mib=args.max_chunk_mib, max_image_mpx=args.max_image_mpx, quiet=args.quiet,
    )


def _m(v: float | None) -> str:
    """A metre figure for the table: "-" when there is none (or it is not finite)."""
    return "-" if v is None or not math.isfinite(v) else f"{v:.3f}"


def _rate(v: float) -> str:
    return f"{v:.1f}" if math.isfinite(v) else "-"


def format_summary(s: ReplaySummary) -> str:
    """A plain-text table of the replay."""
    lines = [] if s.pipeline is None else [s.pipeline]
    lines += [f"replayed {s.path.name}: {s.frames} frames, {s.steps} steps "
             f"({s.fused_steps} fused) in {s.wall_s:.2f} s ({_rate(s.frames_per_s)} frames/s)"]
    if s.estimator_ms is not None and math.isfinite(s.estimator_ms):
        lines.append(f"estimator time: {s.estimator_ms:.2f} ms/frame (decode + detect + locate)")
    lines.append(f"{'':10} {'frames':>7} {'detect':>7} {'estim':>7} {'rmse_m':>8} "
                 f"{'mean_m':>8} {'max_m':>8}")
    for name, r in [*s.per_robot.items(), ("fused", s.fused)]:
        lines.append(f"{name:10} {r.frames:7d} {r.detections:7d} {r.estimates:7d} "
                     f"{_m(r.rmse_m):>8} {_m(r.mean_error_m):>8} {_m(r.max_error_m):>8}")
    if s.pose_sources:
        lines.append("poses corrected (from): " + ", ".join(
            f"{k} {v}" for k, v in s.pose_sources.items()))
    for robot, b in (s.beliefs or {}).items():
        lines.append(f"learnt {robot}: " + describe_belief(b))
    if s.lifted is not None:
        lines.append(f"balls in the air by their blob's width: {s.lifted} of "
                     f"{sum(r.estimates for r in s.per_robot.values())} estimates")
    if s.skipped:
        lines.append("skipped frames: " + ", ".join(f"{k} {v}" for k, v in s.skipped.items()))
    if s.undecodable_messages:
        lines.append(f"undecodable messages: {s.undecodable_messages}")
    if s.loss is not None:
        lines.extend(s.loss.describe())
    for out in s.outputs:
        lines.append(f"wrote {out}")
    return "\n".join(lines)


def warn(warnings: Sequence[str]) -> None:
    """Each warning as a ``warning:`` line on stderr (also with ``-q``: the summary is what
    ``-q`` drops, never what says the results may be wrong)."""
    for line in warnings:
        print(printable(f"warning: {line}"), file=sys.stderr)


def _serve(args: argparse.Namespace) -> int:
    """``--serve``: start the server, say where to look, replay into it, serve until Ctrl-C."""
    from replay.sinks.rerun.live import ViewerServer

    # bad options, and a path that is no log, are refused before a server starts
    options_from_args(args)
    check_mcap_file(Path(args.log))
    server = ViewerServer(
        bind=args.bind or DEFAULT_BIND,
        web_port=DEFAULT_WEB_PORT if args.port is None else args.port,
        grpc_port=DEFAULT_GRPC_PORT if args.grpc_port is None else args.grpc_port)
    with server:
        print(f"{PROG}: serving the Rerun web viewer at {server.web_url} (open it in a "
              "browser; Ctrl-C stops)", file=sys.stderr, flush=True)
        summary = replay(args.log, options_from_args(args, server.grpc_url))
        warn(summary.warnings)
        echo(args, format_summary(summary))
        print(f"{PROG}: replay done; still serving at {server.web_url} until Ctrl-C",
              file=sys.stderr, flush=True)
        stopped = server.serve_forever()
    print(f"{PROG}: stopped serving", file=sys.stderr)
    return EXIT_INTERRUPTED if stopped else 0  # Ctrl-C is how serving ends: 130, as listed


def _main(argv: Sequence[str] | None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if "--help-all" in argv:
        build_parser().print_help()
        return 0
    args = build_parser(all_options=False).parse_intermixed_args(argv)
    live = [f for f, v in (("--bind", args.bind), ("--port", args.port),
                           ("--grpc-port", args.grpc_port)) if v is not None]
    if live and not args.serve:
        raise UsageError(f"{', '.join(live)} only go with --serve")
    keep_image_buffers()  # freed decoded images stay mapped: no page faults refilling them
    if is_batch(args):
        return run_batch(args, options_from_args)
    check_single(args)
    args.log = args.log[0]
    if args.serve:
        return _serve(args)
    summary = replay(args.log, options_from_args(args))
    warn(summary.warnings)
    echo(args, format_summary(summary))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    return run_main(PROG, _main, argv)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
