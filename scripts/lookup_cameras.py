"""Describe a log's cameras as a team's range table would: a lookup calibration per robot, no
camera model (no height, no lens): the camera file a team writes from its own calibration.

    python scripts/lookup_cameras.py LOG OUT.yaml [--step-px 1]

Each robot's entry keeps its image size, centre and usable radius from the log (its
``dsp.cameras`` metadata, or ``--cameras FILE``), and its calibration becomes a ``lookup``
table: the range the robot's own calibration gives at every ``--step-px`` pixels of radius,
out to the usable radius (where the range stops growing the table ends). Replaying the log
with ``dsp-replay LOG --cameras OUT.yaml`` then places each ball as before, but no part of
the pipeline can use a camera model: no line fit, no rays for the 3-D track. So a recorded
match (with its truth and its boxes of the ball's colour) shows what a team's log of the same
play would give, e.g. for a rule meant for cameras without a model.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

from dsp.camera_file import camera_file_text  # noqa: E402
from dsp.cli import run_main  # noqa: E402
from dsp.errors import UsageError  # noqa: E402
from replay.cameras import Cameras, cameras_for  # noqa: E402
from replay.log import LogReader  # noqa: E402


def lookup_entries(cameras: Cameras, robots: Sequence[str], *,
                   step_px: float = 1.0) -> dict[str, dict[str, object]]:
    """Robot -> its camera file entry: the image, centre and usable radius of its
    description, and a lookup table of its calibration's range every ``step_px`` pixels."""
    entries: dict[str, dict[str, object]] = {}
    for robot in robots:
        spec, calibration = cameras.specs[robot], cameras.calibrations[robot]
        usable = spec.usable_radius_px or 0.5 * min(spec.width_px, spec.height_px)
        r_px: list[float] = []
        d_m: list[float] = []
        for k in range(math.floor(usable / step_px) + 1):
            r = k * step_px
            d = calibration.range_m(r)
            if math.isfinite(d) and d > 0 and (not d_m or d > d_m[-1]):
                r_px.append(round(r, 4))
                d_m.append(round(d, 5))
            elif d_m:
                break  # the range stops growing: the table ends there
        if len(r_px) < 2:
            raise UsageError(f"{robot}: its calibration gives no increasing range out to "
                             f"{usable:g} px; nothing to tabulate")
        entries[robot] = {"model": "lookup", "width_px": spec.width_px,
                          "height_px": spec.height_px, "cu_px": spec.centre_px[0],
                          "cv_px": spec.centre_px[1],
                          "usable_radius_px": round(float(min(usable, r_px[-1])), 2),
                          "calibration": {"model": "lookup", "r_px": r_px, "d_m": d_m}}
    return entries


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    p.add_argument("log", type=Path, help="the MCAP log")
    p.add_argument("out", type=Path, help="the camera file to write (.yaml, .yml or .json)")
    p.add_argument("--cameras", type=Path, metavar="FILE",
                   help="the log's cameras from this file instead of its metadata")
    p.add_argument("--step-px", type=float, default=1.0,
                   help="the table's step in pixels of radius (default 1)")
    args = p.parse_args(argv)
    if not (math.isfinite(args.step_px) and 0.1 <= args.step_px <= 50):
        raise UsageError(f"--step-px {args.step_px:g}: give 0.1 to 50 pixels")
    suffix = args.out.suffix.lower()
    if suffix not in (".yaml", ".yml", ".json"):
        raise UsageError(f"{args.out}: a camera file ends in .yaml, .yml or .json")
    with LogReader(args.log) as reader:
        info = reader.info
        cameras = cameras_for(info.robots, log=str(args.log),
                              metadata=info.cameras.camera_set(),
                              cameras=args.cameras)
    entries = lookup_entries(cameras, info.robots, step_px=args.step_px)
    args.out.write_text(camera_file_text(
        entries, suffix, header=f"Every robot of {args.log.name} as a lookup table alone "
        "(python scripts/lookup_cameras.py): no camera model."), encoding="utf-8")
    print(f"wrote {args.out}: {len(entries)} robots, lookup tables only")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main("lookup_cameras.py", main))
