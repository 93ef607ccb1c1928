"""How far a replay's centroids sit from the true ball, in pixels, on a simulated log.

    python scripts/centroid_offsets.py yellow.mcap yellow.json

The truth's boxes are those ``dsp-calibrate --ball-from LOG.mcap`` draws (the ball's
outline through the camera model, at the robot's true pose; hidden and cut balls left
out); their centres, moved into the replay's pixel convention, are compared with the
detections of a results file (``dsp-replay LOG --out RESULTS.json``) of the same log.
Prints the images compared and the median offset along u and v and its length; a
detection more than 10 px from the truth (another object) is counted apart.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
from collections.abc import Sequence
from pathlib import Path

from dsp.cli import run_main
from dsp.errors import InputError
from replay.calibrate.ball_log import frames_from_log


def _main(argv: Sequence[str] | None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("log", type=Path, help="a simulated log (dsp-record)")
    parser.add_argument("results", type=Path, help="its replay's results file (--out)")
    args = parser.parse_args(argv)
    frames, _ = frames_from_log(args.log, None)
    truth = {(m.robot, m.stamp_ns): ((b[0][0] + b[0][2]) / 2 - 0.5, (b[0][1] + b[0][3]) / 2 - 0.5)
             for m, b in zip(frames.images, frames.boxes, strict=True) if b}
    du, dv, far = [], [], 0
    try:
        results = json.loads(args.results.read_text(encoding="utf-8"))["frames"]
    except (ValueError, KeyError, TypeError) as err:
        raise InputError(f"{args.results}: not a dsp-replay results file ({err})") from err
    for frame in results:
        det, key = frame.get("detection"), (frame["robot"], frame["stamp_ns"])
        if det is None or key not in truth:
            continue
        u, v = det["cx_px"] - truth[key][0], det["cy_px"] - truth[key][1]
        if math.hypot(u, v) > 10.0:
            far += 1
            continue
        du.append(u)
        dv.append(v)
    if not du:
        raise InputError(f"{args.results}: no detection of {args.log}'s ball to compare")
    length = statistics.median(math.hypot(u, v) for u, v in zip(du, dv, strict=True))
    print(f"{len(du)} images: median offset u {statistics.median(du):+.2f} px, "
          f"v {statistics.median(dv):+.2f} px, length {length:.2f} px; {far} farther than 10 px")
    return 0


if __name__ == "__main__":
    sys.exit(run_main("centroid_offsets.py", _main))
