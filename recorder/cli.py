"""``dsp-record``: record a scenario of the simulated MSL world to a ROS 2 MCAP log.

Thin: parse arguments, call ``recorder.record.record``; :func:`dsp.cli.run_main` maps known
errors to one line on stderr and an exit code (1 bad input, 2 usage, 3 output exists,
4 renderer, 130 interrupted). Partial logs left beside the output by earlier interrupted or
killed recordings to it are named in a note on stderr before recording starts.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from dsp.atomic import declare_files
from dsp.cli import Parser, add_common_arguments, echo, progress_enabled, run_main
from dsp.realism import REALISM, Realism, realism_preset
from dsp.text import format_bytes, printable
from recorder.field import FIELDS
from recorder.scenarios import SCENARIOS, scenario_from_path

__all__ = ["build_parser", "main"]

PROG = "dsp-record"


def build_parser() -> argparse.ArgumentParser:
    p = Parser(
        prog=PROG,
        allow_abbrev=False,
        description="Record a scenario of the simulated RoboCup MSL world (pybullet) to a "
        "ROS 2 MCAP log: omni images, poses, /tf and ground truth.",
        epilog=f"scenarios: {', '.join(SCENARIOS)}. Without --scenario the file name "
        "names it, e.g. 'dsp-record scenario1.mcap'.",
    )
    p.add_argument("output", type=Path, help="the .mcap log to write")
    p.add_argument("--scenario", metavar="NAME",
                   help=f"one of {', '.join(SCENARIOS)} (default: from the file name)")
    p.add_argument("--seed", type=int, default=0, help="the scenario's seed (default %(default)s)")
    length = p.add_mutually_exclusive_group()
    length.add_argument("--duration", type=float, metavar="S",
                        help="sim seconds (default: 1 s for static scenes, 12 s rolling, "
                        "10 s match)")
    length.add_argument("--frames", type=int, metavar="N", help="camera frames")
    p.add_argument("--rate", type=float, metavar="HZ",
                   help="camera frames per second; poses at twice this "
                   "(default: 5 Hz static, 10 Hz rolling, 20 Hz match)")
    p.add_argument("--image-format", choices=("png", "jpeg"), default="png",
                   help="CompressedImage encoding (default %(default)s)")
    p.add_argument("--jpeg-quality", type=int, default=90, metavar="Q",
                   help="JPEG quality 1-100 (default %(default)s)")
    p.add_argument("--pose-noise", type=float, metavar="M",
                   help="std dev of the believed position noise in metres (default 0)")
    p.add_argument("--yaw-noise", type=float, metavar="DEG",
                   help="std dev of the believed heading noise in degrees (default 0)")
    p.add_argument("--robot-count", type=int, metavar="N",
                   help="how many robots with cameras (random/rolling; default 3)")
    p.add_argument("--field", choices=tuple(FIELDS), default="18x12",
                   help="field size (default %(default)s, the paper's)")
    p.add_argument("--face-px", type=int, default=None, metavar="PX",
                   help="cube-face resolution for rendering (default 1024: sharp at 8 m)")
    _add_match_arguments(p)
    _add_venue_arguments(p)
    add_common_arguments(p, camera="ideal", renderer=True, force=True)
    declare_files(p, outputs=("output",))
    return p


def _add_match_arguments(p: argparse.ArgumentParser) -> None:
    """Match play, timing and the less-than-ideal camera (all off unless given)."""
    g = p.add_argument_group("match play and camera effects (off unless given)")
    g.add_argument("--realism", choices=REALISM, default="none",
                   help="field: a real field's localisation error and camera effects in one "
                   "word (drifting bias 0.05 m / 1 deg, tau 5 s, noise 0.01 m / 0.3 deg, "
                   "exposure 4 ms, image noise 3, gain jitter 0.1, 3 distractors in a "
                   "match); a flag given beside it overrides its value (default none: the "
                   "defaults below)")
    g.add_argument("--camera-phase", choices=("sync", "random"),
                   help="cameras fire together (sync) or each at its own seeded phase "
                   "(random: no two images share a stamp); default random for match, "
                   "sync elsewhere")
    g.add_argument("--pose-rate", type=float, metavar="HZ",
                   help="poses, /tf and truth per second, a whole multiple of --rate "
                   "(default twice --rate; 240 for match)")
    g.add_argument("--pose-bias", type=float, metavar="M",
                   help="std dev of a slowly drifting localisation bias in metres (default 0)")
    g.add_argument("--yaw-bias", type=float, metavar="DEG",
                   help="std dev of a slowly drifting heading bias in degrees (default 0)")
    g.add_argument("--pose-bias-tau", type=float, metavar="S",
                   help="time constant of the drifting bias (default 5 s)")
    g.add_argument("--exposure", type=float, metavar="MS",
                   help="exposure time: motion blur over the physics steps before each "
                   "stamp (default 0)")
    g.add_argument("--image-noise", type=float, metavar="LEVELS",
                   help="std dev of Gaussian pixel noise in grey levels (default 0)")
    g.add_argument("--gain-jitter", type=float, metavar="STD",
                   help="std dev of each camera's wandering log gain, e.g. 0.1 (default 0)")
    g.add_argument("--distractors", type=int, metavar="N",
                   help="boxes of the ball's colour beside the field (match and lobs; "
                   "default 0)")
    g.add_argument("--ball-odometry", action=argparse.BooleanOptionalAction, default=None,
                   help="write the ball's true velocity on /ground_truth/ball/odometry "
                   "(default: on for match)")


def effects(args: argparse.Namespace) -> Realism:
    """The effects: each flag given, else the ``--realism`` preset's (for the scenario the
    output names when ``--scenario`` is not given)."""
    preset = realism_preset(args.realism).for_scenario(
        args.scenario or scenario_from_path(args.output))

    def pick(flag: str, value: float) -> float:
        given = getattr(args, flag)
        return value if given is None else float(given)

    return Realism(
        pose_bias_m=pick("pose_bias", preset.pose_bias_m),
        yaw_bias_deg=pick("yaw_bias", preset.yaw_bias_deg),
        pose_bias_tau_s=pick("pose_bias_tau", preset.pose_bias_tau_s),
        pose_noise_m=pick("pose_noise", preset.pose_noise_m),
        yaw_noise_deg=pick("yaw_noise", preset.yaw_noise_deg),
        exposure_ms=pick("exposure", preset.exposure_ms),
        image_noise=pick("image_noise", preset.image_noise),
        gain_jitter=pick("gain_jitter", preset.gain_jitter),
        distractors=preset.distractors if args.distractors is None else args.distractors)


def _add_venue_arguments(p: argparse.ArgumentParser) -> None:
    """The ball's look, what else wears its colour, the light, lobs (all as before unless
    given)."""
    from recorder.ball import BALL_COLOURS, BALL_PATTERNS

    g = p.add_argument_group("the venue's trouble and lobs (as before unless given)")
    g.add_argument("--ball-colour", choices=tuple(BALL_COLOURS), default="orange",
                   help="the ball's colour (default %(default)s)")
    g.add_argument("--ball-pattern", choices=BALL_PATTERNS, default="plain",
                   help="plain, panels (a football's pentagons and hexagons) or bands, in a "
                   "second tone; the pattern turns as the ball rolls (default %(default)s)")
    g.add_argument("--people", type=int, default=0, metavar="N",
                   help="people in shirts of the ball's colour beside the field (default 0)")
    g.add_argument("--covers", type=int, default=0, metavar="N",
                   help="robots dressed in a skirt of the ball's colour (default 0)")
    g.add_argument("--light-pools", type=int, default=0, metavar="N",
                   help="lamps lighting the field unevenly, each its own brightness and "
                   "colour temperature (default 0: even light)")
    g.add_argument("--lob-fraction", type=float, default=0.0, metavar="F",
                   help="share of the match's kicks that are lobs, 0-1 (default 0; the lobs "
                   "scenario kicks only lobs)")


def _main(argv: Sequence[str] | None) -> int:
    args = build_parser().parse_args(argv)
    from recorder.omni import DEFAULT_FACE_PX
    from recorder.record import RecordOptions, partial_logs, record

    options = RecordOptions(
        scenario=args.scenario,
        seed=args.seed,
        duration_s=args.duration,
        frames=args.frames,
        rate_hz=args.rate,
        camera=args.camera,
        image_format=args.image_format,
        jpeg_quality=args.jpeg_quality,
        robots=args.robot_count,
        field=args.field,
        face_px=DEFAULT_FACE_PX if args.face_px is None else args.face_px,
        renderer=args.renderer,
        force=args.force,
        progress=progress_enabled(args),
        pose_rate_hz=args.pose_rate,
        camera_phase=args.camera_phase,
        ball_odometry=args.ball_odometry,
        ball_colour=args.ball_colour,
        ball_pattern=args.ball_pattern,
        people=args.people,
        covers=args.covers,
        light_pools=args.light_pools,
        lob_fraction=args.lob_fraction,
    ).with_realism(effects(args))
    partials = partial_logs(args.output)
    if partials:
        print(printable(f"{PROG}: note: {_partials_note(partials, args.output)}"),
              file=sys.stderr)
    s = record(args.output, options)
    echo(args,
         f"{s.path}: {s.scenario} seed {s.seed}, {s.frames} frames x {s.robots} robots "
         f"({s.camera}, {s.image_format}) at {s.rate_hz:g} Hz, "
         f"sim {s.sim_duration_ns / 1e9:.2f} s, "
         f"{s.messages} messages, {format_bytes(s.file_size_bytes)}, renderer {s.renderer}, "
         f"wall {s.wall_time_s:.1f} s")
    return 0


NAMED_PARTIALS = 3
"""The partial logs a note names; more are counted."""


def _partials_note(partials: list[Path], output: Path) -> str:
    """One line for the partial logs of earlier recordings to ``output`` (however many)."""
    if len(partials) == 1:
        return (f"{partials[0]} is left from an earlier recording to {output.name} that was "
                f"interrupted or killed (kept; 'dsp-replay --recover {partials[0]}' replays it)")
    names = ", ".join(p.name for p in partials[:NAMED_PARTIALS])
    more = len(partials) - NAMED_PARTIALS
    listed = f"{names} and {more} more" if more > 0 else names
    return (f"{len(partials)} logs are left in {partials[0].parent} from earlier recordings to "
            f"{output.name} that were interrupted or killed: {listed} (kept; 'dsp-replay "
            "--recover FILE' replays one)")


def main(argv: Sequence[str] | None = None) -> int:
    return run_main(PROG, _main, argv)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
