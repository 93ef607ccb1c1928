"""``python -m replay.evaluate.foreign``: write one foreign log and its camera file (thin CLI).

    python -m replay.evaluate.foreign OUT.mcap --seed N --robots 3 --rate 20 \
        --poses exact|drift --drift 0.05,1.0 --covariance none|honest --duration 10 \
        --image jpeg|raw

Every value is checked before anything is drawn; a bad one is one line and exit 2.
"""

from __future__ import annotations

import argparse
import math
import shlex
import sys
from collections.abc import Sequence
from pathlib import Path

from dsp.cli import Parser, run_main
from dsp.errors import UsageError
from dsp.field import FIELDS
from replay.evaluate.foreign import (
    CAMERA_KINDS,
    COVARIANCES,
    EPOCH_S,
    IMAGE_KINDS,
    POSE_KINDS,
    TRUTH_KINDS,
    ForeignOptions,
    replay_arguments,
    write_camera_file,
    write_foreign_log,
)

__all__ = ["build_parser", "main", "options_from_args"]

PROG = "python -m replay.evaluate.foreign"
MAX_SEED = 2**63 - 1
MAX_ROBOTS = 8
MAX_DURATION_S = 600.0
MIN_RATE_HZ, MAX_RATE_HZ = 1.0, 60.0
MIN_SIZE_PX, MAX_SIZE_PX = 64, 2048


def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog=PROG, allow_abbrev=False,
               description="Write a seeded match log in a team's own layout (no dsp metadata), "
               "drawn without the recorder, and the camera file that describes it exactly.")
    p.add_argument("out", type=Path, metavar="OUT.mcap")
    p.add_argument("--seed", default="0", metavar="N", help="the scene's seed (default 0)")
    p.add_argument("--robots", default="3", metavar="N", help="robots r1..rN (default 3)")
    p.add_argument("--rate", default="20", metavar="HZ",
                   help="camera frames per second per robot, each at its own phase (default 20)")
    p.add_argument("--duration", default="10", metavar="S", help="seconds (default 10)")
    p.add_argument("--poses", default="exact", metavar="exact|drift",
                   help="the poses the robots publish: exact, or drifting (default exact)")
    p.add_argument("--drift", default=None, metavar="M,DEG",
                   help="--poses drift: the bias's stationary sigma in m and deg "
                   "(default 0.05,1.0)")
    p.add_argument("--tau", default=None, metavar="S",
                   help="--poses drift: the bias's time constant (default 3 s)")
    p.add_argument("--covariance", default="none", metavar="none|honest",
                   help="none: geometry_msgs/PoseStamped on /{robot}/pose; honest: "
                   "PoseWithCovarianceStamped on /{robot}/amcl_pose stating the error's sigma")
    p.add_argument("--covariance-scale", default="1", metavar="K",
                   help="state K times the honest sigma (default 1)")
    p.add_argument("--image", default="jpeg", metavar="jpeg|raw",
                   help="CompressedImage JPEG (default) or Image rgb8")
    p.add_argument("--camera", default="own", metavar="own|mirror",
                   help="the mirror's profile: own (default; a lookup table in the camera "
                   "file) or mirror (the project's mirror model, with its height)")
    p.add_argument("--size", default="640", metavar="PX", help="image side (default 640)")
    p.add_argument("--field", default="18x12", metavar="|".join(FIELDS),
                   help="the field drawn (default 18x12)")
    p.add_argument("--name-field", action="store_true",
                   help="the camera file names the field (as a team's may): the default then "
                   "corrects the poses from the field lines where the camera has a model")
    p.add_argument("--truth", default="odometry", metavar="odometry|point|pose",
                   help="/mocap/ball as nav_msgs/Odometry (position and velocity, default), "
                   "PointStamped or PoseStamped")
    p.add_argument("--cameras", type=Path, metavar="FILE",
                   help="the camera file (default: OUT with .cameras.yaml)")
    p.add_argument("--force", action="store_true", help="overwrite existing outputs")
    return p


def _number(flag: str, text: str, low: float, high: float, *, whole: bool = False) -> float:
    kind, span = ("a whole number", f"[{int(low)}, {int(high)}]") if whole else (
        "a number", f"[{low:g}, {high:g}]")
    try:
        value = int(text) if whole else float(text)
    except ValueError:
        raise UsageError(f"{flag} {text!r}: give {kind} in {span}") from None
    if not (math.isfinite(value) and low <= value <= high):
        raise UsageError(f"{flag} {text}: give {kind} in {span}")
    return value


def _choice(flag: str, text: str, choices: Sequence[str]) -> str:
    if text not in choices:
        raise UsageError(f"{flag} {text!r}: give one of {', '.join(choices)}")
    return text


def _drift(text: str) -> tuple[float, float]:
    parts = text.split(",")
    if len(parts) != 2:
        raise UsageError(f"--drift {text!r}: give M,DEG, e.g. 0.05,1.0")
    return (_number("--drift", parts[0], 0.0, 1.0), _number("--drift", parts[1], 0.0, 20.0))


def options_from_args(args: argparse.Namespace) -> ForeignOptions:
    """The options, each value checked (:class:`UsageError`, one line naming it)."""
    poses = _choice("--poses", args.poses, POSE_KINDS)
    for flag, value in (("--drift", args.drift), ("--tau", args.tau)):
        if value is not None and poses != "drift":
            raise UsageError(f"{flag} goes with --poses drift (the poses are {poses})")
    return ForeignOptions(
        seed=int(_number("--seed", args.seed, 0, MAX_SEED, whole=True)),
        robots=int(_number("--robots", args.robots, 1, MAX_ROBOTS, whole=True)),
        rate_hz=_number("--rate", args.rate, MIN_RATE_HZ, MAX_RATE_HZ),
        duration_s=_number("--duration", args.duration, 0.1, MAX_DURATION_S),
        poses=poses,
        drift=_drift(args.drift or "0.05,1.0"),
        tau_s=_number("--tau", args.tau or "3", 0.1, 600.0),
        covariance=_choice("--covariance", args.covariance, COVARIANCES),
        covariance_scale=_number("--covariance-scale", args.covariance_scale, 0.01, 100.0),
        image=_choice("--image", args.image, IMAGE_KINDS),
        camera=_choice("--camera", args.camera, CAMERA_KINDS),
        size_px=int(_number("--size", args.size, MIN_SIZE_PX, MAX_SIZE_PX, whole=True)),
        field=_choice("--field", args.field, tuple(FIELDS)),
        names_field=args.name_field,
        truth=_choice("--truth", args.truth, TRUTH_KINDS),
        epoch_s=EPOCH_S,
    )


def _main(argv: Sequence[str] | None) -> int:
    args = build_parser().parse_args(argv)
    options = options_from_args(args)
    out: Path = args.out
    if out.suffix.lower() != ".mcap":
        raise UsageError(f"{out}: the log's name ends in .mcap")
    cameras: Path = args.cameras or out.with_suffix(".cameras.yaml")
    if cameras.resolve() == out.resolve():
        raise UsageError(f"--cameras {cameras}: is the log itself")
    write_camera_file(cameras, options, force=args.force)
    count = write_foreign_log(out, options, force=args.force)
    print(f"wrote {out} ({count} messages) and {cameras}; replay it with:")
    print("dsp-replay " + shlex.join(replay_arguments(out, cameras, options)))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    return run_main(PROG, _main, argv)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
